"""Training and evaluation of planetnav agents: the package behind ``python train.py``.

Modules, by what they hold:

- :mod:`planetnav_train.config`: :class:`~planetnav_train.config.TrainConfig` and its ``eval:`` section,
  :func:`~planetnav_train.config.load_config` / :func:`~planetnav_train.config.parse_config`, which
  algorithms a configuration may name (SB3 or RLlib);
- :mod:`planetnav_train.algorithms`: the SB3 constructor arguments from ``hyperparams``;
- :mod:`planetnav_train.envs`: the training VecEnv (:func:`~planetnav_train.envs.make_training_env`);
- :mod:`planetnav_train.training`: SB3 training of a configuration into a run directory;
- :mod:`planetnav_train.evaluate`: held-out evaluation, paired differences, the JSON, the periodic sweep;
- :mod:`planetnav_train.report`: the printed table, markdown, plots, ``report.md``;
- :mod:`planetnav_train.cli`: the commands and options of ``train.py`` (:func:`~planetnav_train.cli.main`).

Importing the package imports none of them (nor torch, SB3 or Ray). Ray training and sweeps
(:mod:`planetnav_rl`) build on this package. The other way, only functions import from
:mod:`planetnav_rl`: the command line hands a run to Ray, the configuration checks RLlib's ``hyperparams``
keys (:mod:`planetnav_rl.hyperparams`, which imports nothing of this package), so no import circle forms.
"""
