"""Suite version 3: the flight-world tasks' blind zero, reward constants, normalization and learner rows.

Every number this module publishes comes out of one of its commands, so that it can be printed again
after the flight world changes (docs/tasks_v3.md gives each number beside its command)::

    python -m planetnav_train.suite.v3 reward     [--tasks ...] [--episodes N]  # reward baseline and scale
    python -m planetnav_train.suite.v3 search     [--tasks ...]                 # the blind-zero search
    python -m planetnav_train.suite.v3 normalize  [--tasks ...] [--episodes N]  # J_zero, J_best, the gap
    python -m planetnav_train.suite.v3 learners   --task ID --budget N          # PPO, untrained, random
    python -m planetnav_train.suite.v3 curves     FILE... [--plot P.png]        # their learning curves

**Blind policies** ignore the observation. Every target-choice one is a time-indexed action distribution
``P[d, a]`` over the task's decisions ``d`` with a hold ``h``: a fresh action is drawn from ``P[d]`` at
every ``h``-th decision and held in between (:class:`BlindTargets`): fixed schedules (one-hot rows), weighted
random targets, dwell lengths, deadline-anchored sessions, and the cross-entropy method's optimized
distributions are all of this form. A torque one is a time-indexed torque ``U[d]`` plus optional uniform
noise (:class:`BlindTorques`): zero, random, constant spins, pulses that leave a tumble, sinusoidal scans,
and the cross-entropy method's optimized sequence. Each plays the task's own decision interface.

**Seeds** (declared, disjoint, and held so by ``tests/suite/test_v3.py``): search :data:`SEARCH_SEED`..,
the search's second stage :data:`FINAL_SEED`.., the reward constants :data:`NORMALIZATION_SEED`.., the
published evaluation :data:`EVAL_SEED`.. (:data:`EVAL_EPISODES` = 1,000 by default); learners train on
seeds below 10,000 (SB3's and the single-file PPO's env seeds). Every evaluation uses per-step noise
streams, so two policies on one seed draw the same sensor noise where they make the same measurement.

**The objective J** of an episode: the mean over its physics steps of the true position error [km]
(target and torque tasks), or the thrust arc's J at its end (knowledge mapped to the encounter at the
deadlines plus w x delta-v lost) [km]: what :func:`planetnav_train.evaluate.evaluate_agent` reports, so
the rule references and the blind policies are scored alike.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from planetnav_env.config import EnvConfig
from planetnav_env.core import layout as L
from planetnav_env.errors import ConfigError
from planetnav_env.tasks import get_version
from planetnav_train.provenance import git_state, utc_now
from planetnav_train.suite import v3_curves

#: The search's first stage: every candidate on these seeds.
SEARCH_SEED = 110_000
SEARCH_EPISODES = 32
#: The search's second stage: the best :data:`FINALISTS` again on fresh seeds, which pick the winner.
FINAL_SEED = 115_000
FINAL_EPISODES = 100
FINALISTS = 5
#: The reward's baseline and scale (planetnav_env.tasks.constants).
NORMALIZATION_SEED = 120_000
NORMALIZATION_EPISODES = 200
#: The published evaluation: J_zero, J_best, the gap, and every run's score.
EVAL_SEED = 130_000
EVAL_EPISODES = 1000
#: The seed blocks: (name, first seed, the block's size); tests hold them disjoint.
SEED_BLOCKS = (
    ("training", 0, 10_000),
    ("search", SEARCH_SEED, 5_000),
    ("search final", FINAL_SEED, 5_000),
    ("normalization", NORMALIZATION_SEED, 10_000),
    ("evaluation", EVAL_SEED, 20_000),
)
#: The v3 ids and their non-privileged references (rule agents; the lowest J on the evaluation seeds is
#: J_best): the v2 tasks' references, and greedy counting the flight world's photometric-model residual
#: (``bias=photometric``: it knows the onboard model's error bound, not the episode's draw).
_EVENT_REFS = ("greedy", "greedy:success=observed", "greedy:bias=photometric")
V3_TASKS: dict[str, tuple[str, ...]] = {
    "Cruise-Target-v3": _EVENT_REFS,
    "RandomCruise-Target-v3": _EVENT_REFS,
    "MarsApproach-Tasking-v3": _EVENT_REFS,
    "ThrustArc-TCM-v3": (
        "periodic:period=432,session=12,phase=108,cycle=0-1-2",
        "periodic:lead=0,session=24-42-12,start=6,dwell=3,cycle=0-1-2",
        "greedy:threshold=4",
        "optimum",
    ),
    # v2's torque references but the planner: ~5 s an episode in the flight world, 1,000 seeds ~1.5 h of
    # one core. On 100 evaluation seeds it beats greedy by 8.7 [0.5, 16.9] km (docs/tasks_v3.md), so
    # J_best without it is conservative: the gap it gives is a lower bound.
    "Cruise-Torque-v3": ("greedy", "periodic", "baseline"),
}
#: The headline rule: a closed-loop gap of at least 25 %, its interval's lower bound at least 15 %.
HEADLINE_GAP, HEADLINE_GAP_LO = 0.25, 0.15
#: Bins of the reward baseline of a task that decides every physics step (one bin per 10 steps).
TORQUE_BASELINE_BINS = 144
BOOTSTRAP_REPS, BOOTSTRAP_SEED = 10_000, 0
ROOT = Path(__file__).resolve().parents[2]
#: The versioned files the commands write (suite version 3): the search's candidates and winner, and the
#: normalization constants the suite reads.
BLIND_FILE = ROOT / "docs" / "tasks_v3_blind.json"
NORMALIZATION_FILE = ROOT / "docs" / "tasks_v3_normalization.json"
SUITE_VERSION = 3


def eval_config(env_id: str, **overrides: Any) -> EnvConfig:
    """The evaluation environment of v3 task ``env_id``: the registered one with per-step noise streams."""
    cfg = get_version(env_id).config()
    return EnvConfig.from_dict(cfg.to_dict(), noise_streams="per_step", **overrides)


# ---------------------------------------------------------------------------------------------------------
# Blind policies
# ---------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class BlindTargets:
    """A blind target-choice policy: at decision ``d`` (every ``hold``-th, held in between) an action drawn
    from ``probs[d]`` ((D, A), rows summing to 1; one-hot rows: a fixed schedule)."""

    name: str
    probs: np.ndarray
    hold: int = 1

    def entropy(self) -> float:
        """Mean entropy per decision [nats] of the drawn actions (0 for a fixed schedule)."""
        p = self.probs[:: self.hold]
        with np.errstate(divide="ignore", invalid="ignore"):
            return float(-np.nansum(np.where(p > 0, p * np.log(p), 0.0), axis=1).mean())

    def actions(self, d: int, u: np.ndarray, last: np.ndarray) -> np.ndarray:
        """The rows' actions at decision ``d`` from their uniform draws ``u`` (N,) and last actions."""
        if d % self.hold and d > 0:
            return last
        cdf = np.cumsum(self.probs[min(d, len(self.probs) - 1)])
        return np.minimum(np.searchsorted(cdf, u * cdf[-1], side="right"), len(cdf) - 1)


@dataclass(frozen=True)
class BlindTorques:
    """A blind torque policy: ``torques[d]`` ((D, 3), in [-1, 1]) plus, with ``noise`` > 0, a uniform draw
    of that half-width, clipped to [-1, 1]."""

    name: str
    torques: np.ndarray
    noise: float = 0.0

    def actions(self, d: int, u: np.ndarray) -> np.ndarray:
        base = self.torques[min(d, len(self.torques) - 1)]
        return np.clip(base[None, :] + self.noise * (2.0 * u - 1.0), -1.0, 1.0)


def _one_hot(seq: Sequence[int], n_actions: int) -> np.ndarray:
    out = np.zeros((len(seq), n_actions))
    out[np.arange(len(seq)), np.asarray(seq)] = 1.0
    return out


def target_candidates(cfg: EnvConfig) -> list[BlindTargets]:
    """The blind target-choice family of ``cfg`` (without the cross-entropy method's, :func:`cem_targets`):

    - uniform random, and weighted random over every weight vector with entries in {0, 1, 2} (not all
      zero), each held 1, 3 or 6 decisions (dwell lengths);
    - every cycle of 1-3 targets at dwells of 1, 2, 3, 4, 6 and 12 decisions;
    - with the camera-off action (the thrust arc): sessions of 1 or 2 decisions on each target of a cycle
      with 11, 35 or 71 decisions off between, at four phases; and clock-anchored sessions, a block of 1-4
      decisions per target ending ``lead`` decisions before each knowledge deadline (lead 0, 1, 3, 6, 12),
      with optional periodic sessions between.
    """
    import itertools

    n_a, d_n = cfg.n_target_actions, cfg.episode_decisions
    n_t = cfg.n_targets
    out: list[BlindTargets] = []
    for w in itertools.product((0, 1, 2), repeat=n_a):
        if sum(w) == 0 or math.gcd(*w) > 1:  # (2, 2, 0) is (1, 1, 0): each distribution once
            continue
        p = np.tile(np.asarray(w, float) / sum(w), (d_n, 1))
        for hold in (1, 3, 6):
            out.append(BlindTargets(f"weighted:w={'-'.join(map(str, w))},hold={hold}", p, hold))
    cycles: list[tuple[int, ...]] = [(t,) for t in range(n_a)]
    cycles += list(itertools.combinations(range(n_t), 2))
    for a, b, c in itertools.combinations(range(n_t), 3):
        cycles += [(a, b, c), (a, c, b)]
    for cycle in cycles:
        for dwell in (1, 2, 3, 4, 6, 12) if len(cycle) > 1 else (1,):
            seq = [cycle[(d // dwell) % len(cycle)] for d in range(d_n)]
            out.append(BlindTargets(f"cycle:{'-'.join(map(str, cycle))},dwell={dwell}", _one_hot(seq, n_a)))
    if cfg.idle_action:
        off = n_a - 1
        for cycle in cycles:
            if off in cycle:
                continue
            for on, gap in itertools.product((1, 2), (11, 35, 71)):
                block = [t for t in cycle for t in [t] * on + [off] * gap]
                for phase in (0.0, 0.25, 0.5, 0.75):
                    shift = round(phase * (on + gap))
                    seq = [block[(d + shift) % len(block)] for d in range(d_n)]
                    out.append(BlindTargets(f"sessions:{'-'.join(map(str, cycle))},on={on},gap={gap},"
                                            f"phase={phase}", _one_hot(seq, n_a)))  # fmt: skip
        if cfg.operations is not None:
            dec_s = cfg.decision_steps * cfg.step_s
            deadlines = [int(t // dec_s) for t in cfg.operations.deadlines_s]
            for cycle in [c for c in cycles if off not in c and len(c) > 1]:
                for on, lead, between in itertools.product((1, 2, 4), (0, 1, 3, 6, 12), (0, 36, 72)):
                    seq = [off] * d_n
                    if between:
                        for s0 in range(between // 2, d_n, between):
                            for j, t in enumerate(cycle):
                                if s0 + j < d_n:
                                    seq[s0 + j] = t
                    for dl in deadlines:
                        end = dl - lead
                        start = end - on * len(cycle)
                        for j in range(on * len(cycle)):
                            if 0 <= start + j < d_n:
                                seq[start + j] = cycle[j // on]
                    out.append(BlindTargets(f"deadlines:{'-'.join(map(str, cycle))},on={on},lead={lead},"
                                            f"between={between}", _one_hot(seq, n_a)))  # fmt: skip
    return out


def torque_candidates(cfg: EnvConfig) -> list[BlindTorques]:
    """The blind torque family: zero; uniform random (half-width 1, 0.3, 0.1); a constant torque along
    each signed body axis and the diagonal (1, 0.3, 0.1 of the action range: a spin-up that saturates the
    wheels, then a constant tumble); a full-scale pulse of 1, 3, 10 or 30 decisions along each axis, then
    zero (a tumble at the rate the pulse left); a sinusoidal scan about each axis with periods of 10, 30,
    120 and 480 decisions."""
    d_n = cfg.episode_decisions
    out = [BlindTorques("zero", np.zeros((d_n, 3)))]
    out += [BlindTorques(f"random:halfwidth={h}", np.zeros((d_n, 3)), h) for h in (1.0, 0.3, 0.1)]
    axes = {f"{s}{n}": s_v * np.eye(3)[i] for i, n in enumerate("xyz") for s, s_v in (("+", 1), ("-", -1))}
    axes["+xyz"] = np.ones(3) / math.sqrt(3.0)
    for name, ax in axes.items():
        for mag in (1.0, 0.3, 0.1):
            out.append(BlindTorques(f"spin:{name},mag={mag}", np.tile(mag * ax, (d_n, 1))))
        for n in (1, 3, 10, 30):
            u = np.zeros((d_n, 3))
            u[:n] = ax
            out.append(BlindTorques(f"pulse:{name},decisions={n}", u))
    t = np.arange(d_n)[:, None]
    for i, n in enumerate("xyz"):
        for period in (10, 30, 120, 480):
            out.append(
                BlindTorques(f"scan:{n},period={period}", np.sin(2 * np.pi * t / period) * np.eye(3)[i])
            )
    return out


# ---------------------------------------------------------------------------------------------------------
# Rolling blind policies out
# ---------------------------------------------------------------------------------------------------------


@dataclass
class Rollout:
    """Per-episode objective J [km] and, when asked, each physics step's error term e_k [km] ((N, K);
    the reward's e: the true error, or on the thrust arc the objective's increment), the actions taken,
    and each row's state at its episode's end (``final``: the core's ``f`` rows, columns
    ``planetnav_env.core.layout.F_*``: fix counts, dumps, saturation, ...)."""

    objective: np.ndarray
    terms: np.ndarray | None = None
    final: np.ndarray | None = None
    #: With ``actions=True``: every decision's actions, (D, N) or (D, N, 3) (the rows of a finished
    #: episode keep their last decisions' until the longest episode of their batch ends).
    actions: np.ndarray | None = None


class _Recorder:
    """Called after every physics step with the mask of the rows it advanced: sums each row's true error,
    and, with ``k_max`` > 0, keeps each step's error term (the objective's increment on the thrust arc)."""

    def __init__(self, f: np.ndarray, n: int, k_max: int, ops: bool) -> None:
        self.f, self.ops = f, ops
        self.err_sum, self.steps = np.zeros(n), np.zeros(n, np.int64)
        self.e = np.zeros((n, k_max)) if k_max else None
        self.prev_obj = np.zeros(n)

    def __call__(self, stepped: np.ndarray) -> None:
        rows = np.flatnonzero(stepped)
        f = self.f
        self.err_sum[rows] += f[rows, L.F_POS_ERR]
        if self.e is not None:
            k = self.steps[rows]
            if self.ops:
                self.e[rows, k] = f[rows, L.F_OBJECTIVE] - self.prev_obj[rows]
                self.prev_obj[rows] = f[rows, L.F_OBJECTIVE]
            else:
                self.e[rows, k] = f[rows, L.F_POS_ERR]
        self.steps[rows] += 1


def roll_out(
    cfg: EnvConfig,
    policy: BlindTargets | BlindTorques | Callable[[int, np.ndarray], np.ndarray],
    seeds: Sequence[int],
    terms: bool = False,
    batch: int = 256,
    final: bool = False,
    actions: bool = False,
) -> Rollout:
    """Episodes of ``policy`` on ``seeds`` (one vector-env row per seed, ``batch`` rows at a time) in
    ``cfg``'s decision interface. A callable policy gets ``(decision, observations)`` and returns actions.
    Each row's action draws come from its own generator seeded ``(seed, 3)`` (apart from the env's)."""
    from planetnav_env.envs.vector_env import PlanetNavVectorEnv

    js, ts, fs, acts = [], [], [], []
    k_max = cfg.episode_steps
    for start in range(0, len(seeds), batch):
        chunk = list(seeds[start : start + batch])
        n = len(chunk)
        env = PlanetNavVectorEnv(n, cfg, autoreset_mode="disabled")
        obs, _ = env.reset(seed=chunk)
        gens = [np.random.default_rng([s, 3]) for s in chunk]
        rec = _Recorder(env.core.f, n, k_max if terms else 0, cfg.operations is not None)
        done = np.zeros(n, bool)
        last = np.zeros(n, np.int64)
        d = 0
        chunk_acts = []
        while not done.all():
            if isinstance(policy, BlindTargets):
                u = np.array([g.random() for g in gens])
                act = last = policy.actions(d, u, last)
            elif isinstance(policy, BlindTorques):
                u = np.stack([g.random(3) for g in gens])
                act = policy.actions(d, u)
            else:
                act = policy(d, obs)
            if actions:
                chunk_acts.append(np.array(act, copy=True))
            _, term, trunc = env.step_rows(act, ~done, on_step=rec)
            done |= term | trunc
            obs = env.observations()
            d += 1
        if cfg.operations is not None:
            js.append(env.core.f[:, L.F_OBJECTIVE].copy())
        else:
            js.append(rec.err_sum / np.maximum(rec.steps, 1))
        if rec.e is not None:
            ts.append(rec.e)
        if final:
            fs.append(env.core.f.copy())
        if actions:
            acts.append(np.stack(chunk_acts))
        env.close()
    return Rollout(
        np.concatenate(js), np.concatenate(ts) if terms else None, np.concatenate(fs) if final else None,
        np.concatenate(acts, axis=1) if actions else None,
    )  # fmt: skip


def policy_objective(cfg: EnvConfig, policy: Any, seed: int, episodes: int) -> np.ndarray:
    """Per-episode J of a blind policy, or of a rule agent (a spec string, by the suite's evaluator)."""
    if isinstance(policy, str):
        from planetnav_train.suite.blind import evaluate_objective

        return evaluate_objective(policy, cfg, episodes, seed)
    return roll_out(cfg, policy, range(seed, seed + episodes)).objective


# ---------------------------------------------------------------------------------------------------------
# The cross-entropy method over time-indexed action distributions
# ---------------------------------------------------------------------------------------------------------


def _bins(d_n: int, n_bins: int) -> np.ndarray:
    """The bin of each of ``d_n`` decisions when they split into ``n_bins`` equal spans of time."""
    return np.minimum(np.arange(d_n) * n_bins // d_n, n_bins - 1)


def cem_targets(
    cfg: EnvConfig, seeds: Sequence[int], bins: int = 12, population: int = 16, iterations: int = 4,
    elite: float = 0.25, log: Callable[[str], None] = print,
) -> list[BlindTargets]:  # fmt: skip
    """Cross-entropy method over ``bins`` x A logits (a time-indexed action distribution, a fresh draw
    every decision), Gaussian proposals of mean and standard deviation updated from the ``elite`` share of
    each ``population``, every proposal scored on the same ``seeds`` (the search seeds: common random
    numbers). Returns two candidates: the final mean's distribution, and its most likely action per bin
    (a fixed schedule)."""
    n_a, d_n = cfg.n_target_actions, cfg.episode_decisions
    idx = _bins(d_n, bins)
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    mu, sd = np.zeros((bins, n_a)), np.full((bins, n_a), 2.0)

    def probs(theta: np.ndarray) -> np.ndarray:
        z = np.exp(theta - theta.max(axis=1, keepdims=True))
        return (z / z.sum(axis=1, keepdims=True))[idx]

    n_elite = max(2, round(elite * population))
    for it in range(iterations):
        thetas = mu + sd * rng.standard_normal((population, bins, n_a))
        scores = np.array(
            [roll_out(cfg, BlindTargets("cem", probs(t)), seeds).objective.mean() for t in thetas]
        )
        best = thetas[np.argsort(scores)[:n_elite]]
        mu, sd = best.mean(axis=0), best.std(axis=0) + 0.1
        log(
            f"  cem {it + 1}/{iterations}: best {scores.min():.2f}, "
            f"elite mean {np.sort(scores)[:n_elite].mean():.2f}"
        )
    mode = probs(mu).argmax(axis=1)
    return [BlindTargets(f"cem:bins={bins},distribution", probs(mu)),
            BlindTargets(f"cem:bins={bins},mode", _one_hot(mode, n_a))]  # fmt: skip


def cem_torques(
    cfg: EnvConfig, seeds: Sequence[int], bins: int = 12, population: int = 16, iterations: int = 4,
    elite: float = 0.25, log: Callable[[str], None] = print,
) -> list[BlindTorques]:  # fmt: skip
    """Cross-entropy method over a ``bins`` x 3 open-loop torque sequence (held over each bin's
    decisions, in [-1, 1] by tanh), scored on the same ``seeds``; returns the final mean's sequence."""
    d_n = cfg.episode_decisions
    idx = _bins(d_n, bins)
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    mu, sd = np.zeros((bins, 3)), np.full((bins, 3), 1.0)
    n_elite = max(2, round(elite * population))
    for it in range(iterations):
        thetas = mu + sd * rng.standard_normal((population, bins, 3))
        scores = np.array([roll_out(cfg, BlindTorques("cem", np.tanh(t)[idx]), seeds).objective.mean()
                           for t in thetas])  # fmt: skip
        best = thetas[np.argsort(scores)[:n_elite]]
        mu, sd = best.mean(axis=0), best.std(axis=0) + 0.05
        log(
            f"  cem {it + 1}/{iterations}: best {scores.min():.2f}, "
            f"elite mean {np.sort(scores)[:n_elite].mean():.2f}"
        )
    return [BlindTorques(f"cem:bins={bins}", np.tanh(mu)[idx])]


# ---------------------------------------------------------------------------------------------------------
# Statistics
# ---------------------------------------------------------------------------------------------------------


def mean_interval(values: np.ndarray) -> dict[str, float]:
    """Mean and 95 % percentile-bootstrap interval over the seeds."""
    v = np.asarray(values, float)
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    means = v[rng.integers(0, v.size, (BOOTSTRAP_REPS, v.size))].mean(axis=1)
    return {"mean": float(v.mean()), "lo": float(np.quantile(means, 0.025)),
            "hi": float(np.quantile(means, 0.975)), "episodes": int(v.size)}  # fmt: skip


def paired_difference(a: np.ndarray, b: np.ndarray) -> dict[str, float]:
    """mean(a - b) over the same seeds with its 95 % paired bootstrap interval."""
    return mean_interval(np.asarray(a, float) - np.asarray(b, float))


def run_score(j: np.ndarray | Sequence[np.ndarray], j_zero: float, j_best: float) -> dict[str, float]:
    """A run's blind-zero score ``(J_zero - J) / (J_zero - J_best)`` against the published constants, its
    95 % interval a bootstrap over the evaluation seeds (and, given several runs' per-seed arrays, over
    the runs too): the evaluation seeds' spread is in it; the constants are fixed per suite version."""
    if not j_best < j_zero:
        # A reference no better than the blind zero leaves no closed-loop gap to scale by: the formula
        # would rank a policy that beats the zero below it.
        raise ConfigError(
            f"J_best ({j_best!r}) is not below J_zero ({j_zero!r}): the best reference does not beat the "
            "blind zero, so the blind-zero score is undefined; compare J with both"
        )
    mean, draws = _pooled_draws(j if isinstance(j, (list, tuple)) else [j])
    score = (j_zero - draws) / (j_zero - j_best)
    return {"score": (j_zero - mean) / (j_zero - j_best), "lo": float(np.quantile(score, 0.025)),
            "hi": float(np.quantile(score, 0.975)), "J": mean}  # fmt: skip


def _pooled_draws(runs: Sequence[np.ndarray]) -> tuple[float, np.ndarray]:
    """The mean over runs of each run's mean over its evaluation seeds, and bootstrap draws of it: each
    draw picks a run, then resamples that run's seeds (both spreads in the draws)."""
    runs = [np.asarray(x, float) for x in runs]
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    draws = np.zeros(BOOTSTRAP_REPS)
    pick = rng.integers(0, len(runs), (BOOTSTRAP_REPS,))
    for r_i, r in enumerate(runs):
        sel = pick == r_i
        draws[sel] = r[rng.integers(0, r.size, (int(sel.sum()), r.size))].mean(axis=1)
    return float(np.mean([x.mean() for x in runs])), draws


def pooled_mean_interval(runs: Sequence[np.ndarray]) -> dict[str, float]:
    """Several training runs' per-seed values (e.g. paired differences [km]) pooled: the mean over runs
    and its 95 % interval from the two-level bootstrap of :func:`run_score` (a run, then its seeds)."""
    mean, draws = _pooled_draws(runs)
    return {"mean": mean, "lo": float(np.quantile(draws, 0.025)), "hi": float(np.quantile(draws, 0.975)),
            "runs": len(runs)}  # fmt: skip


# ---------------------------------------------------------------------------------------------------------
# Provenance and files
# ---------------------------------------------------------------------------------------------------------


def provenance() -> dict[str, Any]:
    """The commit, whether the tree was clean, what differed from the commit (``changes``: ``git status
    --porcelain`` lines, so result files written beside a run read as such), when, and the command: what
    a published number was printed from."""
    git = git_state(ROOT)
    return {"commit": git["git_commit"], "dirty": git["git_dirty"], "changes": git["git_changes"],
            "utc": utc_now(), "command": " ".join(sys.argv)}  # fmt: skip


def _world(cfg: EnvConfig) -> dict[str, Any]:
    return {g.name: getattr(cfg.world, g.name) for g in dataclasses.fields(cfg.world) if g.init}


def read_json(path: Path) -> dict[str, Any]:
    return json.loads(path.read_text()) if path.exists() else {"suite_version": SUITE_VERSION, "tasks": {}}


def write_json(path: Path, data: dict[str, Any]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=1) + "\n")


def normalization(task: str, path: Path = NORMALIZATION_FILE) -> dict[str, Any]:
    """The published J_zero and J_best of v3 ``task`` (``Cruise-Target-v3``) from the versioned file."""
    rec = read_json(path)["tasks"].get(task)
    if rec is None:
        raise ConfigError(f"no published normalization for {task!r} in {path}: run `python -m "
                          f"planetnav_train.suite.v3 normalize --tasks {task}`")  # fmt: skip
    return rec


def published_scale(task: str, path: Path = NORMALIZATION_FILE) -> tuple[float, float] | None:
    """(J_zero, J_best) [km] of v3 ``task`` where its blind-zero score is defined: the task is normalized
    and its best reference beats its zero (J_best < J_zero). None otherwise (a cruise, whose references
    lose to the zero, has J and no score)."""
    try:
        norm = normalization(task, path)
    except ConfigError:
        return None
    jz, jb = float(norm["J_zero"]["mean"]), float(norm["J_best"]["mean"])
    return (jz, jb) if jb < jz else None


# ---------------------------------------------------------------------------------------------------------
# The commands
# ---------------------------------------------------------------------------------------------------------


def reward_constants(
    env_id: str, episodes: int, seed: int = NORMALIZATION_SEED, **overrides: Any
) -> dict[str, Any]:
    """The reward baseline and scale of v3 task ``env_id`` (planetnav_env.tasks.constants): uniform random
    in the task's interface on ``episodes`` normalization seeds; ``b`` the mean error term per bin of
    physics steps (one bin per decision; :data:`TORQUE_BASELINE_BINS` for a task deciding every step),
    ``s`` the standard deviation of a decision's sum of ``e_k - b(k)`` (``overrides``: options over the
    task's, for smoke runs)."""
    cfg = eval_config(env_id, reward_baseline_km=(), **overrides)
    pol = (BlindTorques("random", np.zeros((cfg.episode_decisions, 3)), 1.0) if cfg.action_mode == "torque"
           else BlindTargets("uniform", np.full((cfg.episode_decisions, cfg.n_target_actions),
                                                1.0 / cfg.n_target_actions)))  # fmt: skip
    e = roll_out(cfg, pol, range(seed, seed + episodes), terms=True).terms
    k_n = cfg.episode_steps
    n_bins = cfg.episode_decisions if cfg.decision_steps > 1 else min(TORQUE_BASELINE_BINS, k_n)
    bin_of = (np.arange(k_n) * n_bins) // k_n  # physics step k = 1..K is column k - 1
    base = np.array([e[:, bin_of == j].mean() for j in range(n_bins)])
    resid = e - base[bin_of][None, :]
    dec = np.arange(k_n) // cfg.decision_steps
    per_decision = np.stack([resid[:, dec == j].sum(axis=1) for j in range(cfg.episode_decisions)], axis=1)
    scale = float(per_decision.std())
    raw = e.sum(axis=1)
    return {
        "scale_km": scale, "baseline_km": [round(float(b), 6) for b in base], "bins": n_bins,
        "policy": pol.name, "seed": seed, "episodes": episodes, "world": _world(cfg),
        # What the posing does: a decision's reward under uniform random, raw (v2's form) and posed.
        "per_decision_raw_std": float((-e.reshape(episodes, -1, cfg.decision_steps).sum(axis=2)
                                       / 1000.0).std()) if k_n % cfg.decision_steps == 0 else None,
        "per_decision_posed_std": 1.0,
        "episode_error_sum_km": mean_interval(raw),
    }  # fmt: skip


def search(env_id: str, episodes: int, final_episodes: int, cem: dict[str, int], log=print) -> dict[str, Any]:
    """The blind-zero search of v3 task ``env_id``: every candidate of the task's family and the
    cross-entropy method's (optimized on the search seeds) on ``episodes`` search seeds; the best
    :data:`FINALISTS` again on ``final_episodes`` fresh seeds, the lowest mean there wins."""
    cfg = eval_config(env_id)
    seeds = range(SEARCH_SEED, SEARCH_SEED + episodes)
    if cfg.action_mode == "torque":
        cands: list[Any] = torque_candidates(cfg)
        cands += cem_torques(
            cfg, seeds[: cem["episodes"]], cem["bins"], cem["population"], cem["iterations"], log=log
        )
    else:
        cands = target_candidates(cfg)
        cands += cem_targets(
            cfg, seeds[: cem["episodes"]], cem["bins"], cem["population"], cem["iterations"], log=log
        )
    by_name = {c.name: c for c in cands}
    first: dict[str, float] = {}
    t0 = time.time()
    for c in cands:
        first[c.name] = float(roll_out(cfg, c, seeds).objective.mean())
    log(f"{env_id}: {len(cands)} candidates on {episodes} search seeds in {time.time() - t0:.0f} s")
    names = sorted(first, key=first.__getitem__)[:FINALISTS]
    final = _second_stage(cfg, {n: by_name[n] for n in names}, first, final_episodes, log)
    winner = min(final, key=final.__getitem__)
    return {"winner": winner, "finalists": final, "candidates": first, "search_seed": SEARCH_SEED,
            "search_episodes": episodes, "final_seed": FINAL_SEED, "final_episodes": final_episodes,
            "cem": cem, "world": _world(cfg),
            "policies": {n: _policy_record(by_name[n]) for n in final}}  # fmt: skip


def _second_stage(
    cfg: EnvConfig, finalists: dict[str, Any], first: dict[str, float], final_episodes: int, log=print
) -> dict[str, float]:
    """Each finalist's mean J on ``final_episodes`` seeds from :data:`FINAL_SEED` (``first``: its
    stage-one mean, logged beside it)."""
    seeds = range(FINAL_SEED, FINAL_SEED + final_episodes)
    final: dict[str, float] = {}
    for name, pol in finalists.items():
        final[name] = float(roll_out(cfg, pol, seeds).objective.mean())
        log(f"  final {name}: {final[name]:.2f} km (search {first[name]:.2f})")
    return final


def refinal(env_id: str, record: dict[str, Any], final_episodes: int, log=print) -> dict[str, Any]:
    """The search ``record`` of v3 task ``env_id`` with its second stage run again on ``final_episodes``
    seeds from :data:`FINAL_SEED`: the same finalists (their stage-one ranks kept), a new winner where more
    seeds separate them. For a task whose finalists lie closer than the first second stage resolves; the
    search seeds' stage is not repeated."""
    cfg = eval_config(env_id)
    if final_episodes > NORMALIZATION_SEED - FINAL_SEED:
        raise ConfigError(f"final_episodes={final_episodes}: the block from {FINAL_SEED} holds "
                          f"{NORMALIZATION_SEED - FINAL_SEED} seeds")  # fmt: skip
    finalists = {n: policy_from_record(n, r) for n, r in record["policies"].items()}
    final = _second_stage(cfg, finalists, record["candidates"], final_episodes, log)
    out = {**record, "winner": min(final, key=final.__getitem__), "finalists": final,
           "final_episodes": final_episodes}  # fmt: skip
    if "provenance" in record:  # the run of the first stage, kept beside this one's
        out["first_stage_provenance"] = record["provenance"]
    return out


def _policy_record(p: Any) -> dict[str, Any]:
    """A finalist as data (the winner is rebuilt from it by :func:`policy_from_record`)."""
    if isinstance(p, BlindTorques):
        return {"kind": "torques", "torques": np.round(p.torques, 6).tolist(), "noise": p.noise}
    return {"kind": "targets", "probs": np.round(p.probs, 6).tolist(), "hold": p.hold}


def policy_from_record(name: str, rec: dict[str, Any]) -> BlindTargets | BlindTorques:
    if rec["kind"] == "torques":
        return BlindTorques(name, np.asarray(rec["torques"], float), float(rec["noise"]))
    probs = np.asarray(rec["probs"], float)
    return BlindTargets(name, probs / probs.sum(axis=1, keepdims=True), int(rec["hold"]))


def zero_check(env_id: str, episodes: int, blind: dict[str, Any], log=print) -> dict[str, Any]:
    """The search's winner of v3 task ``env_id`` on ``episodes`` unseen evaluation seeds from
    :data:`EVAL_SEED` (J_zero with its interval), and every other finalist against it, paired: the zero
    holds where the interval of finalist minus zero reaches 0 or above. Blind roll-outs only (no
    reference), so it runs where the references' cost keeps a task from :func:`normalize`."""
    cfg = eval_config(env_id)
    seeds = range(EVAL_SEED, EVAL_SEED + episodes)
    finalists = {n: policy_from_record(n, r) for n, r in blind["policies"].items()}
    jz = roll_out(cfg, finalists[blind["winner"]], seeds).objective
    log(f"{env_id}: zero {blind['winner']}: {jz.mean():.2f} km")
    checks = {}
    for name, pol in finalists.items():
        if name == blind["winner"]:
            continue
        diff = paired_difference(roll_out(cfg, pol, seeds).objective, jz)
        checks[name] = {**diff, "zero_holds": diff["hi"] >= 0.0}
        log(f"  finalist {name}: paired minus zero {diff['mean']:+.2f} "
            f"[{diff['lo']:+.2f}, {diff['hi']:+.2f}]")  # fmt: skip
    return {"jz": jz, "J_zero": mean_interval(jz), "zero": blind["winner"], "finalists_vs_zero": checks,
            "eval_seed": EVAL_SEED, "eval_episodes": episodes, "world": _world(cfg)}  # fmt: skip


def _headline(gap: dict[str, float]) -> bool:
    """The headline rule on a closed-loop gap record: the gap and its interval's lower bound."""
    return bool(gap["gap"] >= HEADLINE_GAP and gap["gap_lo"] >= HEADLINE_GAP_LO)


def normalize(env_id: str, episodes: int, blind: dict[str, Any], log=print) -> dict[str, Any]:
    """J_zero (the search's winner) and J_best (the best non-privileged reference) of v3 task ``env_id`` on
    ``episodes`` evaluation seeds from :data:`EVAL_SEED`, with their intervals; the closed-loop gap with its
    paired interval and the headline flag; and every finalist against the winner, paired (the check that
    no searched candidate beats the published zero on unseen seeds, :func:`zero_check`)."""
    from planetnav_train.suite.blind import paired_ratio_ci

    cfg = eval_config(env_id)
    zero = zero_check(env_id, episodes, blind, log)
    jz = zero.pop("jz")
    refs = {}
    for spec in V3_TASKS[env_id.split("/", 1)[-1]]:
        try:
            refs[spec] = policy_objective(cfg, spec, EVAL_SEED, episodes)
        except Exception as exc:  # a reference that cannot act here is reported, not fatal
            log(f"  reference {spec}: not evaluated ({type(exc).__name__}: {exc})")
            continue
        log(f"  reference {spec}: {refs[spec].mean():.2f} km")
    best = min(refs, key=lambda s: refs[s].mean())
    jb = refs[best]
    gap = paired_ratio_ci(jz, jb)
    return {
        "J_zero": zero["J_zero"], "zero": zero["zero"], "J_best": mean_interval(jb), "best_reference": best,
        "references": {s: mean_interval(v) for s, v in refs.items()},
        "closed_loop_gap": gap,
        "headline": _headline(gap),
        "finalists_vs_zero": zero["finalists_vs_zero"], "eval_seed": EVAL_SEED, "eval_episodes": episodes,
        "world": zero["world"],
        "per_seed": {"zero": np.round(jz, 4).tolist(), "best": np.round(jb, 4).tolist()},
    }  # fmt: skip


def add_reference(env_id: str, record: dict[str, Any], spec: str, log=print) -> dict[str, Any]:
    """``record`` (a task's :func:`normalize` record) with reference ``spec`` scored on the record's own
    evaluation seeds and paired with its per-seed zero; where it beats J_best it becomes J_best, and the
    gap and the headline flag follow. The rest of the record (the zero, the other references) is kept: a
    reference added to the list needs no rerun of them."""
    from planetnav_train.suite.blind import paired_ratio_ci

    if spec in record["references"]:
        raise ConfigError(f"{env_id}: reference {spec!r} is in the record already; rerun normalize instead")
    jz = np.asarray(record["per_seed"]["zero"], float)
    j = policy_objective(eval_config(env_id), spec, int(record["eval_seed"]), int(record["eval_episodes"]))
    log(f"  reference {spec}: {j.mean():.2f} km")
    record["references"][spec] = mean_interval(j)
    if j.mean() < record["J_best"]["mean"]:
        gap = paired_ratio_ci(jz, j)
        record.update(
            J_best=mean_interval(j), best_reference=spec, closed_loop_gap=gap,
            headline=_headline(gap),
        )  # fmt: skip
        record["per_seed"]["best"] = np.round(j, 4).tolist()
    record.setdefault("added_references", {})[spec] = provenance()
    return record


ID_OPTIONS = ROOT / "tests" / "golden" / "id_options.json"


def record_ids(path: Path = ID_OPTIONS) -> None:
    """Write the v3 ids' resolved options into the id oracle (their reward constants are measured, so
    their entries follow the reward command); every other id's entry is kept as it is."""
    from planetnav_env.envs.registration import id_options

    data = json.loads(path.read_text())
    for task in V3_TASKS:
        env_id = f"planetnav/{task}"
        data["ids"][env_id] = {"options": EnvConfig.from_dict(id_options(env_id)).to_dict()}
    path.write_text(json.dumps(data, indent=1))


# ---------------------------------------------------------------------------------------------------------
# Learner rows
# ---------------------------------------------------------------------------------------------------------
#
# Learner rows of suite version 3: off-the-shelf PPO, an untrained network and uniform random, each with
# its policy's entropy, scored against the published constants (docs/tasks_v3_normalization.json).
#
# - **PPO**: Stable-Baselines3's ``PPO("MlpPolicy", env)`` with every default, ``env =
#   make_vec_env("planetnav/<id>")`` (SB3's own helper, its default of one env), trained for ``budget``
#   decisions (SB3 timesteps) from ``seed``. Nothing is tuned per task. DQN (discrete tasks) and SAC (the
#   torque task) the same way, with ``--algo`` (:data:`LEARNERS`).
# - **untrained**: the same network before training (SB3's initialization from the same seed).
# - **uniform**: uniform random actions in the task's interface.
#
# Each is evaluated with sampled actions on the evaluation seeds (:data:`EVAL_SEED`.., per-step noise
# streams) by :func:`roll_out`; its entropy [nats] is the mean of
# the action distribution's entropy over the observations it meets there (uniform: ``log A``; for a torque
# task the Gaussian's differential entropy, SB3's own ``entropy()``). With a published normalization the
# row has its blind-zero score and interval (:func:`run_score`). Beside them, on the same seeds, the
# published blind zero and the best reference, and each row's paired difference from both.


#: The learners a row can train: SB3 class name, and how the row acts. PPO's stochastic policy is scored
#: with sampled actions (its argmax can collapse to one action); DQN's and SAC's with their deterministic
#: actions (DQN's greedy action, SAC's mean), the policies those algorithms are meant to be evaluated with.
LEARNERS: dict[str, tuple[str, str]] = {"ppo": ("PPO", "sampled"), "dqn": ("DQN", "deterministic"),
                                        "sac": ("SAC", "deterministic")}  # fmt: skip


def _policy_fn(model: Any, entropies: list[float], deterministic: bool = False, seed: int = 0):
    """(decision, observations) -> actions of an SB3 model: sampled from one torch generator seeded
    ``seed`` (:func:`_draw`: a model's score is a function of the model and the seeds, not of torch's
    global stream), recording each batch's mean entropy; or ``deterministic`` (entropy 0 recorded: the
    policy scored is deterministic)."""
    import torch
    from stable_baselines3.common.distributions import CategoricalDistribution, DiagGaussianDistribution

    gen = torch.Generator().manual_seed(seed)
    if not deterministic and not hasattr(model.policy, "get_distribution"):
        raise ConfigError(
            f"sampled actions of a {type(model.policy).__name__}: it exposes no action distribution "
            "(an off-policy actor such as SAC's); score it deterministic"
        )

    def act(d: int, obs: np.ndarray) -> np.ndarray:
        if deterministic:
            entropies.append(0.0)
            a, _ = model.predict(obs, deterministic=True)
            return np.asarray(a)
        with torch.no_grad():
            t, _ = model.policy.obs_to_tensor(obs)
            dist = model.policy.get_distribution(t)
            entropies.append(float(dist.entropy().mean()))
            # exact types: a squashed Gaussian is a DiagGaussianDistribution whose draws need a tanh
            if type(dist) not in (CategoricalDistribution, DiagGaussianDistribution):
                raise ConfigError(
                    f"sampled actions of a {type(dist).__name__}: only a categorical or a diagonal "
                    "Gaussian policy is drawn from the evaluation's generator"
                )
            a = _draw(dist.distribution, gen)
        if model.action_space.shape:
            a = np.clip(a, model.action_space.low, model.action_space.high)
        return a

    return act


def _draw(dist: Any, gen: Any) -> np.ndarray:
    """One action per row from a torch ``Categorical`` or ``Normal`` (a diagonal Gaussian, (N, dim)) with
    generator ``gen``: the one sampling rule of the learned policies' rows (SB3's and the single-file
    PPO's), so two evaluations of one policy on the same seeds draw the same actions."""
    import torch
    from torch.distributions import Categorical

    if isinstance(dist, Categorical):
        return torch.multinomial(dist.probs, 1, True, generator=gen)[:, 0].numpy()
    return (dist.loc + torch.randn(dist.loc.shape, generator=gen) * dist.scale).numpy()


def _row(
    name: str, j: np.ndarray, entropy: float, task: str, extra: dict[str, Any], unscored: str | None = None
) -> dict[str, Any]:
    """A learner row: J, entropy and the blind-zero score against ``task``'s constants; ``unscored``: why
    the row has no score though the task has constants (it was made in another world)."""
    row = {"policy": name, "J": mean_interval(j), "entropy_nats": entropy, **extra}
    if unscored is not None:
        row["score"], row["score_undefined"] = None, unscored
        return row
    try:
        norm = normalization(task)
    except ConfigError:  # no published constants yet: the row carries J only
        row["score"] = None
    else:
        try:
            row["score"] = run_score(j, norm["J_zero"]["mean"], norm["J_best"]["mean"])
        except ConfigError as exc:  # the task's references lose to its zero: J is the row's figure
            row["score"], row["score_undefined"] = None, str(exc)
    return row


def _recorded_per_seed(
    norm: dict[str, Any] | None, cfg: EnvConfig, task: str, seeds: range
) -> dict[str, np.ndarray] | None:
    """The normalization record's per-seed J of the zero and the best reference on ``seeds``, where the
    record holds them: the task's own evaluation configuration and seeds inside the record's (a rule
    reference on 1,000 seeds is minutes; the record is the same roll-out, held to the current code by
    ``tests/train/test_suite_v3.py``). None where they must be rolled out."""
    if norm is None or "per_seed" not in norm or cfg != eval_config(f"planetnav/{task}"):
        return None
    first = seeds.start - int(norm["eval_seed"])
    if seeds.step != 1 or first < 0 or first + len(seeds) > int(norm["eval_episodes"]):
        return None
    return {k: np.asarray(norm["per_seed"][k][first : first + len(seeds)], float) for k in ("zero", "best")}


def _paired_with_published(
    rows: dict[str, Any], per_seed: dict[str, np.ndarray], cfg: EnvConfig, task: str, seeds: range
) -> None:
    """Add the published zero (the search's winner) and, where the task is normalized, its best
    reference as rows on the same seeds, and each learner row's paired difference from them [km]
    (``minus_zero``, ``minus_best_reference``: negative is better); ``per_seed`` keeps each row's J per
    evaluation seed (runs pooled over training seeds pair on them). Where the blind-zero score is
    undefined (the references lose to the zero), these are the rows' comparisons."""
    rows["per_seed"] = {name: np.round(j, 4).tolist() for name, j in per_seed.items()}
    blind = read_json(BLIND_FILE)["tasks"].get(task)
    try:
        norm = normalization(task)
    except ConfigError:  # not normalized yet: no reference row
        norm = None
    recorded = _recorded_per_seed(norm, cfg, task, seeds)
    others: dict[str, np.ndarray] = {}
    if blind is not None:
        if recorded is not None and norm["zero"] == blind["winner"]:
            others["zero"] = recorded["zero"]
        else:
            zero = policy_from_record(blind["winner"], blind["policies"][blind["winner"]])
            others["zero"] = roll_out(cfg, zero, seeds).objective
        rows["rows"].append({"policy": f"blind zero ({blind['winner']})", "J": mean_interval(others["zero"])})
        rows["per_seed"]["zero"] = np.round(others["zero"], 4).tolist()
    if norm is not None:
        best = norm["best_reference"]
        others["best_reference"] = (
            recorded["best"] if recorded is not None else policy_objective(cfg, best, seeds.start, len(seeds))
        )
        j_best = others["best_reference"]
        rows["rows"].append({"policy": f"best reference ({best})", "J": mean_interval(j_best)})
        rows["per_seed"]["best_reference"] = np.round(j_best, 4).tolist()
    for r in rows["rows"]:
        j = per_seed.get(r["policy"])
        if j is not None:
            for name, other in others.items():
                r[f"minus_{name}"] = paired_difference(j, other)


def _published_on(
    task: str, episode_steps: int, seeds: range, world: bool
) -> tuple[dict[str, np.ndarray] | None, tuple[float, float] | None]:
    """The published constants a learning curve pairs with (:data:`v3_curves.Published`)."""
    try:
        norm = normalization(task)
    except ConfigError:  # not normalized: J alone
        return None, None
    if world:  # another world: the task's constants are not its
        return None, None
    cfg = eval_config(f"planetnav/{task}", episode_steps=episode_steps)
    return _recorded_per_seed(norm, cfg, task, seeds), published_scale(task)


def curve_table(runs: Sequence[dict[str, Any]], label: str | None = None) -> dict[str, Any]:
    """:func:`v3_curves.curve_table` against the published constants."""
    return v3_curves.curve_table(runs, _published_on, label)


def learner_rows(
    task: str,
    budget: int,
    seed: int = 0,
    episodes: int = 100,
    episode_steps: int | None = None,
    ppo_overrides: dict[str, Any] | None = None,
    target_actions: str | None = None,
    algo: str = "ppo",
    save_model: str | Path | None = None,
    world: dict[str, Any] | None = None,
    curve_points: int = v3_curves.CURVE_POINTS,
    curve_episodes: int = v3_curves.CURVE_EPISODES,
) -> dict[str, Any]:
    """PPO (SB3 defaults via ``make_vec_env``), the untrained network and uniform random on v3 ``task``
    (``Cruise-Target-v3``): J on ``episodes`` evaluation seeds, entropy, score. ``episode_steps`` shortens
    the episodes and ``ppo_overrides`` changes PPO's arguments: smoke runs only (the command passes
    neither, and a row made with them is not the task's). ``target_actions``: ``relative`` to measure
    relative target actions against the task's absolute ones (same seeds, same budget). ``algo``: a key of
    :data:`LEARNERS` (``dqn`` on a discrete task, ``sac`` on the torque task), SB3's defaults as for PPO;
    ``ppo_overrides`` then applies to it. ``save_model``: where to save the trained model (SB3's zip), to
    study its behaviour afterwards. ``world``: world options merged into the task's flight world for
    training and every row alike (a regime sweep, e.g. ``{"boresight_drift": False}``; a row made with it
    is not the task's, and its score against the task's constants is not one). ``curve_points`` (0: none)
    and ``curve_episodes``: the learning curve's points and seeds (:mod:`planetnav_train.suite.v3_curves`;
    at most ``episodes`` seeds)."""
    import stable_baselines3
    from stable_baselines3.common.env_util import make_vec_env

    if algo not in LEARNERS:
        raise ConfigError(f"algo {algo!r}: one of {sorted(LEARNERS)}")
    cls_name, acting = LEARNERS[algo]

    env_id = f"planetnav/{task}"
    over: dict[str, Any] = {"episode_steps": episode_steps} if episode_steps else {}
    if target_actions:  # the absolute-versus-relative measurement (docs/tasks_md)
        over["target_actions"] = target_actions
    unscored = None
    if world:  # the task's constants belong to its own world: no score on another's
        over["world"] = dict(world)
        unscored = f"world overrides {dict(world)}: not the task's world"
    cfg: EnvConfig = eval_config(env_id, **over)
    seeds = range(EVAL_SEED, EVAL_SEED + episodes)
    discrete = cfg.action_mode != "torque"
    if (algo == "dqn" and not discrete) or (algo == "sac" and discrete):
        raise ConfigError(f"algo {algo!r} does not fit {task}'s {'discrete' if discrete else 'Box'} actions")
    venv = make_vec_env(env_id, seed=seed, env_kwargs=over)
    cls = getattr(stable_baselines3, cls_name)
    model = cls("MlpPolicy", venv, seed=seed, verbose=0, **(ppo_overrides or {}))
    det = acting == "deterministic"
    rows: dict[str, Any] = {"task": task, "algo": algo, "acting": acting,
                            "target_actions": cfg.target_actions, "budget_decisions": budget, "seed": seed,
                            "episodes": episodes, "episode_steps": cfg.episode_steps,
                            "world_overrides": dict(world or {}),
                            "learner_overrides": dict(ppo_overrides or {}), "rows": []}  # fmt: skip
    ent: list[float] = []
    per_seed = {"untrained network": (j := roll_out(cfg, _policy_fn(model, ent, det), seeds).objective)}
    rows["rows"].append(_row("untrained network", j, float(np.mean(ent)), task, {}, unscored))
    uniform, h_uniform = _uniform(cfg)
    per_seed["uniform random"] = j = roll_out(cfg, uniform, seeds).objective
    rows["rows"].append(_row("uniform random", j, h_uniform, task, {}, unscored))
    callback = None
    if curve_points:
        curve_seeds = range(EVAL_SEED, EVAL_SEED + min(curve_episodes, episodes))
        callback = v3_curves.curve_callback(
            lambda: roll_out(cfg, _policy_fn(model, [], det), curve_seeds).objective, budget, curve_points
        )
    t0 = time.time()
    model.learn(total_timesteps=budget, callback=callback)
    train_s = time.time() - t0 - (callback.seconds if callback is not None else 0.0)
    if callback is not None:
        rows["learning_curve"] = {"seeds": [curve_seeds.start, len(curve_seeds)], "draw_seed": 0,
                                  "seconds": callback.seconds, **callback.curve}  # fmt: skip
    ent = []
    name = f"SB3 {cls_name} (defaults, make_vec_env)"
    per_seed[name] = j = roll_out(cfg, _policy_fn(model, ent, det), seeds).objective
    rows["rows"].append(_row(name, j, float(np.mean(ent)), task, {"train_seconds": train_s}, unscored))
    venv.close()
    if save_model is not None:
        model.save(save_model)
        rows["model"] = str(save_model)
    # The published policies act in the task's own interface: a blind cycle's action indices would mean
    # other targets under relative actions.
    published_cfg = eval_config(env_id, **{k: v for k, v in over.items() if k != "target_actions"})
    _paired_with_published(rows, per_seed, published_cfg, task, seeds)
    rows["provenance"] = provenance()
    return rows


SINGLE_FILE_PPO = ROOT / "baselines" / "ppo_single_file.py"
CONTINUOUS_PPO = ROOT / "baselines" / "ppo_continuous.py"


def _script(path: Path) -> Any:
    """A baselines/ script as a module (a script, not a package: loaded from its path)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(path.stem, path)
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    return script


def single_file_ppo() -> Any:
    """``baselines/ppo_single_file.py`` as a module."""
    return _script(SINGLE_FILE_PPO)


def continuous_ppo() -> Any:
    """``baselines/ppo_continuous.py`` (the single-file PPO with a Gaussian head) as a module."""
    return _script(CONTINUOUS_PPO)


def _load_single_file(agent_path: str | Path, cfg: EnvConfig, task: str) -> tuple[Any, Any]:
    """(agent, its script) of a saved single-file agent: a Categorical one on a target task, a Gaussian
    one (ppo_continuous's, its state holding ``log_std``) on a torque task; anything else refused."""
    import pickle

    import torch

    try:
        state = torch.load(agent_path, map_location="cpu")
    except (OSError, RuntimeError, EOFError, pickle.UnpicklingError) as e:
        raise ConfigError(f"{agent_path}: not a saved agent ({str(e).splitlines()[0]})") from e
    if not isinstance(state, dict) or "actor.0.weight" not in state:
        raise ConfigError(f"{agent_path}: not a saved agent (no actor.0.weight in its state)")
    gaussian = "log_std" in state
    script = continuous_ppo() if gaussian else single_file_ppo()
    agent = script.load_agent(agent_path)
    n_a = agent.actor[-1].out_features
    if gaussian and (cfg.action_mode != "torque" or n_a != 3):
        raise ConfigError(f"{agent_path}: a Gaussian agent of {n_a} action dimensions does not fit {task}")
    if not gaussian and (cfg.action_mode == "torque" or n_a != cfg.n_target_actions):
        raise ConfigError(f"{agent_path}: an agent of {n_a} discrete actions does not fit {task}")
    return agent, script


def _sampler(agent: Any, seed: int, ent: list[float]):
    """(decision, observations) -> a single-file agent's sampled actions, from one torch generator seeded
    ``seed``, recording each batch's mean entropy (nats; a Gaussian's differential entropy summed over its
    axes). The env clips a Gaussian's sample to the Box."""
    import torch
    from torch.distributions import Categorical

    gen = torch.Generator().manual_seed(seed)
    gaussian = hasattr(agent, "log_std")

    def act(d: int, obs: np.ndarray) -> np.ndarray:
        with torch.no_grad():
            x = torch.as_tensor(obs, dtype=torch.float32)
            if gaussian:
                dist = agent.distribution(x)
                ent.append(float(dist.entropy().sum(-1).mean()))
            else:
                dist = Categorical(logits=agent.actor(x))
                ent.append(float(dist.entropy().mean()))
            return _draw(dist, gen)

    return act


def _uniform(cfg: EnvConfig) -> tuple[BlindTargets | BlindTorques, float]:
    """Uniform random actions in ``cfg``'s interface and their entropy [nats] (a torque box's: the
    differential entropy of U(-1, 1)^3)."""
    if cfg.action_mode == "torque":
        return BlindTorques("uniform", np.zeros((cfg.episode_decisions, 3)), 1.0), 3 * math.log(2.0)
    n_a = cfg.n_target_actions
    return BlindTargets("uniform", np.full((cfg.episode_decisions, n_a), 1.0 / n_a)), math.log(n_a)


def agent_rows(
    task: str, agent_path: str | Path, episodes: int = 100, seed: int = 0, train_seed: int | None = None
) -> dict[str, Any]:
    """The single-file PPO's saved agent (``baselines/ppo_single_file.py --save-model``, or
    ``baselines/ppo_continuous.py``'s on the torque task) on v3 ``task``: sampled actions (one torch
    generator seeded ``seed``) on the evaluation seeds, its entropy, score, and its paired difference from
    the published zero and best reference, as :func:`learner_rows` reports. With ``train_seed`` (the
    script's ``--seed``), the untrained network (the script's initialization: torch seeded with it, then
    the agent built) and uniform random come first, under the same draws."""
    import torch

    cfg = eval_config(f"planetnav/{task}")
    agent, script = _load_single_file(agent_path, cfg, task)
    gaussian = hasattr(agent, "log_std")
    name = "single-file PPO (Gaussian)" if gaussian else "single-file PPO"
    seeds = range(EVAL_SEED, EVAL_SEED + episodes)
    rows: dict[str, Any] = {"task": task, "algo": "ppo_single_file", "acting": "sampled",
                            "agent": str(agent_path), "episodes": episodes, "rows": []}  # fmt: skip
    per_seed: dict[str, np.ndarray] = {}
    if train_seed is not None:
        rows["seed"] = train_seed
        torch.manual_seed(train_seed)
        obs_dim = agent.actor[0].in_features
        n_out = 3 if gaussian else cfg.n_target_actions
        untrained = (script.GaussianAgent if gaussian else script.Agent)(obs_dim, n_out)
        ent: list[float] = []
        per_seed["untrained network"] = j = roll_out(cfg, _sampler(untrained, seed, ent), seeds).objective
        rows["rows"].append(_row("untrained network", j, float(np.mean(ent)), task, {}))
        uniform, h_uniform = _uniform(cfg)
        per_seed["uniform random"] = j = roll_out(cfg, uniform, seeds).objective
        rows["rows"].append(_row("uniform random", j, h_uniform, task, {}))
    ent = []
    per_seed[name] = j = roll_out(cfg, _sampler(agent, seed, ent), seeds).objective
    rows["rows"].append(_row(name, j, float(np.mean(ent)), task, {}))
    _paired_with_published(rows, per_seed, cfg, task, seeds)
    rows["provenance"] = provenance()
    return rows


def _tasks(arg: Sequence[str] | None) -> list[str]:
    names = list(arg) if arg else list(V3_TASKS)
    bad = [t for t in names if t not in V3_TASKS]
    if bad:
        raise ConfigError(f"not v3 tasks: {bad}; the v3 tasks are {list(V3_TASKS)}")
    return names


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m planetnav_train.suite.v3", description=__doc__.split("\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser(
        "reward", help="the reward baseline and scale (planetnav_env/tasks/tasks_v3_reward.json)"
    )
    r.add_argument("--episodes", type=int, default=NORMALIZATION_EPISODES)
    s = sub.add_parser("search", help="the blind-zero search (docs/tasks_v3_blind.json)")
    s.add_argument("--episodes", type=int, default=SEARCH_EPISODES)
    s.add_argument("--final-episodes", type=int, default=FINAL_EPISODES)
    s.add_argument("--cem-episodes", type=int, default=8)
    s.add_argument("--cem-bins", type=int, default=12)
    s.add_argument("--cem-population", type=int, default=16)
    s.add_argument("--cem-iterations", type=int, default=4)
    s.add_argument(
        "--final-only",
        action="store_true",
        help="rerun only the second stage of the published search, on --final-episodes seeds",
    )
    n = sub.add_parser("normalize", help="J_zero and J_best (docs/tasks_v3_normalization.json)")
    n.add_argument("--episodes", type=int, default=EVAL_EPISODES)
    n.add_argument(
        "--add-reference", metavar="SPEC",
        help="score one more reference on each task's published record (its seeds, paired with its zero) "
        "instead of rerunning the whole normalization",
    )  # fmt: skip
    z = sub.add_parser(
        "zero-check", help="the search's winner and finalists on unseen seeds (blind roll-outs, no reference)"
    )
    z.add_argument("--episodes", type=int, default=EVAL_EPISODES)
    lr = sub.add_parser(
        "learners", help="SB3 PPO (defaults, make_vec_env), an untrained network, uniform random"
    )
    lr.add_argument("--task", required=True)
    lr.add_argument("--budget", type=int, default=300_000, help="decisions")
    lr.add_argument("--seed", type=int, default=0)
    lr.add_argument("--episodes", type=int, default=100, help="evaluation seeds from EVAL_SEED")
    lr.add_argument("--episode-steps", type=int, default=None, help="shorter episodes (smoke runs only)")
    lr.add_argument("--out", default=None, help="write the rows as JSON here")
    lr.add_argument(
        "--target-actions",
        default=None,
        choices=("absolute", "relative"),
        help="override the task's absolute target actions (the relative-action measurement)",
    )
    lr.add_argument("--algo", default="ppo", choices=sorted(LEARNERS), help="the SB3 learner (its defaults)")
    lr.add_argument("--save-model", default=None, help="save the trained model here (SB3's zip)")
    lr.add_argument(
        "--curve-points", type=int, default=v3_curves.CURVE_POINTS, help="learning-curve points (0: none)"
    )
    lr.add_argument(
        "--curve-episodes", type=int, default=v3_curves.CURVE_EPISODES, help="evaluation seeds a point"
    )
    cv = sub.add_parser("curves", help="the learning curves of learners files: a table, and --plot a figure")
    cv.add_argument("files", nargs="+", help="files the learners command wrote (--out)")
    cv.add_argument("--plot", default=None, help="write the figure here (PNG)")
    ag = sub.add_parser(
        "agent-rows",
        help="score a saved single-file PPO agent (baselines/ppo_single_file.py, ppo_continuous.py)",
    )
    ag.add_argument("--task", required=True)
    ag.add_argument("--agent", required=True, help="the state_dict that --save-model wrote")
    ag.add_argument("--episodes", type=int, default=100, help="evaluation seeds from EVAL_SEED")
    ag.add_argument("--train-seed", type=int, default=None,
                    help="the script's --seed: adds its untrained network and uniform random")  # fmt: skip
    ag.add_argument("--out", default=None, help="write the rows as JSON here")
    for q in (r, s, n):
        q.add_argument("--tasks", nargs="*", default=None)
        q.add_argument("--out", default=None, help="the file to write (default: the published one)")
    z.add_argument("--tasks", nargs="*", default=None)
    z.add_argument("--out", default=None, help="write the checks as JSON here")
    sub.add_parser("record-ids", help="the v3 ids' entries of tests/golden/id_options.json (after `reward`)")
    args = p.parse_args(argv)
    if args.cmd == "record-ids":
        record_ids()
        return 0
    if args.cmd == "agent-rows":
        rows = agent_rows(args.task, args.agent, args.episodes, train_seed=args.train_seed)
        print(json.dumps(rows, indent=1))
        if args.out:
            write_json(Path(args.out), rows)
        return 0
    if args.cmd == "learners":
        rows = learner_rows(
            args.task,
            args.budget,
            args.seed,
            args.episodes,
            args.episode_steps,
            target_actions=args.target_actions,
            algo=args.algo,
            save_model=args.save_model,
            curve_points=args.curve_points,
            curve_episodes=args.curve_episodes,
        )
        print(json.dumps(rows, indent=1))
        if args.out:
            write_json(Path(args.out), rows)
        return 0
    if args.cmd == "curves":
        runs = [read_json(Path(f)) for f in args.files]
        groups = v3_curves.group_runs([r for r in runs if r.get("learning_curve")])
        if not groups:
            raise ConfigError(f"none of the {len(runs)} files carries a learning_curve")
        tables = [curve_table(g, label=key[1]) for key, g in sorted(groups.items())]
        for t in tables:
            print("\n".join(v3_curves.format_table(t)))
        if args.plot:
            print(f"wrote {v3_curves.write_plot(tables, Path(args.plot))}")
        return 0
    if args.cmd == "zero-check":
        blinds = read_json(BLIND_FILE)["tasks"]
        out: dict[str, Any] = {"suite_version": SUITE_VERSION, "tasks": {}}
        for task in _tasks(args.tasks):
            if task not in blinds:
                raise ConfigError(f"{task}: no blind search in {BLIND_FILE}; run the search first")
            rec = zero_check(f"planetnav/{task}", args.episodes, blinds[task])
            rec["per_seed_zero"] = np.round(rec.pop("jz"), 4).tolist()
            out["tasks"][task] = rec
            held = all(c["zero_holds"] for c in rec["finalists_vs_zero"].values())
            jz = rec["J_zero"]
            print(f"{task}: J_zero {jz['mean']:.2f} [{jz['lo']:.2f}, {jz['hi']:.2f}] ({rec['zero']}); "
                  f"no finalist beats it: {held}")  # fmt: skip
        out["provenance"] = provenance()
        if args.out:
            write_json(Path(args.out), out)
        return 0
    if args.cmd == "reward":
        from planetnav_env.tasks.constants import REWARD_FILE

        path = Path(args.out) if args.out else REWARD_FILE
        data = read_json(path)
        for task in _tasks(args.tasks):
            rec = reward_constants(f"planetnav/{task}", args.episodes)
            data["tasks"][task.rsplit("-v", 1)[0]] = rec
            print(f"{task}: scale {rec['scale_km']:.2f} km, baseline {rec['baseline_km'][0]:.1f} .. "
                  f"{rec['baseline_km'][-1]:.1f} km over {rec['bins']} bins; a decision's raw reward std "
                  f"{rec['per_decision_raw_std']}, posed 1")  # fmt: skip
        data["provenance"] = provenance()
        write_json(path, data)
        return 0
    path = Path(args.out) if args.out else (BLIND_FILE if args.cmd == "search" else NORMALIZATION_FILE)
    adding = getattr(args, "add_reference", None)  # normalize --add-reference: one reference on a record
    data = read_json(path)
    for task in _tasks(args.tasks):
        if args.cmd == "search" and args.final_only:
            if task not in data["tasks"]:
                raise ConfigError(f"{task}: no search in {path} to rerun the second stage of")
            data["tasks"][task] = refinal(f"planetnav/{task}", data["tasks"][task], args.final_episodes)
        elif args.cmd == "search":
            cem = {"episodes": args.cem_episodes, "bins": args.cem_bins, "population": args.cem_population,
                   "iterations": args.cem_iterations}  # fmt: skip
            data["tasks"][task] = search(f"planetnav/{task}", args.episodes, args.final_episodes, cem)
        else:
            if adding:
                if task not in data["tasks"]:
                    raise ConfigError(f"{task}: no normalization in {path} to add a reference to")
                rec = add_reference(f"planetnav/{task}", data["tasks"][task], args.add_reference)
            else:
                blind = read_json(BLIND_FILE)["tasks"].get(task)
                if blind is None:
                    raise ConfigError(f"{task}: no blind search in {BLIND_FILE}; run the search first")
                rec = normalize(f"planetnav/{task}", args.episodes, blind)
            data["tasks"][task] = rec
            g = rec["closed_loop_gap"]
            jz, jb = rec["J_zero"], rec["J_best"]
            print(f"{task}: J_zero {jz['mean']:.2f} [{jz['lo']:.2f}, {jz['hi']:.2f}]"
                  f", J_best {jb['mean']:.2f} [{jb['lo']:.2f}, {jb['hi']:.2f}] "
                  f"({rec['best_reference']}), gap {g['gap']:.1%} [{g['gap_lo']:.1%}, {g['gap_hi']:.1%}], "
                  f"headline {rec['headline']}")  # fmt: skip
        # Each task's record carries the run that wrote it: tasks of one file come from runs apart (an
        # added reference carries its own, in ``added_references``).
        if not adding:
            data["tasks"][task]["provenance"] = provenance()
        data["provenance"] = provenance()
        write_json(path, data)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
