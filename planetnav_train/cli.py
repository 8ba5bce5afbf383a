"""Train Stable-Baselines3 agents on planetnav and compare them with the rule-based agents.

Usage::

    python train.py                                   # = train --config configs/cruise_ppo.yaml (~10 min)
    python train.py train --config configs/X.yaml [--run-dir DIR] [--timesteps N] [--no-eval]
    python train.py evaluate --agent NAME|PATH --episodes N --seed S --json out.json [--config X.yaml]
    python train.py compare --agents planner greedy periodic baseline random idle [PATH ...] --episodes N \\
        [--json J] [--report DIR] [--reference greedy]
    python train.py train --config configs/rllib_ppo.yaml [--address HOST:PORT]   # RLlib, needs [ray]
    python train.py tune --config configs/sweep.yaml [--address HOST:PORT] [--resume]  # Ray Tune sweep
    python train.py suite --tasks ... --algos ... --seeds ... [--resume]      # benchmark suite, docs/suite.md
    python train.py suite-publish --out runs/suite [--publish-json docs/benchmark.json] \\
        [--readme README.md] [--baselines planetnav_train/baselines]   # publish results; agents suite:<task>
    python train.py suite-references --tasks ... [--agents random ...]   # reference values, cached in OUT
    python train.py suite-restore --from docs/benchmark.json --out runs/suite   # records back from a JSON
    python train.py suite-rerun CELL_KEY ... [--published runs/suite]     # re-run recorded cells, compare
    python train.py suite-sizes [--tasks ...] [--algos ...] [--no-export]  # model/export bytes (< 1 MB ships)

A training run writes ``runs/<name>/``: ``model.zip``, ``config.yaml`` (the resolved configuration; the SB3
loader reads ``algo`` from it), ``tb/`` (TensorBoard), ``monitor/`` (episode CSVs), then, unless
``--no-eval``, ``eval.json``, ``report.md`` and the plots ``pos_err.png``, ``pos_sigma.png``,
``training.png``. Configuration keys: ``configs/README.md``. Agents evaluate on 20 held-out seeds (default
10_000 onwards; training environments use the config's ``seed`` onwards, far below), every agent on the
same seeds; each mean comes with a 95 % t-interval and the paired difference from a reference agent
(``greedy``) on the same seeds (:mod:`planetnav_train.stats`). Agents that cannot act in the environment's
action mode (``idle`` outside ``target`` mode, a model trained for other spaces) are skipped with a note.
``algo: rllib_ppo`` trains with RLlib instead (``planetnav_rl/rllib.py``, registered through
:mod:`planetnav_train.extensions`; the run directory then holds ``checkpoint/`` in place of ``model.zip``,
and ``evaluate``/``compare`` take it as an agent like a model path). Sweeps: ``planetnav_rl/tune.py``
(the ``tune`` command, registered the same way), docs/scaling.md.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from planetnav_agents import strip_sampled
from planetnav_agents.loaders import config_path as model_config_path
from planetnav_env.config import NOISE_STREAMS, EnvConfig
from planetnav_env.errors import ConfigError
from planetnav_train import extensions
from planetnav_train.config import (
    DEFAULT_CONFIG,
    EVAL_SEED,
    REFERENCE,
    ROOT,
    EvalSettings,
    is_rllib_algo,
    load_config,
    parse_config,
)
from planetnav_train.evaluate import (
    compare_agents,
    evaluate_agent,
    evaluation_env,
    results_json,
)
from planetnav_train.provenance import provenance
from planetnav_train.report import print_table, write_report
from planetnav_train.shipped import is_shipped_spec, shipped_model, task_of
from planetnav_train.training import train


def eval_env_config(args: argparse.Namespace, specs: Sequence[str]) -> tuple[EnvConfig, EvalSettings]:
    """The env of ``--config``, else of the first model run directory's ``config.yaml`` or shipped
    baseline's task (``suite:<task>``), else defaults."""
    if args.config:
        tc = load_config(args.config)
    else:
        tc = parse_config({})
        for s in specs:
            if is_shipped_spec(strip_sampled(s)):  # a shipped baseline: its task's registered env
                tc = parse_config({"env_id": shipped_model(task_of(strip_sampled(s)))[1]["env_id"]})
                break
            # a saved model's run config.yaml, as the loader of its format finds it (SB3, RLlib)
            sidecar = model_config_path(strip_sampled(s))
            if sidecar is not None and sidecar.is_file():
                tc = load_config(sidecar)
                break
    steps = args.episode_steps or tc.eval.episode_steps
    noise = args.noise_streams or tc.eval.noise_streams
    return evaluation_env(tc.env_config(), steps, noise), tc.eval


def _train_on_device(args: argparse.Namespace) -> int:
    """``train --device cuda``: the device PPO (baselines/ppo_device.py) on the config's ``env_id`` with its
    seed and ``n_timesteps`` (decisions), the environment, rollout and update on the GPU; a clear error
    where there is no GPU or numba-cuda."""
    from planetnav_env.device.vector_env import cuda_unavailable_reason

    if not args.device.startswith("cuda"):
        raise ConfigError(f"--device must be cpu, cuda or cuda:K, got {args.device!r}")
    why = cuda_unavailable_reason()
    if why is not None:
        raise ConfigError(
            f'--device {args.device}: {why}; install with pip install -e ".[gpu]" on a GPU machine'
        )
    if args.resume or args.address:
        raise ConfigError("--device cuda takes neither --resume nor --address")
    tc = load_config(args.config or DEFAULT_CONFIG)
    if not tc.env_id:
        raise ConfigError("--device cuda trains a registered id: the config needs env_id")
    import runpy

    ppo = runpy.run_path(str(ROOT / "baselines" / "ppo_device.py"))  # a script of the repository
    seed = args.seed if args.seed is not None else tc.seed
    argv = ["--device", args.device, "--env-id", tc.env_id, "--seed", str(seed),
            "--total-timesteps", str(args.timesteps or tc.n_timesteps)]  # fmt: skip
    if args.no_eval:
        argv += ["--eval-episodes", "0"]
    if args.run_dir:
        Path(args.run_dir).mkdir(parents=True, exist_ok=True)
        argv += ["--save-model", str(Path(args.run_dir) / "ppo_device.pt")]
    ppo["main"](argv)
    return 0


def cmd_train(args: argparse.Namespace) -> int:
    """``train``: train a configuration (SB3 or RLlib), then evaluate it with the rule-based agents and write
    the report (unless ``--no-eval``)."""
    if getattr(args, "device", "cpu") != "cpu":
        return _train_on_device(args)
    if args.resume:
        # The run's own config.yaml, as it was written when it started: nothing else may change.
        given = [
            f"--{k.replace('_', '-')}" for k in ("config", "run_dir", "timesteps", "seed") if getattr(args, k)
        ]
        if given:
            raise ConfigError(f"--resume RUN_DIR takes the run's own config.yaml; drop {' '.join(given)}")
        run_dir = Path(args.resume)
        if not (run_dir / "config.yaml").is_file():
            raise ConfigError(f"--resume {run_dir}: no run there (its config.yaml is missing)")
        tc = load_config(run_dir / "config.yaml")
    else:
        tc = load_config(args.config or DEFAULT_CONFIG)
        if args.timesteps:
            tc.n_timesteps = args.timesteps
        if args.seed is not None:
            if args.seed < 0:
                raise ConfigError(f"--seed must be >= 0, got {args.seed}")
            tc.seed = args.seed
        run_dir = Path(args.run_dir) if args.run_dir else ROOT / "runs" / tc.name
    progress = not args.no_progress
    print(f"training {tc.algo.upper()} for {tc.n_timesteps} steps on {tc.n_envs} envs -> {run_dir}")
    resume = bool(args.resume)
    if is_rllib_algo(tc.algo):
        trainer = extensions.trainer(tc.algo)  # registered by planetnav_rl
        model_path, stats = trainer.train(tc, run_dir, address=args.address, progress=progress, resume=resume)
    elif args.address:
        raise ConfigError(f"--address {args.address!r}: only RLlib configs (algo: rllib_ppo) train on Ray")
    else:
        model_path, stats = train(tc, run_dir, progress=progress, resume=resume)
    print(
        f"trained {stats['timesteps']} decisions = {stats.get('env_steps', stats['timesteps'])} env steps"
        + (f" + the teacher's {stats['teacher_env_steps']}" if stats.get("teacher_env_steps") else "")
        + f" in {stats['seconds']:.0f} s ({stats['steps_per_s']:.0f} env steps/s)"
    )
    if args.no_eval:
        return 0
    env_cfg = evaluation_env(tc.env_config(), tc.eval.episode_steps, tc.eval.noise_streams)
    # The trained policy twice: its argmax (the usual deterministic evaluation) and its sampled actions,
    # which on this problem can differ a lot (an argmax can collapse to one action).
    specs = [str(model_path), f"{model_path}@sampled", *tc.eval.agents]
    t0 = time.perf_counter()
    results = compare_agents(specs, env_cfg, tc.eval.episodes, tc.eval.seed, progress, tc.eval.reference)
    stats["eval_seconds"] = time.perf_counter() - t0
    print_table(results)
    print(
        f"wall time: training {stats['seconds']:.0f} s + evaluation {stats['eval_seconds']:.0f} s = "
        f"{(stats['seconds'] + stats['eval_seconds']) / 60:.1f} min"
    )
    report = write_report(run_dir, results, env_cfg, f"Run `{tc.name}`", stats, tc,
                          wall_s=stats["seconds"] + stats["eval_seconds"])  # fmt: skip
    print(f"report: {report}")
    return 0


def write_json(path: str, data: Any) -> None:
    """``data`` as indented JSON at ``path`` (the ``--json`` option of the commands), folders created."""
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    Path(path).write_text(json.dumps(data, indent=2))


def cmd_evaluate(args: argparse.Namespace) -> int:
    """``evaluate``: one agent on held-out seeds; prints its row and optionally writes the JSON."""
    env_cfg, ev = eval_env_config(args, [args.agent])
    episodes = args.episodes or ev.episodes
    seed = ev.seed if args.seed is None else args.seed
    t0 = time.perf_counter()
    result = evaluate_agent(args.agent, env_cfg, episodes, seed, progress=not args.no_progress)
    wall_s = time.perf_counter() - t0
    print_table([result])
    if args.json:
        write_json(args.json, {**results_json([result]), "provenance": provenance(wall_s=wall_s)})
    return 0


def cmd_compare(args: argparse.Namespace) -> int:
    """``compare``: several agents on the same seeds in one table, with the JSON and the report on request."""
    env_cfg, ev = eval_env_config(args, args.agents or [])
    # --agents, else the config's eval.agents (the defaults without a config)
    agents = list(args.agents or ev.agents)
    episodes = args.episodes or ev.episodes
    seed = ev.seed if args.seed is None else args.seed
    reference = args.reference or ev.reference
    t0 = time.perf_counter()
    results = compare_agents(agents, env_cfg, episodes, seed, not args.no_progress, reference)
    wall_s = time.perf_counter() - t0
    print_table(results)
    if args.json:
        write_json(args.json, {**results_json(results), "provenance": provenance(wall_s=wall_s)})
    if args.report:
        report = write_report(Path(args.report), results, env_cfg, "Agent comparison", wall_s=wall_s)
        print(f"report: {report}")
    return 0


def cmd_spread(args: argparse.Namespace) -> int:
    """``spread``: train a config with several seeds and print the 95 % prediction interval of a new run's
    figure (argmax and sampled actions); reuses the runs already in ``--out``."""
    from planetnav_train.spread import format_spread, run_spread

    config = args.config or str(DEFAULT_CONFIG)
    out = Path(args.out) if args.out else ROOT / "runs" / "spread" / Path(config).stem
    result = run_spread(config, args.seeds, out, args.episodes, progress=not args.no_progress)
    print(format_spread(result))
    print(f"per-run figures and intervals: {out / 'spread.json'}")
    return 0


def _positive(flag: str, value: int | None) -> None:
    """:class:`ConfigError` naming ``flag`` and ``value`` unless it is None or >= 1."""
    if value is not None and value < 1:
        raise ConfigError(f"{flag} must be >= 1, got {value}")


def cmd_suite(args: argparse.Namespace) -> int:
    """``suite``: train, evaluate, score and aggregate a grid of benchmark cells
    (:mod:`planetnav_train.suite`, docs/suite.md); a Ray Tune grid when Ray is installed; ``--resume``."""
    from planetnav_train import suite
    from planetnav_train.suite.publish import check_tree

    if args.publish_json or args.readme:  # publishing into the repository: from a clean tree (fail early)
        check_tree(args.allow_dirty)
    if not args.budget_scale > 0:
        raise ConfigError(f"--budget-scale must be > 0, got {args.budget_scale}")
    _positive("--episode-steps", args.episode_steps)
    _positive("--eval-episodes", args.eval_episodes)
    tasks = args.tasks or [t.id for t in suite.TASKS]
    kinds = {suite.get_task(t).action_kind for t in tasks}
    algos = args.algos or sorted({a for k in kinds for a in suite.ALGOS_BY_KIND[k]})
    # Without --algos, the published table's pairs (RecurrentPPO on the Mars approach only).
    cells = suite.make_cells(tasks, algos, args.seeds, args.track, table_only=not args.algos)
    settings = suite.Settings(
        out=Path(args.out),
        budget_scale=args.budget_scale,
        episode_steps=args.episode_steps,
        eval_episodes=args.eval_episodes,
        assists_path=args.assists,
        progress=not args.no_progress,
        exact_actions=args.exact_actions,
        resume=args.resume,
    )
    use_ray = False if args.no_ray else None
    result = suite.run_suite(cells, settings, resume=args.resume, use_ray=use_ray, address=args.address)
    out = suite.finish(result, settings, args.json, Path(args.markdown) if args.markdown else None,
                       allow_dirty=args.allow_dirty)  # fmt: skip
    print(f"ran {len(result['ran'])}, skipped {len(result['skipped'])} finished; {len(result['records'])} "
          f"records in {out['json']}; leaderboard: {out['markdown']}")  # fmt: skip
    _publish(args, out["json"])
    return 0


def _publish(args: argparse.Namespace, suite_json: Path) -> None:
    """``--publish-json`` and ``--readme`` of ``suite`` and ``suite-publish`` (:mod:`~.publish`)."""
    from planetnav_train.suite import publish

    if args.publish_json:
        print(f"published JSON: {publish.publish_json(suite_json, args.publish_json)}")
    if args.readme:
        readme = publish.update_readme(args.readme, publish.load_suite_json(suite_json))
        print(f"summary written into {readme}")


def cmd_suite_publish(args: argparse.Namespace) -> int:
    """``suite-publish``: re-aggregate every record of ``--out`` (nothing trains), write ``OUT/suite.json``
    and the page, then copy the JSON into the repository, update the README's summary and ship the best
    raw-track models as named agents, as the flags ask (docs/suite.md, "Publishing")."""
    from planetnav_train import suite
    from planetnav_train.suite import publish

    publish.check_tree(args.allow_dirty)  # before anything is written
    settings = suite.Settings(out=Path(args.out))
    records = suite.load_records(settings.out)
    if not records:
        raise ConfigError(f"no run records in {settings.out / 'runs'}: nothing to publish")
    result = {"ran": [], "records": records, "references": {}}
    out = suite.finish(result, settings, None, Path(args.markdown) if args.markdown else None,
                       allow_dirty=args.allow_dirty)  # fmt: skip
    print(f"{len(records)} records aggregated into {out['json']}; leaderboard: {out['markdown']}")
    _publish(args, out["json"])
    if args.baselines:
        shipped = publish.ship_baselines(
            settings.out, args.baselines, args.baseline_tasks, official_only=not args.allow_smoke
        )
        for e in shipped:
            print(f"shipped suite:{e['task']}: {e['source_cell']} (objective {e['objective']:.1f}, "
                  f"score {e['normalized_score']:+.2f}, {e['bytes']:,} bytes) -> "
                  f"{args.baselines}/{e['file']}")  # fmt: skip
    return 0


def cmd_suite_restore(args: argparse.Namespace) -> int:
    """``suite-restore``: the records, references and reference cache of a published suite JSON written
    back into an output folder, so that cells can be re-run there and the page published again without
    re-running the table (:mod:`planetnav_train.suite.restore`)."""
    from planetnav_train.suite.restore import format_restored, restore

    print(format_restored(restore(args.source, args.out), args.out))
    return 0


def cmd_suite_references(args: argparse.Namespace) -> int:
    """``suite-references``: the suite's reference values of ``--tasks`` (``random`` and every
    best-reference candidate, or ``--agents``), cached under ``OUT/references`` for the suite to read
    (:mod:`planetnav_train.suite.references`)."""
    from planetnav_train import suite
    from planetnav_train.suite.references import reference_lines

    _positive("--eval-episodes", args.eval_episodes)
    _positive("--episode-steps", args.episode_steps)
    settings = suite.Settings(
        out=Path(args.out), eval_episodes=args.eval_episodes, episode_steps=args.episode_steps
    )
    for line in reference_lines(args.tasks or [t.id for t in suite.TASKS], settings, args.agents):
        print(line, flush=True)
    return 0


def cmd_suite_rerun(args: argparse.Namespace) -> int:
    """``suite-rerun``: re-run published cells with their recorded command and compare each with its record
    (:mod:`planetnav_train.suite.rerun`); exit status 1 if a re-run objective falls outside its cell's
    published 95 % interval."""
    from planetnav_train.suite.rerun import format_rerun, rerun_cell

    inside = []
    for key in args.cells:
        result = rerun_cell(key, Path(args.published))
        print(format_rerun(result), flush=True)
        inside.append(result["inside"])
    return 0 if all(inside) else 1


def cmd_suite_sizes(args: argparse.Namespace) -> int:
    """``suite-sizes``: bytes of each suite algorithm's saved model and of its policy-only export per task,
    and the form it would ship in (:mod:`planetnav_train.suite.sizes`)."""
    from planetnav_train import suite
    from planetnav_train.suite.sizes import cell_sizes, table_header, table_row

    export = not args.no_export
    rows = cell_sizes(args.tasks or [t.id for t in suite.TASKS], args.algos, export)  # names checked here
    for line in table_header(export):
        print(line)
    for row in rows:
        print(table_row(row, export), flush=True)
    return 0


def add_evaluation_arguments(sp: argparse.ArgumentParser) -> None:
    """The environment and evaluation options of ``evaluate`` and ``compare`` (and of the research
    commands that evaluate): ``--episodes``, ``--seed``, ``--config``, ``--episode-steps``,
    ``--noise-streams``, ``--json``; :func:`eval_env_config` reads them."""
    sp.add_argument(
        "--episodes", type=int, help="episodes per agent (default: the config's eval.episodes)"
    )
    sp.add_argument("--seed", type=int, help=f"first held-out seed (default {EVAL_SEED})")
    sp.add_argument("--config", help="YAML whose env (and eval) sections define the environment")
    sp.add_argument("--episode-steps", type=int, help="override the episode length")
    sp.add_argument(
        "--noise-streams",
        choices=NOISE_STREAMS,
        help="override the env's noise_streams: per_step gives every agent the same sensor noise "
        "wherever it makes the same measurement (common random numbers)",
    )
    sp.add_argument("--json", help="write the metrics as JSON here")


def build_parser() -> argparse.ArgumentParser:
    """The command line of ``train.py``: one sub-command per ``cmd_*`` function."""
    p = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.RawTextHelpFormatter
    )
    sub = p.add_subparsers(dest="command")

    t = sub.add_parser("train", help="train an SB3 agent from a YAML config, then evaluate and report")
    t.add_argument("--config", help=f"training YAML (default {DEFAULT_CONFIG.relative_to(ROOT)})")
    t.add_argument("--run-dir", help="output directory (default runs/<name>)")
    t.add_argument("--timesteps", type=int, help="override n_timesteps")
    t.add_argument("--seed", type=int, help="override the config's training seed (spread across runs)")
    t.add_argument("--no-eval", action="store_true", help="skip the evaluation and report")
    t.add_argument(
        "--resume",
        metavar="RUN_DIR",
        help="continue the run in RUN_DIR from its last checkpoint (after a kill or Ctrl-C), with its own "
        "config.yaml, to its configured steps, then evaluate",
    )
    t.add_argument("--address", help="RLlib only: join the Ray cluster at HOST:PORT (default: a local Ray)")
    t.add_argument(
        "--device",
        default="cpu",
        help="cuda (or cuda:K): train with baselines/ppo_device.py on the GPU, the config's env_id, seed "
        "and n_timesteps (needs the [gpu] extra and a GPU); cpu (default): the config's trainer",
    )
    t.set_defaults(func=cmd_train)

    def cmd_tune(args: argparse.Namespace) -> int:
        return extensions.command("tune")(args)  # registered by planetnav_rl

    tn = sub.add_parser("tune", help="Ray Tune sweep over an SB3 or RLlib config (needs the [ray] extra)")
    tn.add_argument("--config", required=True, help="sweep YAML (e.g. configs/sweep.yaml)")
    tn.add_argument("--address", help="join the Ray cluster at HOST:PORT (default: a local Ray)")
    tn.add_argument("--run-dir", help="output directory (default runs/<sweep name>)")
    tn.add_argument("--resume", action="store_true", help="continue an interrupted sweep in --run-dir")
    tn.add_argument("--num-cpus", type=int, help="CPUs of the local Ray (default: all)")
    tn.set_defaults(func=cmd_tune)

    e = sub.add_parser("evaluate", help="evaluate one agent (name or SB3 model path)")
    e.add_argument(
        "--agent", required=True, help="planner, greedy, periodic:period=60,cycle=0-1-2, ... or a model path"
    )
    add_evaluation_arguments(e)
    e.set_defaults(func=cmd_evaluate)

    c = sub.add_parser("compare", help="evaluate several agents on the same seeds and print one table")
    c.add_argument(
        "--agents",
        nargs="+",
        help="names and/or model paths (default: the config's eval.agents, else the default agents)",
    )
    c.add_argument("--report", help="also write report.md, plots and eval.json into this directory")
    c.add_argument("--reference", help=f"paired differences against this agent (default {REFERENCE})")
    add_evaluation_arguments(c)
    c.set_defaults(func=cmd_compare)

    sp_ = sub.add_parser(
        "spread",
        help="train a config with several seeds; the 95 %% prediction interval of a new run's figure",
    )
    sp_.add_argument("--config", help=f"training YAML (default {DEFAULT_CONFIG.relative_to(ROOT)})")
    sp_.add_argument(
        "--seeds", nargs="+", type=int, default=[0, 1, 2, 3, 4], help="training seeds (5 or more to publish)"
    )
    sp_.add_argument("--out", help="runs and spread.json (default runs/spread/<config name>)")
    sp_.add_argument("--episodes", type=int, help="evaluation episodes (default: the config's eval.episodes)")
    sp_.set_defaults(func=cmd_spread)

    for sp in (t, e, c, tn, sp_):
        sp.add_argument("--no-progress", action="store_true", help="no progress bars")

    su = sub.add_parser("suite", help="benchmark suite: train, evaluate, score, aggregate (docs/suite.md)")
    su.add_argument("--tasks", nargs="+", help="task ids, e.g. Cruise-Target-v0 (default: every task)")
    su.add_argument("--algos", nargs="+", help="algorithms (default: every one of the tasks' action kinds)")
    su.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2, 3, 4], help="training seeds")
    su.add_argument("--track", choices=("raw", "assisted"), default="raw", help="default %(default)s")
    su.add_argument("--assists", default="configs/suite/assisted.yaml", help="the assisted track's assists")
    su.add_argument("--budget-scale", type=float, default=1.0, help="x each task's budget (smoke: < 1)")
    su.add_argument("--episode-steps", type=int, help="smoke only: shorter episodes, training and evaluation")
    su.add_argument("--eval-episodes", type=int, help="smoke only: fewer evaluation seeds than the task's")
    su.add_argument("--out", default="runs/suite", help="records, models, references (default %(default)s)")
    su.add_argument(
        "--resume",
        action="store_true",
        help="skip the cells whose record exists in --out; a cell killed mid-training continues from its "
        "checkpoint",
    )
    su.add_argument("--json", help="write this invocation's runs here (the published JSON's form)")
    su.add_argument("--markdown", help="the leaderboard page (default OUT/benchmark.md)")
    su.add_argument("--address", help="run the grid on the Ray cluster at HOST:PORT (needs the [ray] extra)")
    su.add_argument("--no-ray", action="store_true", help="run sequentially even where Ray is installed")
    su.add_argument(
        "--exact-actions",
        action=argparse.BooleanOptionalAction,
        default=False,
        help="evaluate a continuous policy row by row, each row's forward pass the single env's (slower; "
        "default: one forward pass for all rows, equal to the single env's to float rounding)",
    )
    su.add_argument("--no-progress", action="store_true", help="no progress bars")
    su.set_defaults(func=cmd_suite)

    def publishing(sp: argparse.ArgumentParser) -> None:
        sp.add_argument(
            "--publish-json", help="copy OUT/suite.json (all runs, aggregates) here: docs/benchmark.json"
        )
        sp.add_argument(
            "--readme", help="write the summary tables between the suite-summary markers of this README"
        )
        sp.add_argument(
            "--allow-dirty", action="store_true",
            help="publish from a tree with uncommitted changes (refused otherwise); the page says so",
        )  # fmt: skip

    publishing(su)
    sp = sub.add_parser(
        "suite-publish",
        help="re-aggregate a suite's records (no training); publish the JSON, README summary, baselines",
    )
    sp.add_argument("--out", default="runs/suite", help="the suite's output folder (default %(default)s)")
    sp.add_argument("--markdown", help="the leaderboard page (default OUT/benchmark.md)")
    publishing(sp)
    sp.add_argument(
        "--baselines",
        help="ship each task's best raw-track model into this folder, e.g. planetnav_train/baselines",
    )
    sp.add_argument("--baseline-tasks", nargs="+", help="ship these tasks only (default: every raw task)")
    sp.add_argument(
        "--allow-smoke", action="store_true", help="tests only: ship runs with smoke settings too"
    )
    sp.set_defaults(func=cmd_suite_publish)

    sr = sub.add_parser(
        "suite-references",
        help="the suite's reference values (random and each best-reference candidate) per task, cached",
    )
    sr.add_argument("--tasks", nargs="+", help="task ids, e.g. ThrustArc-TCM-v0 (default: every task)")
    sr.add_argument(
        "--agents", nargs="+", help="only these of the tasks' random + candidates (no best chosen)"
    )
    sr.add_argument(
        "--out", default="runs/suite", help="the suite's output folder, the cache (default %(default)s)"
    )
    sr.add_argument("--eval-episodes", type=int, help="smoke only: fewer seeds (not the published values)")
    sr.add_argument("--episode-steps", type=int, help="smoke only: shorter episodes")
    sr.set_defaults(func=cmd_suite_references)

    rs = sub.add_parser(
        "suite-restore",
        help="write a published suite JSON's records and references back into an output folder "
        "(re-run some cells there, then publish again)",
    )
    rs.add_argument(
        "--from", dest="source", default="docs/benchmark.json",
        help="the published suite JSON (default %(default)s)",
    )  # fmt: skip
    rs.add_argument("--out", default="runs/suite", help="the output folder (default %(default)s)")
    rs.set_defaults(func=cmd_suite_restore)

    rr = sub.add_parser(
        "suite-rerun",
        help="re-run published suite cells with their recorded command and compare with the record "
        "(exit 1 if one falls outside its 95 %% interval)",
    )
    rr.add_argument("cells", nargs="+", help="cell keys, e.g. Cruise-Target-v0__ppo__raw__s1")
    rr.add_argument("--published", default="runs/suite", help="the suite's --out (default %(default)s)")
    rr.set_defaults(func=cmd_suite_rerun)

    sz = sub.add_parser(
        "suite-sizes",
        help="bytes of a saved model and its policy-only export per suite algorithm and task (< 1 MB ships)",
    )
    sz.add_argument("--tasks", nargs="+", help="task ids (default: every task)")
    sz.add_argument("--algos", nargs="+", help="algorithms (default: each task's SB3 ones)")
    sz.add_argument(
        "--no-export", action="store_true", help="the full models' bytes only (no policy-only export; faster)"
    )
    sz.set_defaults(func=cmd_suite_sizes)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``train.py`` with ``argv`` (default: ``sys.argv``; none: the default training run); returns the
    exit status (2 with the message on stderr for a configuration or input error)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv:
        argv = ["train"]  # python train.py: the default training run
    args = build_parser().parse_args(argv)
    if args.command is None:
        build_parser().print_help()
        return 2
    try:
        return args.func(args)
    except (ConfigError, FileNotFoundError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
