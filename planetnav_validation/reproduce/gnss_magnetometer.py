"""Reproduce Belokonov & Kramlikh (2007): attitude from a magnetometer and GNSS satellite visibility.

``python -m planetnav_validation.reproduce gnss-magnetometer [--runs N] [--s S] [--json PATH] [--plots DIR]``

The paper's model task (stage 1-3), vectorised over realisations:

1. circular orbit at 300 and 1000 km, inclination 63 deg, argument of latitude and RAAN uniform in
   [0, 360) deg; frozen GPS + GLONASS constellation (48 satellites, see
   ``planetnav_validation.gnss_visibility``) at a random epoch (each system turned about the Earth's
   axis and along its orbits by independent uniform angles);
2. attitude: yaw, pitch, roll each uniform in [0, 360) deg, as the paper states (``--attitude so3`` draws
   uniformly on SO(3) instead, a sensitivity check);
3. antenna on body x with a 180 deg beam; Earth-shadowed satellites excluded; antenna direction in the
   orbital frame from functional (5), both the exact sphere-constrained minimiser and the normalised
   unconstrained least squares;
4. axial dipole field, measured exactly (unit vectors); q-method with weights ``a_mag = s``,
   ``a_antenna = 1`` in criterion (2) (ERRATA 002 item 3: s is the ratio of the coefficients *in
   criterion (2)*, magnetometer : antenna, so s = 10 trusts the exact magnetometer ten times more);
5. errors: spatial angle of the antenna direction; yaw/pitch/roll errors read two ways (differences of
   the angles, wrapped, and the angles of the error rotation); total rotation angle.

See docs/gnss_magnetometer.md for the comparison with the published figures.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from planetnav_env.attitude import quaternion as qt
from planetnav_env.attitude.wahba import attitude_error_angle, q_method
from planetnav_env.errors import InvalidParameterError
from planetnav_validation import gnss_visibility as gv
from planetnav_validation.euler import euler321_differences, euler321_error_angles, quaternion_from_euler321

ALTITUDES_KM = (300.0, 1000.0)
INCLINATION_DEG = 63.0
DEFAULT_RUNS = 100_000
DEFAULT_S = 10.0
#: The s grid of figures 3-4 (log-spaced; s < 1 is the reading of the printed eq. (6), 1/a_i).
S_SWEEP = tuple(float(x) for x in np.round(np.logspace(-2, 3, 21), 6))
PAPER = {
    "300": {"antenna": 9.6, "psi": 5.8, "theta": 2.8, "phi": 4.0},
    "1000": {"antenna": 7.8, "psi": 5.1, "theta": 1.5, "phi": 3.6},
}
_EX = np.array([1.0, 0.0, 0.0])
_CHUNK = 10_000  # realisations per vectorised block: ~12 MB per (chunk, 48, 3) array


def _random_attitude(rng: np.random.Generator, n: int, sampling: str) -> np.ndarray:
    """True attitudes (body relative to orbital frame), (n, 4)."""
    if sampling == "euler":
        psi, theta, phi = rng.uniform(0.0, 2.0 * np.pi, size=(3, n))
        return quaternion_from_euler321(psi, theta, phi)
    if sampling == "so3":
        return qt.normalize(rng.normal(size=(n, 4)))
    raise InvalidParameterError(f"attitude sampling must be 'euler' or 'so3', got {sampling!r}")


def _attitude_from_antenna(
    b_mag: np.ndarray, r_mag: np.ndarray, antenna_orb: np.ndarray, s: float | np.ndarray
) -> np.ndarray:
    """q-method on the pair (magnetic field, antenna axis) with weights (s, 1); s scalar or (S,) grid."""
    n = b_mag.shape[0]
    b = np.stack([b_mag, np.broadcast_to(_EX, (n, 3))], axis=1)
    r = np.stack([r_mag, antenna_orb], axis=1)
    s_arr = np.asarray(s, dtype=float)
    if s_arr.ndim == 0:
        return q_method(b, r, np.stack([np.full(n, float(s_arr)), np.ones(n)], axis=-1))
    w = np.stack([np.broadcast_to(s_arr[:, None], (s_arr.size, n)), np.ones((s_arr.size, n))], axis=-1)
    return q_method(b[None], r[None], w)


def simulate(
    rng: np.random.Generator,
    runs: int,
    altitude_km: float,
    s: float = DEFAULT_S,
    attitude: str = "euler",
    inclination_deg: float = INCLINATION_DEG,
) -> dict[str, np.ndarray]:
    """The paper's Monte Carlo at one altitude; all arrays have length ``runs``.

    Returns angles in degrees: ``antenna_err_constrained``, ``antenna_err_unconstrained`` (spatial angle
    between the true and the estimated antenna axis); ``diff_err`` (runs, 3) |psi, theta, phi| differences;
    ``rot_err`` (runs, 3) yaw/pitch/roll of the error rotation; ``total_err``; the same three for the
    unconstrained antenna as ``*_unc``; counts ``n_visible``, ``n_structure``, ``n_shadowed``; and
    ``q_true``, ``q_est`` (runs, 4), the field and antenna vectors for sweeps.
    """
    runs = int(runs)
    if runs < 1:
        raise InvalidParameterError(f"runs must be >= 1, got {runs}")
    h = gv.validate_altitude(altitude_km)
    s = float(s)
    if not np.isfinite(s) or s <= 0.0:
        raise InvalidParameterError(f"weight ratio s must be positive and finite, got {s!r}")
    if not np.isfinite(inclination_deg):
        raise InvalidParameterError(f"inclination must be finite, got {inclination_deg!r} deg")
    # All random draws happen first, chunk by chunk in a fixed order; the computation per chunk is then a
    # pure function of them (a thread pool over chunks was tried: no gain on the 2-core machine).
    n_sys = len(gv.CONSTELLATION)
    inc = np.radians(inclination_deg)
    parts = []
    for start in range(0, runs, _CHUNK):
        n = min(_CHUNK, runs - start)
        orbit = rng.uniform(0.0, 2.0 * np.pi, size=(2, n))
        shells = rng.uniform(0.0, 2.0 * np.pi, size=(2, n, n_sys))
        q_true = _random_attitude(rng, n, attitude)
        parts.append(_simulate_chunk(orbit, shells, q_true, h, s, inc))
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


def _simulate_chunk(
    orbit: np.ndarray, shells: np.ndarray, q_true: np.ndarray, h: float, s: float, inc: float
) -> dict[str, np.ndarray]:
    """One block: ``orbit`` (2, n) argument of latitude and RAAN, ``shells`` (2, n, systems) RAAN and phase
    offsets of each constellation, ``q_true`` (n, 4) [rad]; pure function of its inputs."""
    r, v = gv.circular_orbit(gv.R_EARTH_KM + h, inc, orbit[1], orbit[0])
    c = gv.orbital_frame(r, v)
    sats = gv.constellation_positions(shells[0], shells[1])
    blocked = gv.earth_blocks(r, sats)
    los = sats - r[:, None, :]
    los /= np.linalg.norm(los, axis=-1, keepdims=True)
    los_orb = los @ np.swapaxes(c, -1, -2)  # row-vector form of C @ g

    rot = qt.dcm_body_to_inertial(q_true)  # body -> orbital
    antenna_true = rot[:, :, 0]
    cls = gv.classify_satellites(los_orb, antenna_true, blocked)
    normal = gv.normal_equations(los_orb, cls)
    ant_c = gv.constrained_from_normal(*normal)
    ant_u = gv.unconstrained_from_normal(*normal)

    b_orb = np.einsum("nij,nj->ni", c, gv.dipole_field(r))
    b_orb /= np.linalg.norm(b_orb, axis=-1, keepdims=True)
    b_body = np.einsum("nji,nj->ni", rot, b_orb)  # measured exactly: R^T b_orb

    out: dict[str, np.ndarray] = {
        "q_true": q_true,
        "b_body": b_body,
        "b_orb": b_orb,
        "antenna_constrained": ant_c,
        "antenna_unconstrained": ant_u,
        "n_visible": np.sum(cls == 1, axis=-1),
        "n_structure": np.sum(cls == -1, axis=-1),
        "n_shadowed": np.sum(cls == 0, axis=-1),
    }
    for tag, ant in (("", ant_c), ("_unc", ant_u)):
        cosang = np.clip(np.sum(ant * antenna_true, axis=-1), -1.0, 1.0)
        out["antenna_err" + ("_constrained" if tag == "" else "_unconstrained")] = np.degrees(
            np.arccos(cosang)
        )
        q_est = _attitude_from_antenna(b_body, b_orb, ant, s)
        out["q_est" + tag] = q_est
        out["diff_err" + tag] = np.degrees(euler321_differences(q_true, q_est))
        out["rot_err" + tag] = np.degrees(euler321_error_angles(q_true, q_est))
        out["total_err" + tag] = np.degrees(attitude_error_angle(q_true, q_est))
    return out


def sweep_s(sim: dict[str, np.ndarray], s_values: Sequence[float] = S_SWEEP, n_max: int = 20_000) -> dict:
    """Mean errors [deg] vs s on the first ``n_max`` realisations of ``sim`` (constrained antenna)."""
    n = min(n_max, sim["q_true"].shape[0])
    q_true = sim["q_true"][:n]
    s_arr = np.asarray(s_values, dtype=float)
    q_est = _attitude_from_antenna(sim["b_body"][:n], sim["b_orb"][:n], sim["antenna_constrained"][:n], s_arr)
    diff = np.degrees(euler321_differences(q_true[None], q_est))
    rot = np.degrees(euler321_error_angles(q_true[None], q_est))
    tot = np.degrees(attitude_error_angle(q_true[None], q_est))
    names = ("psi", "theta", "phi")
    return {
        "runs": int(n),
        "s": s_arr.tolist(),
        "diff_mean_deg": {k: diff[..., i].mean(axis=-1).tolist() for i, k in enumerate(names)},
        "rot_mean_deg": {k: rot[..., i].mean(axis=-1).tolist() for i, k in enumerate(names)},
        "total_mean_deg": tot.mean(axis=-1).tolist(),
    }


def summarise(sim: dict[str, np.ndarray]) -> dict:
    """The JSON block of one altitude (degrees)."""
    names = ("psi", "theta", "phi")

    def angles(a: np.ndarray) -> dict[str, float]:
        return {k: float(a[:, i].mean()) for i, k in enumerate(names)}

    tot = sim["total_err"]
    return {
        "antenna": {
            "constrained_mean_deg": float(sim["antenna_err_constrained"].mean()),
            "unconstrained_mean_deg": float(sim["antenna_err_unconstrained"].mean()),
        },
        # Primary: the literal reading (differences of the paper's angles); see the docs.
        "angle_err_mean_deg": angles(sim["diff_err"]),
        "angle_err_mean_deg_error_rotation": angles(sim["rot_err"]),
        "angle_err_mean_deg_unconstrained": angles(sim["diff_err_unc"]),
        "total_err_mean_deg": float(tot.mean()),
        "total_err_p90_deg": float(np.percentile(tot, 90.0)),
        "total_err_p90_deg_unconstrained": float(np.percentile(sim["total_err_unc"], 90.0)),
        "fraction_total_below_5deg": float(np.mean(tot < 5.0)),
        "fraction_all_angle_diffs_below_5deg": float(np.mean(np.all(sim["diff_err"] < 5.0, axis=-1))),
        "angle_diff_p90_deg": {
            k: float(np.percentile(sim["diff_err"][:, i], 90.0)) for i, k in enumerate(names)
        },
        "visible_mean": float(sim["n_visible"].mean()),
        "structure_shadowed_mean": float(sim["n_structure"].mean()),
        "shadowed_mean": float(sim["n_shadowed"].mean()),
        "min_visible": int(sim["n_visible"].min()),
        "fraction_fewer_than_4_visible": float(np.mean(sim["n_visible"] < 4)),
    }


def run_experiment(
    runs: int = DEFAULT_RUNS, s: float = DEFAULT_S, seed: int = 2007, attitude: str = "euler"
) -> tuple[dict, dict[str, dict[str, np.ndarray]], float]:
    """Both altitudes: (JSON summary, raw simulations by altitude key, Monte Carlo seconds)."""
    rng = np.random.default_rng(seed)
    sims: dict[str, dict[str, np.ndarray]] = {}
    t0 = time.perf_counter()
    for h in ALTITUDES_KM:
        sims[str(int(h))] = simulate(rng, runs, h, s=s, attitude=attitude)
    elapsed = time.perf_counter() - t0
    summary = {
        "runs": int(runs),
        "s": float(s),
        "seed": int(seed),
        "attitude_sampling": attitude,
        "monte_carlo_seconds": elapsed,
        "altitudes_km": {k: summarise(v) for k, v in sims.items()},
    }
    return summary, sims, elapsed


def _table(summary: dict) -> str:
    lines = [
        f"Belokonov & Kramlikh (2007) reproduction: {summary['runs']} runs per altitude, "
        f"s = {summary['s']:g}, attitude sampling '{summary['attitude_sampling']}'",
        f"{'quantity [deg]':42s} {'paper 300':>9s} {'ours 300':>9s} {'paper 1000':>10s} {'ours 1000':>10s}",
    ]
    alt = summary["altitudes_km"]

    def row(label: str, paper_key: str | None, get) -> None:
        vals = []
        for h in ("300", "1000"):
            p = PAPER[h][paper_key] if paper_key else None
            vals += ["-" if p is None else f"{p:.1f}", f"{get(alt[h]):.2f}"]
        lines.append(f"{label:42s} {vals[0]:>9s} {vals[1]:>9s} {vals[2]:>10s} {vals[3]:>10s}")

    row("antenna error, constrained |u|=1 (mean)", "antenna", lambda a: a["antenna"]["constrained_mean_deg"])
    row(
        "antenna error, unconstrained+normalised", "antenna", lambda a: a["antenna"]["unconstrained_mean_deg"]
    )
    for k in ("psi", "theta", "phi"):
        row(f"{k} error, angle difference (mean)", k, lambda a, k=k: a["angle_err_mean_deg"][k])
    for k in ("psi", "theta", "phi"):
        row(f"{k} error, error rotation (mean)", k, lambda a, k=k: a["angle_err_mean_deg_error_rotation"][k])
    for k in ("psi", "theta", "phi"):
        row(
            f"{k} error, unconstrained antenna (mean)",
            k,
            lambda a, k=k: a["angle_err_mean_deg_unconstrained"][k],
        )
    row("total rotation error (mean)", None, lambda a: a["total_err_mean_deg"])
    row("total rotation error p90 ('90% < 5')", None, lambda a: a["total_err_p90_deg"])
    row("fraction total < 5 deg [-]", None, lambda a: a["fraction_total_below_5deg"])
    row("visible satellites (mean) [-]", None, lambda a: a["visible_mean"])
    row("behind the antenna (mean) [-]", None, lambda a: a["structure_shadowed_mean"])
    row("Earth-shadowed (mean) [-]", None, lambda a: a["shadowed_mean"])
    return "\n".join(lines)


def _plots(summary: dict, sims: dict[str, dict[str, np.ndarray]], sweeps: dict, out_dir: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []

    def density(ax, data: np.ndarray, label: str, hi: float) -> None:
        bins = np.linspace(0.0, hi, 121)
        ax.hist(np.clip(data, 0.0, hi), bins=bins, density=True, histtype="step", label=label)

    def save(fig, name: str) -> None:
        path = out_dir / name
        fig.tight_layout()
        fig.savefig(path, dpi=110)
        plt.close(fig)
        written.append(path)

    for fig_no, h in ((1, "300"), (2, "1000")):
        sim = sims[h]
        fig, ax = plt.subplots(figsize=(6, 4))
        density(ax, sim["antenna_err_constrained"], "constrained |u| = 1", 60.0)
        density(ax, sim["antenna_err_unconstrained"], "unconstrained, normalised", 60.0)
        ax.axvline(PAPER[h]["antenna"], color="k", ls="--", lw=0.8, label=f"paper mean {PAPER[h]['antenna']}")
        ax.set(
            xlabel="antenna direction error d_a [deg] (last bin: >= 60)",
            ylabel="density P(d_a) [1/deg]",
            title=f"Fig. {fig_no}: antenna error, h = {h} km",
        )
        ax.legend()
        save(fig, f"fig{fig_no:02d}_antenna_{h}km.png")

    for fig_no, h in ((3, "300"), (4, "1000")):
        sw = sweeps[h]
        fig, ax = plt.subplots(figsize=(6, 4))
        for k in ("theta", "psi", "phi"):
            ax.semilogx(sw["s"], sw["diff_mean_deg"][k], marker=".", label=f"{k} (angle difference)")
        ax.semilogx(sw["s"], sw["rot_mean_deg"]["theta"], ls="--", label="theta (error rotation)")
        ax.semilogx(sw["s"], sw["total_mean_deg"], color="k", label="total rotation angle")
        ax.axvline(DEFAULT_S, color="grey", lw=0.8)
        ax.set(
            xlabel="s = a_mag / a_antenna in criterion (2)",
            ylabel="mean error [deg]",
            title=f"Fig. {fig_no}: mean error vs s, h = {h} km ({sw['runs']} runs)",
        )
        ax.legend(fontsize=8)
        save(fig, f"fig{fig_no:02d}_s_sweep_{h}km.png")

    fig_no = 5
    for h in ("300", "1000"):
        sim = sims[h]
        for i, k in ((1, "theta"), (0, "psi"), (2, "phi")):
            fig, ax = plt.subplots(figsize=(6, 4))
            density(ax, sim["diff_err"][:, i], "angle difference", 30.0)
            density(ax, sim["rot_err"][:, i], "error rotation", 30.0)
            ax.axvline(PAPER[h][k], color="k", ls="--", lw=0.8, label=f"paper mean {PAPER[h][k]}")
            ax.set(
                xlabel=f"{k} error [deg] (last bin: >= 30)",
                ylabel="density [1/deg]",
                title=f"Fig. {fig_no}: {k} error, h = {h} km",
            )
            ax.legend()
            save(fig, f"fig{fig_no:02d}_{k}_{h}km.png")
            fig_no += 1
    return written


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m planetnav_validation.reproduce gnss-magnetometer", description=__doc__.split("\n")[0]
    )
    parser.add_argument("--runs", type=int, default=DEFAULT_RUNS, help="realisations per altitude (100000)")
    parser.add_argument("--s", type=float, default=DEFAULT_S, help="weight ratio magnetometer:antenna (10)")
    parser.add_argument("--seed", type=int, default=2007, help="random seed (2007)")
    parser.add_argument(
        "--attitude",
        choices=("euler", "so3"),
        default="euler",
        help="random attitudes: Euler angles uniform (the paper) or uniform on SO(3)",
    )
    parser.add_argument("--sweep-runs", type=int, default=20_000, help="realisations used for the s sweep")
    parser.add_argument("--json", type=Path, help="write the summary JSON here")
    parser.add_argument("--plots", type=Path, help="write figures 1-10 into this directory")
    args = parser.parse_args(list(argv) if argv is not None else None)
    if args.runs < 1 or args.sweep_runs < 1:
        parser.error("--runs and --sweep-runs must be >= 1")
    if not np.isfinite(args.s) or args.s <= 0.0:
        parser.error(f"--s must be a positive number, got {args.s}")

    summary, sims, elapsed = run_experiment(args.runs, args.s, args.seed, args.attitude)
    sweeps = {h: sweep_s(sim, n_max=args.sweep_runs) for h, sim in sims.items()}
    summary["s_sweep"] = sweeps
    for h, sw in sweeps.items():
        i = int(np.argmin(sw["diff_mean_deg"]["theta"]))
        summary["altitudes_km"][h]["s_best_theta"] = sw["s"][i]
    print(_table(summary))
    print(f"Monte Carlo time: {elapsed:.2f} s for 2 x {args.runs} realisations")
    for h in sweeps:
        print(
            f"s sweep h = {h} km: mean theta error (angle difference) minimal at s = "
            f"{summary['altitudes_km'][h]['s_best_theta']:g}"
        )
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(summary, indent=2))
        print(f"wrote {args.json}")
    if args.plots is not None:
        for p in _plots(summary, sims, sweeps, args.plots):
            print(f"wrote {p}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
