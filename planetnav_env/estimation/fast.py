"""Deprecated: the compiled EKF kernels moved to :mod:`planetnav_env.estimation.ekf_kernels`.

Every name still resolves here, with a :class:`DeprecationWarning` naming the new path.
"""

from planetnav_env._deprecation import moved_names

__getattr__ = moved_names(__name__, "planetnav_env.estimation.ekf_kernels")
