"""Where does a learned policy beat every rule on MarsApproach-Tasking-v3? A regime map.

    python research/tasks_v3/mars_regime_map.py attribute --model M.zip [--episodes 100]
    python research/tasks_v3/mars_regime_map.py map --model M.zip --effect E --strengths S ...
    python research/tasks_v3/mars_regime_map.py rules --model M.zip --specs SPEC ... [--episodes 300]
    python research/tasks_v3/mars_regime_map.py learn --effect E --strength S --seed K --out F.json
    python research/tasks_v3/mars_regime_map.py table F.json ...

``M.zip`` is a saved SB3 DQN model of the task (``python -m planetnav_train.suite.v3 learners --task
MarsApproach-Tasking-v3 --algo dqn --seed 1 --save-model M.zip``), acting deterministically as the suite
scores DQN. All seeds are evaluation seeds from 130,100 on (the first 100, 130,000.., are the ones the
model was picked on), with per-step noise streams, every policy on the same seeds.

- ``attribute``: the model, the published blind zero, the best blind finalist and covariance greedy in the
  flight world and in the flight world with one of the camera's unmodelled effects off at a time (the
  effects of ``gap_ceiling.py``'s camera-exact world): which effect makes the Mars fixes costly.
- ``map``: one effect swept from 0 (off) to its flight value (1): at each strength, J of the model (trained
  in the flight world), of every blind finalist and of each reference; the model's paired difference from
  the best rule at that strength (negative: the model is better). A row whose interval lies below 0 is a
  strength at which this learned policy beats every non-privileged rule.
- ``rules``: the model against further non-privileged rules in the flight world (rule specs, e.g. the
  adaptive ``greedy:bias=observed``, which divides a target's score by its observed mean NIS), paired,
  with each rule's difference from the published zero.
- ``learn``: the suite's DQN learner row (SB3's defaults through ``make_vec_env``, 300,000 decisions)
  trained and scored at one strength, beside the zero, the references and uniform random in that world.
- ``table``: the ``learn`` runs pooled per strength (two-level bootstrap over training runs and seeds);
  the suite's own DQN runs of the task (``research/tasks_v3/learners/MarsApproach-Tasking-v3-dqn-*.json``)
  are the flight row.
"""

from __future__ import annotations

import argparse
import json
import time
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path

import numpy as np

from planetnav_train.stats import mean_ci, paired_difference
from planetnav_train.suite import v3

TASK = "MarsApproach-Tasking-v3"
ENV_ID = f"planetnav/{TASK}"
FIRST = v3.EVAL_SEED + 100
DQN = "SB3 DQN (defaults, make_vec_env)"


def _drift(s: float) -> dict:
    return {"boresight_drift": False} if s == 0.0 else {"drift_sigma_arcsec": 1.0 * s}


def _cob(s: float) -> dict:
    # The onboard photometric model's error bound, 5 % in flight; at 0 the model is exact.
    return {"cob_model_error": 0.05 * s}


#: strength (0 = off, 1 = the flight value) -> the flight world's overrides, per effect.
EFFECTS: dict[str, Callable[[float], dict]] = {
    "drift": _drift,
    "cob_model_error": _cob,
    "lambert_cob": lambda s: {} if s else {"lambert_cob": False},
    "oblate_planets": lambda s: {} if s else {"oblate_planets": False},
    "image_errors": lambda s: {} if s else {"image_errors": False},
}


def world_for(effect: str, strength: float) -> dict:
    """The flight world's overrides with ``effect`` at ``strength`` (0: off; 1: the flight value)."""
    if effect not in EFFECTS:
        raise SystemExit(f"effect {effect!r}: one of {sorted(EFFECTS)}")
    if not 0.0 <= strength <= 1.0:
        raise SystemExit(f"strength {strength!r}: must lie in [0, 1]")
    if strength not in (0.0, 1.0) and effect in ("lambert_cob", "oblate_planets", "image_errors"):
        raise SystemExit(f"effect {effect!r} is on or off: strength 0 or 1, not {strength!r}")
    return EFFECTS[effect](strength)


def _model_act(path: str):
    from stable_baselines3 import DQN as DQNModel

    model = DQNModel.load(path, device="cpu")
    return v3._policy_fn(model, [], deterministic=True)


def blind_policies(task: str = TASK) -> dict:
    """The published blind finalists of ``task`` by name, the zero (the search's winner) first."""
    blind = v3.read_json(v3.BLIND_FILE)["tasks"][task]
    names = [blind["winner"], *(s for s in blind["finalists"] if s != blind["winner"])]
    return {name: v3.policy_from_record(name, blind["policies"][name]) for name in names}


def _rules(cfg, seeds: range) -> dict[str, np.ndarray]:
    """J per seed of every blind finalist (the zero first) and every reference of the task."""
    out = {f"blind {n}": v3.roll_out(cfg, p, seeds).objective for n, p in blind_policies().items()}
    for spec in v3.V3_TASKS[TASK]:
        out[f"reference {spec}"] = v3.policy_objective(cfg, spec, seeds.start, len(seeds))
    return out


def _compare(cfg, act, seeds: range) -> tuple[np.ndarray, dict[str, np.ndarray], np.ndarray, str]:
    """The model's J, every rule's, the zero's, and the name of the best rule, on ``seeds`` in ``cfg``."""
    jm = v3.roll_out(cfg, act, seeds).objective
    rules = _rules(cfg, seeds)
    return jm, rules, next(iter(rules.values())), min(rules, key=lambda k: rules[k].mean())


def _diff(a: np.ndarray, b: np.ndarray) -> str:
    d = paired_difference(a, b)
    return f"{d.mean:+.1f} [{d.low:+.1f}, {d.high:+.1f}]"


def attribute(args: argparse.Namespace) -> None:
    act = _model_act(args.model)
    seeds = range(FIRST, FIRST + args.episodes)
    worlds = {"flight": {}, **{f"{e} off": world_for(e, 0.0) for e in
                               ("drift", "lambert_cob", "oblate_planets", "image_errors")}}  # fmt: skip
    print(f"{TASK}: {args.model} (DQN, deterministic); seeds {seeds.start}..{seeds.stop - 1}\n")
    print("| world | J model | J zero | J best rule (which) | J greedy | model - best rule | greedy - zero |")
    print("|---|---|---|---|---|---|---|")
    for name, world in worlds.items():
        t0 = time.time()
        jm, rules, zero, best = _compare(v3.eval_config(ENV_ID, world=world), act, seeds)
        jg = rules["reference greedy"]
        cells = [name, f"{jm.mean():.1f}", f"{zero.mean():.1f}", f"{rules[best].mean():.1f} ({best})",
                 f"{jg.mean():.1f}", _diff(jm, rules[best]), _diff(jg, zero)]  # fmt: skip
        print("| " + " | ".join(cells) + f" |  ({time.time() - t0:.0f} s)", flush=True)


def regime_map(args: argparse.Namespace) -> None:
    act = _model_act(args.model)
    seeds = range(FIRST, FIRST + args.episodes)
    print(f"{TASK}: {args.model} (DQN, deterministic, trained in the flight world); effect {args.effect}; "
          f"seeds {seeds.start}..{seeds.stop - 1}\n")  # fmt: skip
    cols = ("strength", "J model", "J zero", "J best rule (which)", "J greedy", "model - best rule",
            "model - zero")  # fmt: skip
    print("| " + " | ".join(cols) + " |")
    print("|---|---|---|---|---|---|---|")
    for s in args.strengths:
        t0 = time.time()
        jm, rules, zero, best = _compare(v3.eval_config(ENV_ID, world=world_for(args.effect, s)), act, seeds)
        cells = [f"{s:g}", mean_ci(jm).format("{:.1f}"), f"{zero.mean():.1f}",
                 f"{rules[best].mean():.1f} ({best})", f"{rules['reference greedy'].mean():.1f}",
                 _diff(jm, rules[best]), _diff(jm, zero)]  # fmt: skip
        print("| " + " | ".join(cells) + f" |  ({time.time() - t0:.0f} s)", flush=True)


def rules(args: argparse.Namespace) -> None:
    act = _model_act(args.model)
    seeds = range(FIRST, FIRST + args.episodes)
    cfg = v3.eval_config(ENV_ID)
    jm = v3.roll_out(cfg, act, seeds).objective
    zero = v3.roll_out(cfg, next(iter(blind_policies().values())), seeds).objective
    print(f"{TASK}: {args.model} (DQN, deterministic); seeds {seeds.start}..{seeds.stop - 1}")
    print(f"  model: J {mean_ci(jm).format('{:.1f}')}; the zero: J {mean_ci(zero).format('{:.1f}')}")
    for spec in args.specs:
        j = v3.policy_objective(cfg, spec, seeds.start, len(seeds))
        cells = f"J {mean_ci(j).format('{:.1f}')}; model - it {_diff(jm, j)}; it - zero {_diff(j, zero)}"
        print(f"  {spec}: {cells}", flush=True)


def learn(args: argparse.Namespace) -> None:
    world = world_for(args.effect, args.strength)
    rows = v3.learner_rows(TASK, args.budget, args.seed, args.episodes, algo="dqn", world=world or None)
    rows.update(effect=args.effect, strength=args.strength)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    v3.write_json(Path(args.out), rows)
    for r in rows["rows"]:
        extra = "".join(f"  {k} {r[k]['mean']:+.1f} [{r[k]['lo']:+.1f}, {r[k]['hi']:+.1f}]"
                        for k in ("minus_zero", "minus_best_reference") if k in r)  # fmt: skip
        print(f"{r['policy']:<45} J {r['J']['mean']:7.1f}{extra}")


def table(paths: list[str]) -> None:
    by: dict[tuple[str, float], list[dict]] = defaultdict(list)
    for p in paths:
        d = json.loads(Path(p).read_text())
        if d.get("world_overrides"):
            by[(d["effect"], float(d["strength"]))].append(d)
        elif d.get("algo") == "dqn" and d["task"] == TASK:  # the suite's own runs: every effect at 1
            by[("flight", 1.0)].append(d)
        else:
            raise SystemExit(f"{p}: neither a `learn` run nor the suite's DQN run of {TASK}")
    head = ["effect", "strength", "runs", "J zero", "J reference", "DQN J (runs)", "DQN - zero",
            "DQN - reference", "per run: DQN - zero"]  # fmt: skip
    print("| " + " | ".join(head) + " |")
    print("|---" * len(head) + "|")
    for (effect, s), runs in sorted(by.items()):
        if len({tuple(r["per_seed"]["zero"]) for r in runs}) != 1:
            raise SystemExit(f"{effect} {s}: the runs' zero rows differ (other seeds or world)")
        ps = [{k: np.asarray(v, float) for k, v in r["per_seed"].items()} for r in runs]
        jd = [p[DQN].mean() for p in ps]
        cells = [
            effect,
            f"{s:g}",
            str(len(runs)),
            f"{ps[0]['zero'].mean():.1f}",
            f"{next(p['best_reference'] for p in ps if 'best_reference' in p).mean():.1f}",
            f"{np.mean(jd):.1f} ({min(jd):.1f}..{max(jd):.1f})",
        ]
        for other in ("zero", "best_reference"):
            # An older run wrote no reference row: the reference's difference pools the runs that did.
            d = v3.pooled_mean_interval([p[DQN] - p[other] for p in ps if other in p])
            cells.append(f"{d['mean']:+.1f} [{d['lo']:+.1f}, {d['hi']:+.1f}]")
        cells.append(", ".join(_diff(p[DQN], p["zero"]) for p in ps))
        print("| " + " | ".join(cells) + " |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    a = sub.add_parser("attribute")
    a.set_defaults(func=attribute)
    a.add_argument("--model", required=True)
    a.add_argument("--episodes", type=int, default=100)
    m = sub.add_parser("map")
    m.set_defaults(func=regime_map)
    m.add_argument("--model", required=True)
    m.add_argument("--effect", required=True, choices=sorted(EFFECTS))
    m.add_argument("--strengths", type=float, nargs="+", default=[0.0, 0.25, 0.5, 1.0])
    m.add_argument("--episodes", type=int, default=300)
    r = sub.add_parser("rules")
    r.set_defaults(func=rules)
    r.add_argument("--model", required=True)
    r.add_argument("--specs", nargs="+", required=True)
    r.add_argument("--episodes", type=int, default=300)
    learn_p = sub.add_parser("learn")
    learn_p.set_defaults(func=learn)
    learn_p.add_argument("--effect", required=True, choices=sorted(EFFECTS))
    learn_p.add_argument("--strength", type=float, required=True)
    learn_p.add_argument("--seed", type=int, default=0)
    learn_p.add_argument("--episodes", type=int, default=100)
    learn_p.add_argument("--budget", type=int, default=300_000)
    learn_p.add_argument("--out", required=True)
    t = sub.add_parser("table")
    t.set_defaults(func=lambda a: table(a.paths))
    t.add_argument("paths", nargs="+")
    args = ap.parse_args()
    args.func(args)


if __name__ == "__main__":
    main()
