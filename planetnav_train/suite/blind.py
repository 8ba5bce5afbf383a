"""The best blind policy of a task, and the closed-loop gap and score measured from it.

A blind policy ignores the observation: random actions (in the task's own interface), idle where the task has
a "camera off" action, and fixed cyclic schedules of targets
(:class:`planetnav_agents.schedule.ScheduleAgent`:
planets, and pulsars on the Mars approach). With a linear-Gaussian filter and a geometry that repeats, such a
schedule is near-optimal (docs/tasks_v2.md); what remains between it and the best reference is what
only a policy that reads the state can win:

* closed-loop gap = ``(J_blind - J_best) / J_blind``, ``J_best`` the best non-privileged reference;
* blind-zero score = ``(J_blind - J) / (J_blind - J_best)``: 0 is the best blind policy, 1 the best reference.

:func:`search_blind` evaluates every candidate of :func:`blind_candidates` on search seeds apart from the
evaluation seeds (default 40,000.., 30 episodes), then :func:`measure_task` scores the winner beside the
references on the task's evaluation seeds (50,000.., 100 episodes, per-step noise streams: every policy
draws the same sensor noise where it makes the same measurement). Intervals are 95 % percentile bootstraps
over the seeds, paired (the same resampled seeds for both policies).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from planetnav_env.config import EnvConfig
from planetnav_env.errors import ConfigError

#: Search seeds: disjoint from training (0..), train.py's evaluation (10,000..), the periodic sweep (20,000..)
#: and the suite's evaluation seeds (50,000..).
BLIND_SEARCH_SEED = 40_000
BLIND_SEARCH_EPISODES = 30
#: The second stage: the best :data:`FINALISTS` of the first, again on :data:`FINAL_EPISODES` further seeds
#: (after the first stage's), which pick the winner. The best of ~40 candidates on 30 seeds is flattered by
#: its seeds (the winner's curse: on Cruise-Target-v2 a one-stage winner scored 198.6 km on its seeds and
#: 232.7 [210.9, 256.7] on the evaluation seeds); a fresh look at a few finalists is not.
FINALISTS = 5
FINAL_EPISODES = 100
#: Dwell per target in decisions of the task's own interface (times its ``decision_steps`` physics steps), so
#: that every schedule is one the task's decision interface can play.
DWELL_DECISIONS = (1, 2, 3, 4, 6)
#: Mixed dwells on the Mars approach: decisions on the planet, then on each pulsar.
MIXED_DWELLS = ((2, 1), (3, 1), (4, 1), (4, 2), (6, 2))
#: Session schedules on the operations scenarios (the thrust arc: the camera off is thrust on): each
#: target imaged for ``SESSION_DECISIONS`` decisions, then the camera off for ``SESSION_GAPS`` decisions, in
#: turn. At ThrustArc-TCM-v2's 2-h decisions: 2- or 4-h sessions, 1, 3 or 6 days apart (the rules' tuned
#: sessions: 2 h every 3 days).
SESSION_DECISIONS = (1, 2)
SESSION_GAPS = (11, 35, 71)
#: When the first session starts, as a share of one session's block (on + off): like the rules' phase.
SESSION_STARTS = (0.0, 0.25, 0.5, 0.75)
#: The references of the ``-v2`` target tasks: the nominal rule (greedy on the filter's model) and the
#: adaptive one (greedy with each planet's observed success rate); the oracle knows the drawn rates.
V2_REFERENCES = ("greedy", "greedy:success=observed")
V2_PRIVILEGED = ("greedy:success=oracle",)
#: Legend labels of the references in the regime map's figure (other agents keep their spec).
ROLE_LABELS = {
    "blind": "best blind schedule",
    "greedy": "greedy (nominal: the filter's model)",
    "greedy:success=observed": "greedy, observed success rates (adaptive)",
    "greedy:success=oracle": "greedy, true success rates (oracle, privileged)",
    "greedy:timing=observed": "greedy, pulsars weighted by their NIS (adaptive)",
    "greedy:timing=oracle": "greedy, pulsars weighted by their true drift (oracle, privileged)",
}
#: The timing error's adaptive rule and oracle (the pulsars weighted by their phases' NIS, or by the drift).
TIMING_REFERENCES = ("greedy", "greedy:timing=observed")
TIMING_PRIVILEGED = ("greedy:timing=oracle",)
BOOTSTRAP_REPS = 10_000
BOOTSTRAP_SEED = 0

#: Evaluates agent ``spec`` on ``episodes`` seeds from ``seed``: returns the per-episode objective values.
Evaluator = Callable[[str, EnvConfig, int, int], np.ndarray]


def evaluate_objective(spec: str, cfg: EnvConfig, episodes: int, seed: int) -> np.ndarray:
    """The :data:`Evaluator` of the commands: agent ``spec`` on ``episodes`` seeds from ``seed`` by
    :func:`planetnav_train.evaluate.evaluate_agent`, each episode's objective [km]: the mean true position
    error, or on an operations scenario its J (knowledge at the deadlines plus w x delta-v lost)."""
    from planetnav_train.evaluate import evaluate_agent

    r = evaluate_agent(spec, cfg, episodes, seed, progress=False)
    key = "per_episode_objective" if cfg.operations is not None else "per_episode_mean_pos_err_km"
    return np.asarray(r.metrics[key], dtype=float)


def _cycles(n_targets: int) -> list[tuple[int, ...]]:
    """Cycles of 1, 2 or 3 distinct targets, one per rotation class (both orientations of three)."""
    out: list[tuple[int, ...]] = [(t,) for t in range(n_targets)]
    out += list(itertools.combinations(range(n_targets), 2))
    for a, b, c in itertools.combinations(range(n_targets), 3):
        out += [(a, b, c), (a, c, b)]
    return out


def blind_candidates(cfg: EnvConfig) -> list[str]:
    """Agent specs of the blind family of task ``cfg``.

    - Target choice: ``random`` and every schedule of :func:`_cycles` at the dwells of
      :data:`DWELL_DECISIONS` (and, with pulsars, :data:`MIXED_DWELLS`); ``idle`` where the task has the
      camera-off action; on an operations scenario also the session schedules of
      :data:`SESSION_DECISIONS` x :data:`SESSION_GAPS` (each target a session, the camera off between).
    - Wheel torques (``action_mode="torque"``): ``random`` and ``zero``. A schedule executed by the PD law
      is not blind there: the law reads the attitude, and pointing is the decision these tasks pose.
    """
    if cfg.action_mode == "torque":
        return ["random", "zero"]
    if cfg.action_mode != "target":
        raise ConfigError(
            "the blind search covers the target-choice and wheel-torque tasks; got action_mode "
            f"{cfg.action_mode!r}"
        )
    k = cfg.decision_steps
    specs = ["random"] + (["idle"] if cfg.idle_action else [])
    if cfg.operations is not None:
        for cycle in _cycles(cfg.n_targets):
            targets = "-".join(f"{t}-off" for t in cycle)
            for on, off in itertools.product(SESSION_DECISIONS, SESSION_GAPS):
                steps = "-".join(f"{on * k}-{off * k}" for _ in cycle)
                for start in SESSION_STARTS:
                    # The first session after ``first`` decisions: skip the cycle up to that point of its
                    # last gap.
                    first = round(start * (on + off))
                    phase = (len(cycle) * (on + off) - first) % (len(cycle) * (on + off)) * k
                    specs.append(
                        f"schedule:targets={targets},steps={steps}" + (f",phase={phase}" if phase else "")
                    )
    for cycle in _cycles(cfg.n_targets):
        targets = "-".join(map(str, cycle))
        dwells = [(d * k,) for d in DWELL_DECISIONS] if len(cycle) > 1 else [(k,)]
        if cfg.n_pulsars and len(cycle) > 1 and any(t < cfg.n_planets for t in cycle):
            dwells += [tuple((a if t < cfg.n_planets else b) * k for t in cycle) for a, b in MIXED_DWELLS]
        specs += [f"schedule:targets={targets},steps={'-'.join(map(str, d))}" for d in dwells]
    return list(dict.fromkeys(specs))


def default_references(cfg: EnvConfig) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The non-privileged references (the best is the score's 1) and the oracles of task ``cfg``: the
    suite's references on the operations and torque tasks; nominal and adaptive greedy (and the oracle)
    where an event is drawn; nominal greedy otherwise."""
    from planetnav_train.suite.tasks import THRUST_ARC_REFS, TORQUE_REFS

    if cfg.operations is not None:
        return THRUST_ARC_REFS, ()
    if cfg.action_mode == "torque":
        return TORQUE_REFS, ()
    if cfg.image_success_min < 1.0:
        return V2_REFERENCES, V2_PRIVILEGED
    if cfg.world.pulsar_frequency_error_bound > 0.0:
        return TIMING_REFERENCES, TIMING_PRIVILEGED
    return ("greedy",), ()


def _mean_ci(values: np.ndarray, rng: np.random.Generator) -> tuple[float, float, float]:
    idx = rng.integers(0, values.size, size=(BOOTSTRAP_REPS, values.size))
    means = values[idx].mean(axis=1)
    return float(values.mean()), float(np.quantile(means, 0.025)), float(np.quantile(means, 0.975))


def paired_ratio_ci(blind: np.ndarray, best: np.ndarray, j: np.ndarray | None = None) -> dict[str, float]:
    """The closed-loop gap ``(mean(blind) - mean(best)) / mean(blind)`` and, with ``j``, the blind-zero score
    ``(mean(blind) - mean(j)) / (mean(blind) - mean(best))``, each with a 95 % paired percentile bootstrap
    interval over the seeds (the arrays are per-seed values on the same seeds)."""
    blind, best = np.asarray(blind, float), np.asarray(best, float)
    if blind.shape != best.shape or blind.ndim != 1 or blind.size < 2:
        raise ConfigError(
            f"paired values need two equal 1-D arrays of >= 2 seeds, got {blind.shape}, {best.shape}"
        )
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    idx = rng.integers(0, blind.size, size=(BOOTSTRAP_REPS, blind.size))
    mb, mr = blind[idx].mean(axis=1), best[idx].mean(axis=1)
    gap = (mb - mr) / mb
    out = {
        "gap": float((blind.mean() - best.mean()) / blind.mean()),
        "gap_lo": float(np.quantile(gap, 0.025)),
        "gap_hi": float(np.quantile(gap, 0.975)),
    }
    if j is not None:
        j = np.asarray(j, float)
        mj = j[idx].mean(axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            score = (mb - mj) / (mb - mr)
        out.update(
            score=blind_zero_score(float(j.mean()), float(blind.mean()), float(best.mean())),
            score_lo=float(np.nanquantile(score, 0.025)),
            score_hi=float(np.nanquantile(score, 0.975)),
        )
    return out


def blind_zero_score(j: float, j_blind: float, j_best: float) -> float:
    """``(J_blind - J) / (J_blind - J_best)``: 0 is the best blind policy, 1 the best non-privileged
    reference (lower objective is better). Raises :class:`ConfigError` naming the values when they are not
    finite or the two references coincide."""
    vals = {"J": j, "J_blind": j_blind, "J_best": j_best}
    bad = {k: v for k, v in vals.items() if not math.isfinite(float(v))}
    if bad:
        raise ConfigError(f"blind-zero score: non-finite objective value(s) {bad}")
    if j_blind == j_best:
        raise ConfigError(f"blind-zero score: J_blind equals J_best ({j_blind!r}): the score has no scale")
    return (float(j_blind) - float(j)) / (float(j_blind) - float(j_best))


@dataclass(frozen=True)
class BlindResult:
    """The search's winner, every candidate's first-stage figure (mean objective on the search seeds) and
    the finalists' second-stage figures (on the next ``final_episodes`` seeds), which picked the winner."""

    winner: str
    search: dict[str, float]
    search_seed: int
    search_episodes: int
    final: dict[str, float]
    final_episodes: int
    #: The winner's per-seed values on the seeds that chose it last.
    winner_values: tuple[float, ...] = ()

    @property
    def winner_mean(self) -> float:
        """The winner's figure on the seeds that chose it last (the second stage's, when there is one)."""
        return self.final[self.winner] if self.final else self.search[self.winner]


def search_blind(
    cfg: EnvConfig,
    evaluate: Evaluator,
    seed: int = BLIND_SEARCH_SEED,
    episodes: int = BLIND_SEARCH_EPISODES,
    candidates: Sequence[str] | None = None,
    progress: Callable[[str, float], None] | None = None,
    finalists: int = FINALISTS,
    final_episodes: int = FINAL_EPISODES,
) -> BlindResult:
    """Evaluate every blind candidate of ``cfg`` on ``episodes`` search seeds from ``seed``, then the best
    ``finalists`` again on the next ``final_episodes`` seeds; the lowest second-stage mean wins
    (``final_episodes`` 0: one stage, the lowest first-stage mean)."""
    specs = list(candidates) if candidates is not None else blind_candidates(cfg)
    figures: dict[str, float] = {}
    for spec in specs:
        figures[spec] = float(np.mean(evaluate(spec, cfg, episodes, seed)))
        if progress is not None:
            progress(spec, figures[spec])
    values: dict[str, np.ndarray] = {}
    final: dict[str, float] = {}
    if final_episodes > 0 and len(figures) > 1:
        for spec in sorted(figures, key=figures.__getitem__)[:finalists]:
            values[spec] = np.asarray(evaluate(spec, cfg, final_episodes, seed + episodes), float)
            final[spec] = float(values[spec].mean())
            if progress is not None:
                progress(f"final {spec}", final[spec])
    pool = final or figures
    winner = min(pool, key=pool.__getitem__)
    kept = tuple(float(v) for v in values.get(winner, ()))
    return BlindResult(winner, figures, seed, episodes, final, final_episodes if final else 0, kept)


def measure_task(
    cfg: EnvConfig,
    blind: BlindResult,
    references: Sequence[str],
    privileged: Sequence[str],
    evaluate: Evaluator,
    seed: int,
    episodes: int,
    extra: Sequence[str] = (),
) -> dict[str, Any]:
    """Score the blind winner, the ``references`` (non-privileged: the best is the score's 1), the
    ``privileged`` ones (oracles: reported, never the 1) and ``extra`` agents on the evaluation seeds; returns
    the JSON record: each agent's per-seed values, mean and interval, the closed-loop gap with its interval,
    and each agent's blind-zero score."""
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    names = [blind.winner, *references, *privileged, *extra]
    values = {s: np.asarray(evaluate(s, cfg, episodes, seed), float) for s in dict.fromkeys(names)}
    best = min(references, key=lambda s: values[s].mean())
    jb, jr = values[blind.winner], values[best]
    agents = {}
    for s, v in values.items():
        mean, lo, hi = _mean_ci(v, rng)
        row = {"mean": mean, "lo": lo, "hi": hi, "per_seed": v.tolist()}
        row.update({k: v2 for k, v2 in paired_ratio_ci(jb, jr, v).items() if k.startswith("score")})
        row["role"] = (
            "blind" if s == blind.winner else "privileged" if s in privileged
            else "reference" if s in references else "agent"
        )  # fmt: skip
        agents[s] = row
    gap = paired_ratio_ci(jb, jr)
    search_mean = blind.winner_mean
    # Search and evaluation seeds differ: the two means agree when the interval of their difference (an
    # unpaired bootstrap, each set resampled on its own) holds 0.
    agree = None
    if len(blind.winner_values) > 1:
        sv = np.asarray(blind.winner_values)
        diffs = sv[rng.integers(0, sv.size, (BOOTSTRAP_REPS, sv.size))].mean(axis=1) - jb[
            rng.integers(0, jb.size, (BOOTSTRAP_REPS, jb.size))
        ].mean(axis=1)
        lo, hi = float(np.quantile(diffs, 0.025)), float(np.quantile(diffs, 0.975))
        agree = {"difference": float(sv.mean() - jb.mean()), "lo": lo, "hi": hi, "holds_0": lo <= 0.0 <= hi}
    return {
        "blind_winner": blind.winner,
        "blind_search": {
            "seed": blind.search_seed,
            "episodes": blind.search_episodes,
            "candidates": blind.search,
            "final_episodes": blind.final_episodes,
            "finalists": blind.final,
            "winner_mean": search_mean,
        },
        "eval_seed": seed,
        "eval_episodes": episodes,
        "best_reference": best,
        "J_blind": float(jb.mean()),
        "J_best": float(jr.mean()),
        "closed_loop_gap": gap,
        # The winner's search figure inside its evaluation interval: the search did not overfit its seeds.
        "winner_search_inside_eval_ci": bool(
            agents[blind.winner]["lo"] <= search_mean <= agents[blind.winner]["hi"]
        ),
        # Search figure minus evaluation figure of the winner, with its 95 % interval (None: one stage).
        "winner_search_minus_eval": agree,
        "agents": agents,
    }


def regime_map(
    cfg_for: Callable[[float], EnvConfig],
    strengths: Sequence[float],
    agents: Sequence[str],
    candidates: Sequence[str],
    evaluate: Evaluator,
    search_seed: int,
    search_episodes: int,
    seed: int,
    episodes: int,
    finalists: int = FINALISTS,
    final_episodes: int = FINAL_EPISODES,
) -> dict[str, Any]:
    """The event's strength swept from 0 upward: at each ``strength`` (``cfg_for(strength)`` is the task
    there) the best blind policy of ``candidates`` found on the search seeds (two stages, as
    :func:`search_blind`) and every agent of ``agents`` on the evaluation seeds, each with its mean and 95 %
    interval. Returns ``{"strengths": [...],
    "points": [{"strength", "blind": spec, "agents": {spec: {mean, lo, hi}}}]}``; the blind winner's row
    is under ``"blind"`` in ``agents``."""
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    points = []
    for s in strengths:
        cfg = cfg_for(float(s))
        res = search_blind(
            cfg, evaluate, search_seed, search_episodes, candidates=candidates, finalists=finalists,
            final_episodes=final_episodes,
        )  # fmt: skip
        rows: dict[str, Any] = {}
        for spec in ("blind", *agents):
            v = np.asarray(evaluate(res.winner if spec == "blind" else spec, cfg, episodes, seed), float)
            mean, lo, hi = _mean_ci(v, rng)
            rows[spec] = {"mean": mean, "lo": lo, "hi": hi}
        points.append(
            {"strength": float(s), "blind": res.winner, "blind_search": res.winner_mean, "agents": rows}
        )
    return {"strengths": [float(s) for s in strengths], "points": points}


def plot_regime_map(data: Mapping[str, Any], title: str, xlabel: str, path: str) -> None:
    """One figure of :func:`regime_map`'s result: mean objective and 95 % interval per agent over the
    strength, one colour per agent."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.0), dpi=120)
    xs = np.asarray(data["strengths"])
    specs = list(data["points"][0]["agents"])
    colours = plt.get_cmap("tab10")
    for c, spec in enumerate(specs):
        rows = [p["agents"][spec] for p in data["points"]]
        m = np.array([r["mean"] for r in rows])
        lo = np.array([r["lo"] for r in rows])
        hi = np.array([r["hi"] for r in rows])
        label = ROLE_LABELS.get(spec, spec)
        ax.plot(xs, m, "o-", color=colours(c), label=label)
        ax.fill_between(xs, lo, hi, color=colours(c), alpha=0.15)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("mean true position error [km]")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
