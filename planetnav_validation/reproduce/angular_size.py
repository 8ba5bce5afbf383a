"""Reproduction of the thesis (000): navigation by direction and angular size of planets.

``python -m planetnav_validation.reproduce angular-size [--quick] [--runs N] [--json PATH] [--plots DIR]``

Experiments (thesis, chapter 3):

* Mars and Venus, model 1 (``direction``) and model 2 (``direction+size``), 1 hour at
  h = 1 s and 1 day at h = 60 s: 8 cases, a Monte Carlo of N runs each (default 100).
* Switching (section 2.4 / conclusion): 60 days at h = 600 s, Venus only, Mars only, and the
  nearest planet by the filter's estimate, with the direction+size model.

Trajectory (the thesis gives none): a Venus-to-Mars Hohmann-type transfer ellipse
(perihelion 0.7233 AU, aphelion 1.5237 AU), inclination 2 deg to the J2000 ecliptic, node
0 deg, argument of perihelion 270 deg, mean anomaly 30 deg at 2020-08-01 00:00 TDB. At that
epoch the spacecraft is 0.84 AU from the Sun, Venus is 0.227 AU away (54 deg from the Sun
direction), Mars 0.549 AU (171 deg); Venus stays the nearer planet until day ~27, then Mars.
Planets move on the thesis's Keplerian ephemeris, in truth and filter alike, as in the
thesis; ``--ephemeris de421`` uses DE421 for both.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from planetnav_env.astro.bodies import body
from planetnav_env.astro.ephemeris import Ephemeris, make_ephemeris
from planetnav_env.estimation.ekf import FilterConfig
from planetnav_env.estimation.measurements import MeasurementModel
from planetnav_env.scenarios.episodes import CRUISE_EPOCH, cruise_state
from planetnav_env.sensors.camera_config import CameraConfig
from planetnav_validation.navigation import NavigationResult, simulate_navigation

EPOCH = CRUISE_EPOCH
MODELS = ("direction", "direction+size")


def initial_state() -> np.ndarray:
    """Spacecraft state at EPOCH (heliocentric ICRF, km and km/s): the ``cruise`` scenario's."""
    return cruise_state()


def measurement_model(kind: str, camera: CameraConfig) -> MeasurementModel:
    """Filter measurement model with the camera's noise (3.5" direction, 2.5 px diameter)."""
    return MeasurementModel(kind, sigma_dir=camera.sigma_direction_rad, sigma_size=camera.sigma_alpha_rad)


@dataclass(frozen=True)
class Case:
    name: str
    planet: str  # "mars", "venus" or "nearest"
    model: str
    duration_s: float
    step_s: float


def thesis_cases(quick: bool) -> list[Case]:
    cases = []
    for duration, step in ((3600.0, 1.0), (86400.0, 60.0)):
        for planet in ("mars", "venus"):
            for model in MODELS:
                cases.append(Case(f"{planet}/{model}/{duration / 3600:g}h", planet, model, duration, step))
    return cases


def switching_cases(quick: bool) -> list[Case]:
    days = 30.0 if quick else 60.0
    return [
        Case(f"{p}/direction+size/{days:g}d", p, "direction+size", days * 86400.0, 600.0)
        for p in ("venus", "mars", "nearest")
    ]


def nearest_schedule(eph: Ephemeris):
    """Thesis rule (section 2.4): measure the planet nearest to the *estimated* position.

    One target serves every Monte Carlo run of a batch, so the rule reads the mean estimate.
    """

    def schedule(k: int, t: float, x_est: np.ndarray) -> str:
        r = x_est[:, :3].mean(axis=0)
        dv = np.linalg.norm(eph.position("venus", t) - r)
        dm = np.linalg.norm(eph.position("mars", t) - r)
        return "venus" if dv <= dm else "mars"

    return schedule


def run_case(
    case: Case, n_runs: int, seed: int, eph: Ephemeris, camera: CameraConfig, cfg: FilterConfig
) -> NavigationResult:
    if case.planet == "nearest":
        schedule = nearest_schedule(eph)
    else:

        def schedule(k: int, t: float, x_est: np.ndarray) -> str:
            return case.planet

    return simulate_navigation(
        x0=initial_state(),
        t0=EPOCH,
        dt=case.step_s,
        n_steps=round(case.duration_s / case.step_s),
        schedule=schedule,
        ephemeris=eph,
        measurement=measurement_model(case.model, camera),
        config=cfg,
        n_runs=n_runs,
        rng=np.random.default_rng(seed),
    )


def los_decomposition(case: Case, res: NavigationResult, eph: Ephemeris) -> tuple[np.ndarray, np.ndarray]:
    """Final position error split along the last line of sight (range) and across it, per run [km]."""
    name = next((p for p in reversed(res.target) if p is not None), None)
    err = res.x_est[-1, :, :3] - res.x_true[-1, :, :3]
    if name is None:
        return np.full(len(err), np.nan), np.full(len(err), np.nan)
    d = eph.position(name, res.t[-1]) - res.x_true[-1, :, :3]
    u = d / np.linalg.norm(d, axis=-1, keepdims=True)
    along = np.sum(err * u, axis=-1)
    cross = np.linalg.norm(err - along[:, None] * u, axis=-1)
    return np.abs(along), cross


def summarize(case: Case, res: NavigationResult, eph: Ephemeris) -> dict:
    pos, vel = res.pos_err, res.vel_err
    along, cross = los_decomposition(case, res, eph)
    switches = sum(1 for a, b in zip(res.target, res.target[1:], strict=False) if a != b)
    return {
        "planet": case.planet,
        "model": case.model,
        "duration_s": case.duration_s,
        "step_s": case.step_s,
        "final_pos_err_km": float(pos[-1].mean()),
        "final_vel_err_km_s": float(vel[-1].mean()),
        "rms_pos_err_km": float(np.sqrt(np.mean(pos**2, axis=0)).mean()),
        "rms_vel_err_km_s": float(np.sqrt(np.mean(vel**2, axis=0)).mean()),
        "final_range_err_km": float(along.mean()),
        "final_cross_err_km": float(cross.mean()),
        "final_pos_sigma_km": float(res.pos_sigma[-1].mean()),
        "final_vel_sigma_km_s": float(res.vel_sigma[-1].mean()),
        "mean_nees": float(res.nees.mean()),
        "rejected_fraction": float(1.0 - res.accepted[res.measured].mean()) if res.measured.any() else 0.0,
        "switches": switches,
    }


def plot_case(case: Case, res: NavigationResult, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    hours = (res.t - res.t[0]) / 3600.0
    fig, axes = plt.subplots(2, 1, figsize=(8, 6.5), sharex=True)
    for ax, sl, unit, title in (
        (axes[0], slice(0, 3), "km", "position"),
        (axes[1], slice(3, 6), "km/s", "velocity"),
    ):
        err = res.x_est[:, 0, sl] - res.x_true[:, 0, sl]
        sig = np.sqrt(np.diagonal(res.P[:, 0], axis1=-2, axis2=-1)[:, sl])
        for j, c in enumerate("xyz"):
            line = ax.plot(hours, err[:, j], lw=0.8, label=f"{c} error (run 0)")[0]
            ax.plot(hours, 3 * sig[:, j], ls="--", lw=0.7, color=line.get_color())
            ax.plot(hours, -3 * sig[:, j], ls="--", lw=0.7, color=line.get_color())
        rms = np.sqrt(np.mean(np.sum((res.x_est[..., sl] - res.x_true[..., sl]) ** 2, -1), axis=1))
        ax.plot(hours, rms, color="k", lw=1.2, label=f"RMS |error| over {res.x_true.shape[1]} runs")
        ax.set_ylabel(f"{title} error [{unit}]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper right")
    axes[1].set_xlabel("time [h]")
    fig.suptitle(f"{case.name}: estimation error and ±3σ (dashed)")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def plot_angular_sizes(eph: Ephemeris, camera: CameraConfig, days: float, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from planetnav_env.dynamics.orbit import GravityModel
    from planetnav_validation.numpy_orbit import propagate

    step = 3600.0
    n = int(days * 86400 / step)
    traj = propagate(GravityModel("sun"), initial_state()[None], EPOCH, step, n)[:, 0]
    t = EPOCH + step * np.arange(n + 1)
    fig, ax = plt.subplots(figsize=(8, 4))
    for name in ("venus", "mars"):
        dist = np.linalg.norm(eph.position(name, t) - traj[:, :3], axis=-1)
        alpha = 2 * np.arcsin(body(name).radius / dist)
        ax.plot(t / 86400 - t[0] / 86400, np.rad2deg(alpha) * 3600, label=name)
    sig = np.rad2deg(camera.sigma_alpha_rad) * 3600
    ax.axhline(sig, color="k", ls="--", lw=0.8, label=f"1σ diameter noise ({camera.diameter_noise_px:g} px)")
    ax.set_yscale("log")
    ax.set_xlabel("days since 2020-08-01")
    ax.set_ylabel("apparent diameter [arcsec]")
    ax.set_title("Angular size of Venus and Mars along the trajectory (thesis fig. 8)")
    ax.grid(alpha=0.3, which="both")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def _table(rows: list[dict]) -> str:
    head = f"{'planet':<8}{'model':<16}{'span':>8}{'h [s]':>7}{'final |dr| km':>15}{'RMS |dr| km':>13}"
    head += (
        f"{'along LOS km':>13}{'across km':>10}{'final |dv| m/s':>16}{'3σ r km':>10}{'NEES':>7}{'switch':>7}"
    )
    lines = [head, "-" * len(head)]
    for r in rows:
        span = f"{r['duration_s'] / 3600:g}h" if r["duration_s"] <= 86400 else f"{r['duration_s'] / 86400:g}d"
        lines.append(
            f"{r['planet']:<8}{r['model']:<16}{span:>8}{r['step_s']:>7g}{r['final_pos_err_km']:>15.1f}"
            f"{r['rms_pos_err_km']:>13.1f}{r['final_range_err_km']:>13.1f}{r['final_cross_err_km']:>10.2f}"
            f"{1e3 * r['final_vel_err_km_s']:>16.3f}"
            f"{3 * r['final_pos_sigma_km']:>10.0f}"
            f"{r['mean_nees']:>7.2f}{r['switches']:>7d}"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m planetnav_validation.reproduce angular-size", description=__doc__.split("\n")[1]
    )
    ap.add_argument("--quick", action="store_true", help="10 runs and a 30-day switching arc (< 60 s)")
    ap.add_argument(
        "--runs", type=int, default=None, help="Monte Carlo runs per case (default 100; --quick 10)"
    )
    ap.add_argument("--seed", type=int, default=2016)
    ap.add_argument("--ephemeris", default="keplerian", choices=("keplerian", "de421"))
    ap.add_argument("--json", type=Path, default=None, help="write the summary JSON here")
    ap.add_argument("--plots", type=Path, default=None, help="write figures into this directory")
    args = ap.parse_args(argv)
    n_runs = args.runs if args.runs is not None else (10 if args.quick else 100)
    if n_runs < 1:
        ap.error(f"--runs must be >= 1, got {n_runs}")

    eph = make_ephemeris(args.ephemeris)
    camera = CameraConfig()
    cfg = FilterConfig()
    started = time.perf_counter()
    thesis_rows, switch_rows = [], []
    if args.plots:
        args.plots.mkdir(parents=True, exist_ok=True)
    for i, case in enumerate(thesis_cases(args.quick) + switching_cases(args.quick)):
        res = run_case(case, n_runs, args.seed + i, eph, camera, cfg)
        row = summarize(case, res, eph)
        (thesis_rows if case.planet != "nearest" and case.step_s < 600 else switch_rows).append(row)
        if args.plots:
            plot_case(case, res, args.plots / (case.name.replace("/", "_").replace("+", "-") + ".png"))
        print(f"  {case.name:<36} done ({time.perf_counter() - started:5.1f} s)", file=sys.stderr)
    if args.plots:
        plot_angular_sizes(eph, camera, 60.0, args.plots / "angular_sizes.png")

    print(
        f"\nThesis cases ({n_runs} runs each, means over runs; seed {args.seed}, ephemeris {args.ephemeris})"
    )
    print(_table(thesis_rows))
    print("\nSwitching to the nearest planet (direction+size)")
    print(_table(switch_rows))
    print(
        f'\ncamera: 1σ direction {camera.direction_noise_arcsec:g}",'
        f" 1σ diameter {camera.diameter_noise_px:g} px ="
        f' {np.rad2deg(camera.sigma_alpha_rad) * 3600:.0f}"; filter: σr0 {cfg.sigma_pos0:g} km,'
        f" σv0 {cfg.sigma_vel0 * 1e3:g} m/s, q {cfg.accel_psd:g} km²/s³"
    )
    print(f"total {time.perf_counter() - started:.1f} s")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        payload = {
            "runs": n_runs,
            "seed": args.seed,
            "ephemeris": args.ephemeris,
            "cases": thesis_rows,
            "switching": switch_rows,
        }
        args.json.write_text(json.dumps(payload, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
