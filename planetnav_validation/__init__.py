"""Validation of planetnav: the reproductions of the three source papers, their harnesses, and test oracles.

Not part of the environment: nothing in ``planetnav_env``, ``planetnav_agents``, ``planetnav_train`` or
``planetnav_rl`` imports it; it imports the environment's physics (``tests/project/test_import_graph.py``).

* :mod:`planetnav_validation.reproduce`: ``python -m planetnav_validation.reproduce NAME`` (angular-size,
  optical-pulsar, gnss-magnetometer; ``docs/validation.md``);
* harnesses: :mod:`~planetnav_validation.navigation` (Monte Carlo of the planet-direction EKF on a cruise),
  :mod:`~planetnav_validation.approach_methods` (the patent's optical, pulsar and hybrid filters on the Mars
  approach), with the image-plane measurement (:mod:`~planetnav_validation.image_plane`);
* the GNSS/magnetometer paper's geometry: :mod:`~planetnav_validation.gnss_visibility`,
  :mod:`~planetnav_validation.euler` (3-2-1 angles), :mod:`~planetnav_validation.body_rate` (eq. (3));
* oracles the compiled code is held to: :mod:`~planetnav_validation.numpy_ekf` (the numpy EKF and the
  filterpy adapter), :mod:`~planetnav_validation.numpy_orbit` (the numpy RK4 state transition matrix),
  :mod:`~planetnav_validation.wahba_svd` (Markley's SVD solution, Wahba's loss).
"""
