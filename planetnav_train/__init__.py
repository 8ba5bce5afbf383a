"""Training and evaluation of planetnav agents: the package behind ``python train.py``.

Modules, by what they hold:

- :mod:`planetnav_train.config`: :class:`~planetnav_train.config.TrainConfig` and its ``eval:`` section,
  :func:`~planetnav_train.config.load_config` / :func:`~planetnav_train.config.parse_config`;
- :mod:`planetnav_train.algorithms`: which algorithms train (SB3 or RLlib) and the SB3 constructor
  arguments;
- :mod:`planetnav_train.envs`: the training VecEnv (:func:`~planetnav_train.envs.make_training_env`);
- :mod:`planetnav_train.training`: SB3 training of a configuration into a run directory;
- :mod:`planetnav_train.evaluate`: held-out evaluation, paired differences, the JSON, the periodic sweep;
- :mod:`planetnav_train.report`: the printed table, markdown, plots, ``report.md``;
- :mod:`planetnav_train.cli`: the commands and options of ``train.py`` (:func:`~planetnav_train.cli.main`).

Importing the package imports none of them (nor torch, SB3 or Ray). Ray training and sweeps
(:mod:`planetnav_rl`) build on this package; it imports :mod:`planetnav_rl` only inside the functions that
hand a run to Ray, so the dependency points one way.
"""
