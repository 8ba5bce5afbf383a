"""Training and evaluation of planetnav agents: the package behind ``python train.py``.

Modules, by what they hold:

- :mod:`planetnav_train.config`: :class:`~planetnav_train.config.TrainConfig` and its ``eval:`` section,
  :func:`~planetnav_train.config.load_config` / :func:`~planetnav_train.config.parse_config`, which
  algorithms a configuration may name (SB3 or RLlib);
- :mod:`planetnav_train.algorithms`: the SB3 constructor arguments from ``hyperparams``;
- the training env: :mod:`~planetnav_train.batch_wrappers` (features and shaping
  over N rows, over the env's decision interface; :mod:`~planetnav_train.moved_options` names the former
  training-side decision keys), :mod:`~planetnav_train.features`, :mod:`~planetnav_train.shaping`,
  :mod:`~planetnav_train.masking`, :mod:`~planetnav_train.vec_training` (the native SB3 ``VecEnv``),
  :mod:`~planetnav_train.sb3_vec` (the SB3 ``VecEnv`` adapter of the vector env),
  :mod:`~planetnav_train.envs` (:func:`~planetnav_train.envs.make_training_env`);
- :mod:`planetnav_train.training`: SB3 training of a configuration into a run directory, with
  :mod:`~planetnav_train.pretrain` (cloning, DAgger);
- learned policies: :mod:`~planetnav_train.sb3` (the SB3 loader and algorithm registry),
  :mod:`~planetnav_train.policy_only` and :mod:`~planetnav_train.export` (policy-only exports),
  :mod:`~planetnav_train.shipped` (the ``suite:<task>`` baselines), :mod:`~planetnav_train.loaders` (their
  registration with ``planetnav_agents.make_agent``);
- :mod:`planetnav_train.evaluate`: held-out evaluation, paired differences, the JSON, the periodic sweep,
  with :mod:`~planetnav_train.stats`;
- :mod:`planetnav_train.report`: the printed table, markdown, plots, ``report.md``;
- :mod:`planetnav_train.suite`: the benchmark suite (a subpackage);
- :mod:`planetnav_train.cli`: the commands and options of ``train.py`` (:func:`~planetnav_train.cli.main`);
- :mod:`planetnav_train.extensions`: what packages built on this one register (RLlib training, the
  ``tune`` command, the suite's Ray grid; :mod:`planetnav_rl` fills it through an entry point).

Importing the package imports none of them (nor torch, SB3 or Ray). This package imports
``planetnav_env`` and ``planetnav_agents`` and never :mod:`planetnav_rl`, which builds on it.
"""
