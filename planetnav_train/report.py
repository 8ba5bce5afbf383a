"""Reports of an evaluation: the table printed by the commands (:func:`print_table`), its markdown form,
the plots of the mean error and 1-sigma over time and of the training episodes, and ``report.md`` with
``eval.json`` (:func:`write_report`)."""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from planetnav_env.config import EnvConfig
from planetnav_train.config import TrainConfig
from planetnav_train.evaluate import EvalResult, results_json
from planetnav_train.provenance import provenance
from planetnav_train.stats import MeanCI


def _paired_cell(r: EvalResult, mean_key: str, ci_key: str) -> str:
    """A paired difference from ``metrics["vs_reference"]`` as ``"+d [lo, hi]"`` for the tables."""
    vs = r.metrics.get("vs_reference")
    if vs is None:
        return "-"
    if vs["reference"] == r.name:
        return "(reference)"
    return MeanCI(vs[mean_key], *vs[ci_key], r.metrics["episodes"], math.nan, 0.95).format("{:+.1f}")


def _vs_reference(r: EvalResult) -> tuple[str, str]:
    """(the paired difference of the mean error, the ratio of the means) against the reference."""
    vs = r.metrics.get("vs_reference")
    ratio = "-" if vs is None else ("1.00" if vs["reference"] == r.name else f"{vs['ratio']:.2f}")
    return _paired_cell(r, "mean_diff_km", "ci95_km"), ratio


def _sigma_vs_reference(r: EvalResult) -> str:
    """The paired difference of the filter's mean 1-sigma against the reference."""
    return _paired_cell(r, "mean_sigma_diff_km", "sigma_ci95_km")


TABLE_HEAD = (
    "agent",
    "mean err km [95% CI]",
    "Δ vs ref km [95% CI]",
    "ratio",
    "Δ 1σ vs ref km [95% CI]",
    "final err km",
    "final 1σ km",
    "measured",
    "slews",
    "s/episode",
)


#: Columns added after :data:`TABLE_HEAD` when the environment has operations (the objective J).
OBJECTIVE_HEAD = ("J km [95% CI]", "ΔJ vs ref km [95% CI]")


def has_operations_objective(results: Sequence[EvalResult]) -> bool:
    """Whether the evaluations are of an operations scenario (their objective is J, not the mean error)."""
    return any(r.ran and r.metrics.get("objective_kind") == "operations J" for r in results)


def _objective_cells(r: EvalResult) -> list[str]:
    """(J with its 95 % interval, the paired difference of J against the reference) [km]."""
    m = r.metrics
    ci = MeanCI(m["objective_mean"], *m["objective_ci95"], m["episodes"], math.nan, 0.95)
    vs = m.get("vs_reference")
    has_diff = vs is not None and "objective_ci95_km" in vs
    diff = _paired_cell(r, "mean_objective_diff_km", "objective_ci95_km") if has_diff else "-"
    return [ci.format("{:.1f}"), diff]


def table_rows(results: Sequence[EvalResult]) -> list[list[str]]:
    """One row of cells per agent, in the order of :func:`table_head` (skipped agents noted)."""
    rows = []
    width = len(table_head(results))
    with_objective = has_operations_objective(results)
    for r in results:
        if not r.ran:
            rows.append([r.name, "skipped (note below)", *[""] * (width - 2)])
            continue
        m = r.metrics
        ci = MeanCI(m["mean_pos_err_km"], *m["mean_pos_err_ci95_km"], m["episodes"], math.nan, 0.95)
        diff, ratio = _vs_reference(r)
        rows.append(
            [
                r.name,
                ci.format("{:.1f}"),
                diff,
                ratio,
                _sigma_vs_reference(r),
                f"{m['final_pos_err_km']:.1f}",
                f"{m['final_pos_sigma_km']:.1f}",
                f"{m['measured_fraction']:.2f}",
                f"{m['slews']:.1f}",
                f"{m['seconds_per_episode']:.2f}",
                *(_objective_cells(r) if with_objective else []),
            ]
        )
    return rows


def _reference_name(results: Sequence[EvalResult]) -> str | None:
    """The name of the reference agent of the paired columns, or None."""
    return next(
        (r.metrics["vs_reference"]["reference"] for r in results if "vs_reference" in r.metrics), None
    )


def table_head(results: Sequence[EvalResult]) -> list[str]:
    """:data:`TABLE_HEAD` with the reference agent's name in the paired columns, and the objective's
    columns (:data:`OBJECTIVE_HEAD`) on an operations scenario."""
    head = list(TABLE_HEAD)
    ref = _reference_name(results)
    if ref:
        head[2] = f"Δ vs {ref} km [95% CI]"
        head[4] = f"Δ 1σ vs {ref} km [95% CI]"
    if has_operations_objective(results):
        head += [OBJECTIVE_HEAD[0], f"ΔJ vs {ref} km [95% CI]" if ref else OBJECTIVE_HEAD[1]]
    return head


def markdown_table(results: Sequence[EvalResult]) -> str:
    """The table as markdown, followed by the notes of the skipped agents."""
    head = table_head(results)
    lines = ["| " + " | ".join(head) + " |", "|" + "|".join("---" for _ in head) + "|"]
    lines += ["| " + " | ".join(row) + " |" for row in table_rows(results)]
    lines += [f"\nSkipped `{n}`: {why}" for n, why in skipped_notes(results)]
    return "\n".join(lines)


def skipped_notes(results: Sequence[EvalResult]) -> list[tuple[str, str]]:
    """(name, reason) of the agents that could not run in this environment."""
    return [(r.name, str(r.skipped)) for r in results if not r.ran]


def print_table(results: Sequence[EvalResult], title: str | None = None) -> None:
    """Print the table (rich) and the notes of the skipped agents; ``title`` defaults to the seeds."""
    from rich.console import Console
    from rich.table import Table

    rows = table_rows(results)
    ran = [r for r in results if r.ran]
    if title is None:
        n = ran[0].metrics["episodes"] if ran else 0
        first = ran[0].metrics["seed"] if ran else 0
        title = f"planetnav agents: {n} held-out seeds ({first}..{first + n - 1}), paired on the same seeds"
    table = Table(title=title)
    for i, h in enumerate(table_head(results)):
        table.add_column(h, justify="left" if i == 0 else "right", no_wrap=True)
    for row in rows:
        table.add_row(*row)
    console = Console()
    if not console.is_terminal:
        # Logs and pipes: rich would assume 80 columns and truncate the agent names.
        console = Console(width=200)
    console.print(table)
    for name, why in skipped_notes(results):
        console.print(f"skipped {name}: {why}", highlight=False)


def write_plots(results: Sequence[EvalResult], out_dir: Path, step_s: float) -> list[str]:
    """Mean position error and 1-sigma vs time, one line per agent (Agg PNGs); returns the file names."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = []
    for attr, fname, ylabel in (
        ("pos_err_curve", "pos_err.png", "position error [km] (mean over episodes)"),
        ("pos_sigma_curve", "pos_sigma.png", "filter position 1-sigma, sqrt(tr P_rr) [km]"),
    ):
        fig, ax = plt.subplots(figsize=(8, 4.5))
        for r in results:
            if not r.ran:
                continue
            curve = getattr(r, attr)
            hours = (np.arange(len(curve)) + 1) * step_s / 3600.0
            ax.plot(hours, curve, label=r.name, lw=1.2)
        ax.set_yscale("log")
        ax.set_xlabel("time [h]")
        ax.set_ylabel(ylabel)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
        fig.tight_layout()
        fig.savefig(out_dir / fname, dpi=110)
        plt.close(fig)
        names.append(fname)
    return names


def write_training_plot(episodes: Sequence[tuple[int, float, float]], out_dir: Path) -> str | None:
    """Training episode return and final position error vs timesteps; None without finished episodes."""
    if not episodes:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    steps, ret, err = (np.asarray(v, dtype=float) for v in zip(*episodes, strict=True))
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    a1.plot(steps, ret, ".", ms=3)
    a1.set_ylabel("episode return")
    a2.plot(steps, err, ".", ms=3)
    a2.set_yscale("log")
    a2.set_ylabel("final pos err [km]")
    a2.set_xlabel("timesteps")
    for a in (a1, a2):
        a.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(out_dir / "training.png", dpi=110)
    plt.close(fig)
    return "training.png"


def write_report(
    out_dir: Path,
    results: Sequence[EvalResult],
    env_cfg: EnvConfig,
    title: str,
    train_stats: dict[str, Any] | None = None,
    tc: TrainConfig | None = None,
    wall_s: float | None = None,
) -> Path:
    """``report.md`` + plots + ``eval.json`` in ``out_dir``; ``eval.json`` carries the
    :func:`~planetnav_train.provenance.provenance` of this process with ``wall_s`` (the caller's wall
    seconds of the run, training included where it trained)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    plots = write_plots(results, out_dir, env_cfg.step_s)
    training_plot = write_training_plot(train_stats["episodes"], out_dir) if train_stats else None
    with open(out_dir / "eval.json", "w") as fh:
        json.dump({**results_json(results), "provenance": provenance(wall_s=wall_s)}, fh, indent=2)
    ran = [r for r in results if r.ran]
    m0 = ran[0].metrics if ran else {"episodes": 0, "seed": 0}
    lines = [
        f"# {title}",
        "",
        f"Scenario `{env_cfg.scenario}`, planets {', '.join(env_cfg.planets)}, action mode "
        f"`{env_cfg.action_mode}`, {env_cfg.episode_steps} steps of {env_cfg.step_s:g} s, "
        f"{m0['episodes']} held-out episodes (seeds {m0['seed']}..{m0['seed'] + m0['episodes'] - 1}), "
        "the same seeds for every agent"
        + (
            "; per-step noise streams (the same sensor noise for every agent wherever it makes the same "
            "measurement at the same step)."
            if env_cfg.noise_streams == "per_step"
            else "."
        ),
        "",
    ]
    if train_stats and tc:
        lines += [
            f"Training: {tc.algo.upper()} `{tc.policy}`, {train_stats['timesteps']} decisions "
            f"({train_stats['env_steps']} physics steps, decision_steps {tc.env_config().decision_steps}) on "
            f"{tc.n_envs} envs in {train_stats['seconds']:.0f} s "
            f"({train_stats['steps_per_s']:.0f} env steps/s, environment + learning), seed {tc.seed}; "
            f"features {tc.features or 'none'}; shaping "
            f"{tc.shaping or 'none'}. Evaluation {train_stats.get('eval_seconds', 0):.0f} s.",
            "",
        ]
    lines += [
        markdown_table(results),
        "",
        "Mean err: per-step true position error averaged over the episode, then over episodes, with the "
        "95 % Student-t interval over the episodes. Δ vs ref: mean over seeds of (agent - reference) of the "
        "episode's mean error, with the paired 95 % t-interval (an interval containing 0 means the "
        "difference is inside the seed-to-seed noise); ratio: the agent's mean / the reference's. Δ 1σ vs "
        "ref: the same paired difference for the filter's own position 1-sigma, sqrt(trace P_rr) averaged "
        "over the episode (what the covariance reward measures; it varies far less from seed to seed than "
        "the error drawn around it, so its interval resolves differences the error's cannot). Final: "
        "at the last step (mean over episodes). Final 1σ: sqrt(trace P_rr) of the filter at the last step. "
        "Measured: fraction of steps with a camera measurement. Slews: target changes per episode. "
        "s/episode: wall time per episode including the agent's own computation. eval.json has the "
        "per-episode values, the velocity error and the return.",
        "",
    ]
    lines += [f"![{p}]({p})" for p in plots]
    if training_plot:
        lines += ["", f"![training]({training_plot})"]
    path = out_dir / "report.md"
    path.write_text("\n".join(lines) + "\n")
    return path
