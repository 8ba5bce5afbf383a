"""Ray Tune sweeps over SB3 or RLlib training: ``python train.py tune --config configs/sweep.yaml``.

A sweep YAML names a training configuration (``base``, any ``algo`` that ``train.py train`` takes), the
search ``space`` over its hyper-parameters and seed, and how to search. Each trial trains in
``iterations`` equal chunks of ``n_timesteps``; after each chunk it saves its model and evaluates it with
:func:`planetnav_train.evaluate.evaluate_agent` on held-out seeds, and reports the held-out **mean position
error** (the metric, minimised; never the training return) with the node it ran on. An ASHA scheduler
stops poor trials at its rungs; the search is random (Tune's variant generator) or Optuna (TPE).

Keys of the sweep YAML (unknown keys raise :class:`ConfigError` naming them):

================ =========================================================================================
name             sweep name; the default run directory is ``runs/<name>/``
base             training YAML, relative to the sweep file (e.g. ``smoke.yaml``)
train            mapping merged over ``base`` (e.g. ``n_timesteps``); ``hyperparams``/``env`` merge by key
space            ``{key: {distribution: args}}``; key is ``seed`` or ``hyperparams.NAME``; distributions
                 ``choice: [..]``, ``uniform: [lo, hi]``, ``loguniform: [lo, hi]``, ``randint: [lo, hi)``
num_samples      trials
search           ``random`` (default) or ``optuna``
search_seed      seed of the searcher (default 0): the same YAML proposes the same trials
scheduler        ``{type: asha, grace_period: 1, reduction_factor: 2}`` or ``{type: none}``
iterations       chunks (= reports = ASHA time steps) per trial (default 2)
eval             ``{episodes, seed, episode_steps}`` of the held-out evaluation (default: the base's eval)
cpus_per_trial   CPUs Ray reserves per trial (default 1); RLlib trials sample in the trial's own process
max_failures     retries of a trial whose worker or node died, from its last checkpoint (default 2)
================ =========================================================================================

Outputs in the run directory: ``tune/`` (Tune's experiment: trial checkpoints, the state ``--resume``
continues from), ``results.csv`` (one row per trial: parameters, metric, status, node), ``report.md`` with
``metric_per_trial.png``, and ``best_config.yaml``: the best trial's complete training configuration,
loadable by ``python train.py train --config``.
"""

from __future__ import annotations

import copy
import csv
import dataclasses
import math
import tempfile
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from planetnav_env.config import EnvConfig
from planetnav_env.errors import ConfigError, with_prefix
from planetnav_rl import require_ray
from planetnav_train.algorithms import algo_kwargs, policy_class
from planetnav_train.config import ROOT, TrainConfig, is_rllib_algo, parse_config, read_yaml_mapping
from planetnav_train.envs import make_training_env
from planetnav_train.evaluate import evaluate_agent
from planetnav_train.sb3 import algorithm_class

#: Metrics of :func:`planetnav_train.evaluate.evaluate_agent` a sweep may optimise (all minimised position /
#: velocity errors).
METRICS = ("mean_pos_err_km", "final_pos_err_km", "final_pos_sigma_km", "mean_vel_err_km_s")
DISTRIBUTIONS = ("choice", "uniform", "loguniform", "randint")
EXPERIMENT = "tune"  # the Tune experiment's directory name inside the run directory


@dataclass
class SweepConfig:
    """A validated sweep YAML (see the module docstring for the keys)."""

    name: str
    base: str
    space: dict[str, dict[str, Any]]
    train: dict[str, Any] = field(default_factory=dict)
    metric: str = "mean_pos_err_km"
    num_samples: int = 4
    search: str = "random"
    search_seed: int = 0
    scheduler: dict[str, Any] = field(default_factory=lambda: {"type": "asha"})
    iterations: int = 2
    eval: dict[str, Any] = field(default_factory=dict)
    cpus_per_trial: float = 1.0
    max_failures: int = 2
    #: The base training configuration with ``train`` merged in (a plain mapping); set by :func:`load_sweep`.
    base_config: dict[str, Any] = field(default_factory=dict)


def _merge(base: Mapping[str, Any], over: Mapping[str, Any]) -> dict[str, Any]:
    out = copy.deepcopy(dict(base))
    for key, value in over.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = _merge(out[key], value)
        else:
            out[key] = copy.deepcopy(value)
    return out


def apply_params(base: Mapping[str, Any], params: Mapping[str, Any]) -> dict[str, Any]:
    """The training configuration ``base`` with the sampled ``params`` (``seed``, ``hyperparams.X``) set."""
    cfg = copy.deepcopy(dict(base))
    for key, value in params.items():
        node = cfg
        *parents, leaf = key.split(".")
        for p in parents:
            node = node.setdefault(p, {})
        # Tune hands back numpy scalars for some domains; YAML and SB3 want plain Python numbers.
        node[leaf] = value.item() if hasattr(value, "item") else value
    return cfg


def _representative(dist: str, args: Any) -> Any:
    """A value of the distribution, used to validate a key before any trial runs."""
    return args[0] if dist == "choice" else (int(args[0]) if dist == "randint" else float(args[0]))


def _check_space(space: Any, where: str) -> dict[str, dict[str, Any]]:
    if not isinstance(space, Mapping) or not space:
        raise ConfigError(f"{where}: 'space' must be a non-empty mapping of key -> {{distribution: args}}")
    out = {}
    for key, spec in space.items():
        if not isinstance(spec, Mapping) or len(spec) != 1:
            raise ConfigError(f"{where}: space.{key} must be one {{distribution: args}}, got {spec!r}")
        ((dist, args),) = spec.items()
        if dist not in DISTRIBUTIONS:
            raise ConfigError(
                f"{where}: space.{key}: distribution {dist!r} is not one of {list(DISTRIBUTIONS)}"
            )
        if not isinstance(args, list) or not args or (dist != "choice" and len(args) != 2):
            raise ConfigError(
                f"{where}: space.{key}: {dist} takes a list ([lo, hi] or choices), got {args!r}"
            )
        if key != "seed" and not key.startswith("hyperparams."):
            raise ConfigError(
                f"{where}: search space key {key!r} is not a hyperparameter: use 'seed' or 'hyperparams.NAME'"
            )
        out[str(key)] = {dist: list(args)}
    return out


def load_sweep(path: str | Path) -> SweepConfig:
    """Read and validate a sweep YAML, including its base training configuration and every search-space
    key (each is set to a representative value and the result validated like ``train.py train`` would),
    so that a bad algo or key fails here, before Ray starts."""
    path = Path(path)
    data = read_yaml_mapping(path, "sweep configuration file")
    known = {f.name for f in dataclasses.fields(SweepConfig)} - {"base_config"}
    unknown = sorted(set(data) - known)
    if unknown:
        raise ConfigError(f"{path}: unknown key(s) {unknown}; known keys: {sorted(known)}")
    if "base" not in data or "space" not in data:
        raise ConfigError(f"{path}: a sweep needs 'base' (a training YAML) and 'space'")
    data = dict(data)
    data.setdefault("name", path.stem)
    sc = SweepConfig(**data)
    sc.space = _check_space(sc.space, str(path))
    if sc.metric not in METRICS:
        raise ConfigError(f"{path}: metric {sc.metric!r} is not one of {list(METRICS)}")
    if sc.search not in ("random", "optuna"):
        raise ConfigError(f"{path}: search {sc.search!r} is not one of ['random', 'optuna']")
    stype = (sc.scheduler or {}).get("type", "asha")
    if stype not in ("asha", "none"):
        raise ConfigError(f"{path}: scheduler.type {stype!r} is not one of ['asha', 'none']")
    for key in ("num_samples", "iterations", "max_failures"):
        value = getattr(sc, key)
        if (
            not isinstance(value, int)
            or isinstance(value, bool)
            or value < (0 if key == "max_failures" else 1)
        ):
            raise ConfigError(f"{path}: {key} must be a positive integer, got {value!r}")
    base_path = (path.parent / sc.base) if not Path(sc.base).is_absolute() else Path(sc.base)
    if not base_path.is_file():
        raise ConfigError(f"{path}: base training configuration {sc.base!r} not found at {base_path}")
    base = dict(read_yaml_mapping(base_path, "base training configuration"))
    base.setdefault("name", sc.name)
    sc.base_config = _merge(base, sc.train or {})
    try:
        tc = parse_config(sc.base_config)
    except ConfigError as exc:
        raise with_prefix(exc, f"{path}: base {sc.base}") from None
    sample = {k: _representative(*next(iter(v.items()))) for k, v in sc.space.items()}
    try:
        parse_config(apply_params(sc.base_config, sample))
    except ConfigError as exc:
        raise with_prefix(exc, f"{path}: search space key(s) {sorted(sample)} for algo {tc.algo!r}") from None
    if tc.n_timesteps < sc.iterations:
        raise ConfigError(f"{path}: n_timesteps {tc.n_timesteps} is less than iterations {sc.iterations}")
    return sc


def param_space(sc: SweepConfig) -> dict[str, Any]:
    """Tune's search space: flat dotted keys (``hyperparams.lr``) -> ``ray.tune`` domains."""
    from ray import tune

    out = {}
    for key, spec in sc.space.items():
        ((dist, args),) = spec.items()
        out[key] = tune.choice(args) if dist == "choice" else getattr(tune, dist)(*args)
    return out


# ---------------------------------------------------------------------------------------------------------
# The trial
# ---------------------------------------------------------------------------------------------------------


class _SB3Learner:
    """An SB3 model trained chunk by chunk (``learn(reset_num_timesteps=False)`` continues the rollout)."""

    def __init__(self, tc: TrainConfig, restore: Path | None) -> None:
        import torch

        torch.set_num_threads(tc.torch_threads)
        self.venv = make_training_env(tc, None)
        cls = algorithm_class(tc.algo)
        if restore is not None:
            self.model = cls.load(restore / "model.zip", env=self.venv, device="cpu")
        else:
            policy = policy_class(tc)
            self.model = cls(policy, self.venv, seed=tc.seed, device="cpu", verbose=0, **algo_kwargs(tc))

    @property
    def timesteps(self) -> int:
        return int(self.model.num_timesteps)

    def learn_until(self, total: int) -> None:
        if total > self.timesteps:
            self.model.learn(total_timesteps=total - self.timesteps, reset_num_timesteps=False)

    def save(self, directory: Path) -> Path:
        self.model.save(directory / "model.zip")
        return directory / "model.zip"

    def close(self) -> None:
        self.venv.close()


class _RLlibLearner:
    """An RLlib PPO trained iteration by iteration; samples in the trial's own process (no env runner
    actors), so a trial needs exactly the CPUs Tune reserved for it."""

    def __init__(self, tc: TrainConfig, restore: Path | None) -> None:
        from planetnav_rl.rllib import build_algorithm

        self.algo = build_algorithm(tc, num_env_runners=0)
        self._steps = 0
        if restore is not None:
            self.algo.restore_from_path(str(restore / "checkpoint"))
            self._steps = int((restore / "timesteps.txt").read_text())

    @property
    def timesteps(self) -> int:
        return self._steps

    def learn_until(self, total: int) -> None:
        from planetnav_rl.rllib import iteration_summary

        while self._steps < total:
            self._steps = int(iteration_summary(self.algo.train())["timesteps"])

    def save(self, directory: Path) -> Path:
        self.algo.save_to_path(str(directory / "checkpoint"))
        (directory / "timesteps.txt").write_text(str(self._steps))
        return directory / "checkpoint"

    def close(self) -> None:
        self.algo.stop()


def run_trial(
    params: dict[str, Any],
    base: dict[str, Any],
    settings: dict[str, Any],
    report: Callable[[dict[str, Any]], None] | None = None,
) -> None:
    """One Tune trial: train ``base`` with ``params`` in ``settings["iterations"]`` chunks, evaluating on
    held-out seeds after each and reporting the metrics, the node, and a checkpoint to resume from.

    ``report``: where the metrics go instead of ``tune.report`` (then no checkpoint is read or written):
    runs the same trial outside a sweep, e.g. to check that it is reproducible.
    """
    from ray import tune

    from planetnav_rl.cluster import node_label

    cfg = apply_params(base, params)
    tc = parse_config(cfg)
    ev = {**dataclasses.asdict(tc.eval), **settings.get("eval", {})}
    env_cfg = tc.env_config()
    if ev.get("episode_steps"):
        env_cfg = EnvConfig.from_dict(env_cfg.to_dict(), episode_steps=ev["episode_steps"])
    node = node_label()
    checkpoint = tune.get_checkpoint() if report is None else None
    start = 0
    with tempfile.TemporaryDirectory() as restore_dir:
        restore = None
        if checkpoint is not None:  # a retry after a node failure, or --resume: continue from the last chunk
            restore = Path(checkpoint.to_directory(restore_dir))
            start = int((restore / "iteration.txt").read_text())
        learner = (_RLlibLearner if is_rllib_algo(tc.algo) else _SB3Learner)(tc, restore)
    iterations = int(settings["iterations"])
    t0 = time.perf_counter()
    for it in range(start, iterations):
        learner.learn_until(math.ceil(tc.n_timesteps * (it + 1) / iterations))
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp)
            model_path = learner.save(out)
            (out / "iteration.txt").write_text(str(it + 1))
            with open(out / "config.yaml", "w") as fh:  # the trial's own training config
                yaml.safe_dump(tc.to_dict(), fh, sort_keys=False)
            result = evaluate_agent(
                str(model_path), env_cfg, int(ev["episodes"]), int(ev["seed"]), progress=False
            )
            metrics = {
                **{k: result.metrics[k] for k in METRICS},
                "timesteps": learner.timesteps,
                "train_seconds": time.perf_counter() - t0,
                **node,
            }
            if report is None:
                tune.report(metrics, checkpoint=tune.Checkpoint.from_directory(tmp))
            else:
                report(metrics)
    learner.close()


# ---------------------------------------------------------------------------------------------------------
# Driver
# ---------------------------------------------------------------------------------------------------------


def _scheduler(sc: SweepConfig) -> Any:
    opts = dict(sc.scheduler or {})
    if opts.pop("type", "asha") == "none":
        return None
    from ray.tune.schedulers import ASHAScheduler

    return ASHAScheduler(
        time_attr="training_iteration",
        max_t=sc.iterations,
        grace_period=int(opts.pop("grace_period", 1)),
        reduction_factor=float(opts.pop("reduction_factor", 2)),
    )


def _searcher(sc: SweepConfig) -> Any:
    if sc.search == "optuna":
        from ray.tune.search.optuna import OptunaSearch

        return OptunaSearch(seed=sc.search_seed)
    from ray.tune.search import BasicVariantGenerator

    return BasicVariantGenerator(random_state=sc.search_seed)


def _trainable(sc: SweepConfig) -> Any:
    from ray import tune

    settings = {"iterations": sc.iterations, "eval": dict(sc.eval or {})}
    fn = tune.with_parameters(run_trial, base=sc.base_config, settings=settings)
    return tune.with_resources(fn, {"cpu": sc.cpus_per_trial})


def run_sweep(
    sc: SweepConfig, run_dir: Path, resume: bool = False, callbacks: list[Any] | None = None
) -> dict[str, Any]:
    """Run (or with ``resume`` continue) the sweep into ``run_dir``; Ray must be initialised. Returns the
    summary that :func:`write_outputs` wrote (rows, best row, file paths). ``callbacks``: extra
    ``ray.tune.Callback`` objects (tests use one to remove a node mid-sweep)."""
    from ray import tune

    run_dir = Path(run_dir).resolve()
    exp_dir = run_dir / EXPERIMENT
    if resume:
        if not tune.Tuner.can_restore(str(exp_dir)):
            raise ConfigError(f"--resume: no interrupted sweep to continue in {exp_dir}")
        tuner = tune.Tuner.restore(str(exp_dir), trainable=_trainable(sc), resume_errored=True)
    else:
        if exp_dir.exists():
            raise ConfigError(f"{exp_dir} already holds a sweep: pass --resume, or another --run-dir")
        run_dir.mkdir(parents=True, exist_ok=True)
        tuner = tune.Tuner(
            _trainable(sc),
            param_space=param_space(sc),
            tune_config=tune.TuneConfig(
                metric=sc.metric,
                mode="min",
                num_samples=sc.num_samples,
                search_alg=_searcher(sc),
                scheduler=_scheduler(sc),
            ),
            run_config=tune.RunConfig(
                name=EXPERIMENT,
                storage_path=str(run_dir),
                failure_config=tune.FailureConfig(max_failures=sc.max_failures),
                checkpoint_config=tune.CheckpointConfig(num_to_keep=1),
                callbacks=callbacks,
                verbose=1,
            ),
        )
    t0 = time.perf_counter()
    grid = tuner.fit()
    return write_outputs(sc, run_dir, grid, time.perf_counter() - t0)


def _rows(sc: SweepConfig, grid: Any) -> list[dict[str, Any]]:
    rows = []
    for i in range(len(grid)):
        r = grid[i]
        m = r.metrics or {}
        cfg = r.config or {}
        row: dict[str, Any] = {"trial": m.get("trial_id") or Path(r.path).name}
        row["status"] = "ERROR" if r.error else "TERMINATED"
        if not r.error and int(m.get("training_iteration", 0)) < sc.iterations:
            row["status"] = "STOPPED"  # by the scheduler (ASHA) at a rung, not an error
        for key in sc.space:
            row[key] = cfg.get(key)
        row[sc.metric] = m.get(sc.metric)
        row["iterations"] = m.get("training_iteration", 0)
        row["timesteps"] = m.get("timesteps")
        row["seconds"] = m.get("time_total_s")  # the trial's own run time (all its chunks and evaluations)
        row["node_id"] = (m.get("node_id") or "")[:12]
        row["node_ip"] = m.get("node_ip", "")
        row["hostname"] = m.get("hostname", "")
        # Every node the trial reported from, in order: more than one when it was retried after a failure.
        hist = r.metrics_dataframe
        seen: list[str] = []
        if hist is not None and "node_id" in getattr(hist, "columns", ()):
            for n in hist["node_id"].dropna():
                if str(n)[:12] not in seen:
                    seen.append(str(n)[:12])
        row["nodes_seen"] = " ".join(seen) or row["node_id"]
        row["error"] = (str(r.error).strip().splitlines() or [""])[0][:160] if r.error else ""
        row["_path"] = r.path
        row["_history"] = r.metrics_dataframe
        rows.append(row)
    return rows


def write_outputs(sc: SweepConfig, run_dir: Path, grid: Any, seconds: float) -> dict[str, Any]:
    """``results.csv``, ``report.md`` + ``metric_per_trial.png`` and ``best_config.yaml`` in ``run_dir``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = _rows(sc, grid)
    cols = [k for k in rows[0] if not k.startswith("_")] if rows else []
    with open(run_dir / "results.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=cols, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    scored = [r for r in rows if isinstance(r.get(sc.metric), float) and not math.isnan(r[sc.metric])]
    best = min(scored, key=lambda r: r[sc.metric]) if scored else None
    if best is not None:
        params = {k: best[k] for k in sc.space}
        best_cfg = apply_params(sc.base_config, params)
        best_cfg["name"] = f"{sc.name}_best"
        with open(run_dir / "best_config.yaml", "w") as fh:
            fh.write(
                f"# Best trial {best['trial']} of sweep {sc.name}: {sc.metric} = {best[sc.metric]:.1f}\n"
            )
            fh.write("# python train.py train --config this-file\n")
            yaml.safe_dump(best_cfg, fh, sort_keys=False)
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for r in rows:
        hist = r["_history"]
        if hist is not None and sc.metric in getattr(hist, "columns", ()):
            ax.plot(
                hist["training_iteration"], hist[sc.metric], "o-", label=f"{r['trial']} ({r['node_id'][:6]})"
            )
    ax.set_xlabel("training iteration (chunk of n_timesteps / iterations)")
    ax.set_ylabel(f"{sc.metric} (held-out)")
    ax.set_yscale("log")
    ax.grid(True, which="both", alpha=0.3)
    if rows:
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(run_dir / "metric_per_trial.png", dpi=110)
    plt.close(fig)
    nodes = sorted({(r["node_id"], r["node_ip"], r["hostname"]) for r in rows if r["node_id"]})
    all_seen = {n for r in rows for n in r["nodes_seen"].split()}
    lines = [
        f"# Sweep `{sc.name}`",
        "",
        f"{len(rows)} trials of `{sc.base}` ({sc.base_config.get('algo')}), search {sc.search}, scheduler "
        f"{(sc.scheduler or {}).get('type', 'asha')}, {sc.iterations} iterations per trial; metric "
        f"`{sc.metric}` on held-out seeds (minimised), wall time {seconds:.0f} s on {len(all_seen)} "
        "node(s). `node_id`: where the trial finished; `nodes_seen`: every node it reported from (two "
        "after a retry).",
        "",
        "| " + " | ".join(cols) + " |",
        "|" + "|".join("---" for _ in cols) + "|",
    ]
    for r in rows:
        cells = [f"{v:.4g}" if isinstance(v, float) else str(v) for v in (r[c] for c in cols)]
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", "Nodes: " + ", ".join(f"`{n[0]}` ({n[1]}, {n[2]})" for n in nodes), ""]
    if best is not None:
        lines += [
            f"Best: trial `{best['trial']}`, {sc.metric} = {best[sc.metric]:.1f}: `best_config.yaml`.",
            "",
        ]
    lines += ["![metric per trial](metric_per_trial.png)", ""]
    (run_dir / "report.md").write_text("\n".join(lines))
    return {
        "rows": [{k: v for k, v in r.items() if not k.startswith("_")} for r in rows],
        "best": None if best is None else {k: v for k, v in best.items() if not k.startswith("_")},
        "seconds": seconds,
        "results_csv": run_dir / "results.csv",
        "report": run_dir / "report.md",
        "best_config": (run_dir / "best_config.yaml") if best is not None else None,
    }


def cmd_tune(args: Any) -> int:
    """``train.py tune``: validate the sweep and the address, start or join Ray, run, write the outputs."""
    require_ray("train.py tune")
    from planetnav_rl.cluster import check_address, init_ray, shutdown_ray

    sc = load_sweep(args.config)
    if args.address:
        check_address(args.address)  # before anything else starts
    run_dir = Path(args.run_dir) if args.run_dir else ROOT / "runs" / sc.name
    info = init_ray(args.address, num_cpus=getattr(args, "num_cpus", None))
    try:
        summary = run_sweep(sc, run_dir, resume=bool(args.resume))
    finally:
        shutdown_ray(info)
    for row in summary["rows"]:
        print({k: row[k] for k in ("trial", "status", sc.metric, "node_id", "node_ip")})
    print(f"report: {summary['report']}\nbest config: {summary['best_config']}")
    return 0


__all__ = [
    "METRICS",
    "SweepConfig",
    "apply_params",
    "cmd_tune",
    "load_sweep",
    "param_space",
    "run_sweep",
    "run_trial",
    "write_outputs",
]
