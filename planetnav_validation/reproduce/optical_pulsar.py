"""Reproduce patent 003: hybrid optical + X-ray pulsar navigation (OPHN) on approach to Mars.

``python -m planetnav_validation.reproduce optical-pulsar [--quick] [--runs N] [--json PATH] [--plots DIR]``

Runs optical-only (OPN), single-pulsar (PN) and the hybrid (OPHN) on the same Mars approach
(:mod:`planetnav_env.scenarios.approach`: 96 h to closest approach on 2021-02-10 12:00 TDB, Mars-centred
dynamics with Sun, Earth and Jupiter from DE421), a Monte Carlo of ``--runs`` runs per method with common
random numbers, prints a table, writes the summary JSON and error-vs-time plots with the filters' 3-sigma.

Metrics (per method): ``final_pos_err_km`` the RMS over runs of |position error| at closest approach;
``rms_pos_err_km_last_half`` the RMS over runs and over the second half of the span; ``time_to_10km_h`` the
hours from the start after which the run-RMS error stays below 10 km to the end (null if it never does).
See docs/optical_pulsar.md for the comparison with the patent's claims.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from planetnav_env.errors import PlanetNavError
from planetnav_env.estimation.ekf import FilterConfig
from planetnav_env.scenarios.approach import ApproachConfig, MarsApproach
from planetnav_env.sensors import pulsar as psr
from planetnav_validation.approach_methods import METHODS, ApproachResult, NavConfig, run_methods
from planetnav_validation.image_plane import image_plane_sigma_mm

DEFAULT_RUNS = 20
QUICK_RUNS = 5
PATENT_CLAIMS = {
    "OPN": "single-target optical is not observable: the error drifts, does not converge",
    "PN": "single pulsar: converges in tens of hours, error tens to hundreds of km",
    "OPHN": "hybrid: converges within hours to the km level",
}


def pulsar_geometry(scn: MarsApproach, pulsars: Sequence[str]) -> dict[str, dict[str, float]]:
    """Angle [deg] between each pulsar's direction and the spacecraft-to-Mars line of sight at the start and
    at the end; the pulsar adds range information along the line of sight in proportion to its cosine."""
    u = -scn.x_true[:, :3] / scn.range_km()[:, None]
    out = {}
    for name in pulsars:
        n = psr.pulsar(name).direction
        ang = np.degrees(np.arccos(np.clip(u @ n, -1.0, 1.0)))
        out[psr.pulsar(name).bname] = {
            "los_angle_start_deg": float(ang[0]),
            "los_angle_end_deg": float(ang[-1]),
        }
    return out


def run_experiment(
    runs: int, seed: int, nav: NavConfig, approach: ApproachConfig | None = None
) -> tuple[dict, dict[str, ApproachResult], MarsApproach, float]:
    """Build the approach, run the three methods; returns (summary, results, scenario, elapsed seconds)."""
    t0 = time.perf_counter()
    scn = MarsApproach(approach)
    results = run_methods(scn, tuple(METHODS), runs=runs, seed=seed, nav=nav)
    elapsed = time.perf_counter() - t0
    methods = {}
    for m, r in results.items():
        s = r.summary()
        s.update(
            n_optical_updates=r.n_optical,
            n_pulsar_updates=r.n_pulsar,
            n_ambiguity_skipped=r.n_ambiguity_skipped,
            n_gated=int(r.rejected.sum()),
            patent_claim=PATENT_CLAIMS[m],
        )
        methods[m] = s
    cfg = scn.config
    summary = {
        "runs": runs,
        "methods": methods,
        "scenario": {
            "closest_approach_tdb_s": cfg.closest_approach_tdb,
            "closest_approach": "2021-02-10T12:00:00 TDB" if cfg == ApproachConfig() else None,
            "duration_h": cfg.duration_h,
            "end_before_ca_h": cfg.end_before_ca_h,
            "dt_s": cfg.dt_s,
            "v_inf_km_s": cfg.v_inf_km_s,
            "periapsis_altitude_km": cfg.periapsis_altitude_km,
            "start_range_km": float(scn.range_km()[0]),
        },
        "sensors": {
            "pulsars": list(nav.pulsars),
            "pulsar_range_sigma_km": {p: psr.range_sigma_km(p, nav.detector) for p in nav.pulsars},
            "pulsar_geometry": pulsar_geometry(scn, nav.pulsars),
            "detector_area_cm2": nav.detector.area_cm2,
            "integration_time_s": nav.detector.integration_time_s,
            "background_ph_cm2_s": nav.detector.background_ph_cm2_s,
            "optical_interval_s": nav.optical_interval_s,
            "image_plane_sigma_mm": image_plane_sigma_mm(nav.camera, nav.star_tracker_arcsec),
            "focal_length_mm": nav.camera.focal_length_mm,
        },
        "filter": {
            "sigma_pos0_km": nav.filter.sigma_pos0,
            "sigma_vel0_km_s": nav.filter.sigma_vel0,
            "accel_psd_km2_s3": nav.filter.accel_psd,
        },
        "seed": seed,
        "elapsed_s": elapsed,
    }
    return summary, results, scn, elapsed


def _fmt(v: float | None, spec: str = ".2f") -> str:
    return "never" if v is None else format(v, spec)


def _table(summary: dict) -> str:
    lines = [
        f"Mars approach, {summary['scenario']['duration_h']:g} h to closest approach, "
        f"{summary['runs']} runs per method, pulsar(s) {', '.join(summary['sensors']['pulsars'])}",
        f"{'method':<6} {'final |err| km':>15} {'RMS last half km':>17} {'t(<10 km) h':>12} "
        f"{'final 3sig km':>14}"
        f" {'NEES end':>9} {'opt/psr upd':>12}",
    ]
    for m, s in summary["methods"].items():
        lines.append(
            f"{m:<6} {s['final_pos_err_km']:>15.2f} {s['rms_pos_err_km_last_half']:>17.2f} "
            f"{_fmt(s['time_to_10km_h']):>12} {s['final_3sigma_km']:>14.2f} {s['mean_final_nees']:>9.3g} "
            f"{s['n_optical_updates']:>5}/{s['n_pulsar_updates']:<6}"
        )
    for name, g in summary["sensors"]["pulsar_geometry"].items():
        lines.append(
            f"{name}: range sigma {summary['sensors']['pulsar_range_sigma_km'][name]:.3f} km per "
            f"{summary['sensors']['integration_time_s']:g} s; angle to the Mars line of sight "
            f"{g['los_angle_start_deg']:.1f} deg at the start, {g['los_angle_end_deg']:.1f} deg at closest "
            "approach"
        )
    return "\n".join(lines)


def _plots(results: dict[str, ApproachResult], summary: dict, out_dir: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    fig, axes = plt.subplots(len(results), 1, figsize=(8, 3.2 * len(results)), sharex=True)
    for ax, (m, r) in zip(np.atleast_1d(axes), results.items(), strict=True):
        t = r.t_h
        ax.semilogy(t, r.pos_err_norm, color="0.75", lw=0.5)
        ax.semilogy(t, r.rms_over_runs, color="C0", lw=1.5, label="|error|, RMS over runs")
        ax.semilogy(t, 3.0 * np.sqrt(np.mean(r.sigma_pos**2, axis=1)), "C3--", lw=1.2, label="filter 3-sigma")
        ax.axhline(10.0, color="k", lw=0.6, ls=":")
        ax.set_ylabel("position error [km]")
        ax.set_title(f"{m}: {PATENT_CLAIMS[m]}", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8, loc="lower left")
    np.atleast_1d(axes)[-1].set_xlabel("hours since start (closest approach at the right edge)")
    fig.suptitle(f"Mars approach, {summary['runs']} runs, pulsar {', '.join(summary['sensors']['pulsars'])}")
    fig.tight_layout()
    p = out_dir / "optical_pulsar_errors.png"
    fig.savefig(p, dpi=120)
    plt.close(fig)
    paths.append(p)

    fig, ax = plt.subplots(figsize=(8, 4))
    for m, r in results.items():
        ax.semilogy(r.t_h, r.rms_over_runs, lw=1.5, label=m)
    ax.axhline(10.0, color="k", lw=0.6, ls=":")
    ax.set_xlabel("hours since start")
    ax.set_ylabel("RMS position error [km]")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    p = out_dir / "optical_pulsar_compare.png"
    fig.savefig(p, dpi=120)
    plt.close(fig)
    paths.append(p)
    return paths


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m planetnav_validation.reproduce optical-pulsar", description=__doc__.split("\n")[0]
    )
    parser.add_argument("--quick", action="store_true", help=f"{QUICK_RUNS} runs per method (a smoke run)")
    parser.add_argument(
        "--runs", type=int, default=None, help=f"Monte Carlo runs per method ({DEFAULT_RUNS})"
    )
    parser.add_argument("--seed", type=int, default=3, help="random seed (3)")
    parser.add_argument(
        "--pulsar", action="append", default=None, help="pulsar(s) for PN and OPHN (repeatable; B0531+21)"
    )
    parser.add_argument("--area-m2", type=float, default=1.0, help="X-ray detector area [m^2] (1)")
    parser.add_argument(
        "--t-obs", type=float, default=1000.0, help="pulsar integration time per TOA [s] (1000)"
    )
    parser.add_argument(
        "--sigma-pos0", type=float, default=100.0, help="a-priori 1-sigma per axis [km] (100)"
    )
    parser.add_argument(
        "--sigma-vel0", type=float, default=1e-3, help="a-priori 1-sigma per axis [km/s] (1e-3)"
    )
    parser.add_argument("--json", type=Path, help="write the summary JSON here")
    parser.add_argument("--plots", type=Path, help="write the figures into this directory")
    args = parser.parse_args(list(argv) if argv is not None else None)
    runs = args.runs if args.runs is not None else (QUICK_RUNS if args.quick else DEFAULT_RUNS)
    if runs < 1:
        parser.error(f"--runs must be >= 1, got {runs}")
    try:
        nav = NavConfig(
            pulsars=tuple(args.pulsar or ("B0531+21",)),
            detector=psr.XrayDetector(area_cm2=args.area_m2 * 1e4, integration_time_s=args.t_obs),
            filter=FilterConfig(sigma_pos0=args.sigma_pos0, sigma_vel0=args.sigma_vel0, accel_psd=1e-16),
        )
        summary, results, _, elapsed = run_experiment(runs, args.seed, nav)
    except PlanetNavError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(_table(summary))
    print(f"Monte Carlo time: {elapsed:.2f} s for 3 methods x {runs} runs")
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(summary, indent=2))
        print(f"wrote {args.json}")
    if args.plots is not None:
        for p in _plots(results, summary, args.plots):
            print(f"wrote {p}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
