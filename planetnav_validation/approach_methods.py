"""The patent-003 navigation methods on the Mars approach: a Monte Carlo EKF harness.

Runs the optical-only, pulsar-only and hybrid filters on the truth of
:class:`planetnav_env.scenarios.approach.MarsApproach` (``python -m planetnav_validation.reproduce
optical-pulsar`` reproduces the patent's claims with it, ``docs/optical_pulsar.md``).

Filter
------
One :class:`planetnav_validation.numpy_ekf.BatchEKF` per method (the leading axis = Monte Carlo runs), RK4
prediction with the RK4 state transition matrix at ``dt_s`` (default 60 s), the same force model (the step
size is the only dynamics error: the truth takes steps of at most 10 s; ``tests/env/test_approach.py`` bounds
both against DOP853). Measurements
(each sensor at its own rate; when both report at one step, they form one stacked vector and one update,
``z = [p, l, delta_phi_1, ...]``):

* optical: (p, l) [mm] of Mars's centre (:mod:`planetnav_validation.image_plane`), every
  ``optical_interval_s``; the truth camera points at Mars with a random pointing error; the filter uses the
  star tracker's attitude (truth attitude times a random error) in ``R_ci``;
* pulsar: total phase [cycles] of each pulsar (:mod:`planetnav_env.sensors.pulsar`), one per integration
  window ``detector.integration_time_s``, cycle ambiguity resolved against the prediction when
  ``k sigma_pred < 1/2`` cycle (otherwise skipped and counted).

Methods: ``OPN`` optical only, ``PN`` pulsar only, ``OPHN`` both.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from planetnav_env.astro.bodies import body
from planetnav_env.errors import InvalidParameterError, require_positive
from planetnav_env.estimation.ekf import FilterConfig
from planetnav_env.estimation.ekf_kernels import nees_batch_kernel
from planetnav_env.numerics.portable_math import unit3
from planetnav_env.scenarios.approach import MarsApproach
from planetnav_env.sensors import pulsar as psr
from planetnav_env.sensors.camera_config import DEFAULT_CAMERA, CameraConfig
from planetnav_validation.image_plane import (
    boresight_camera_to_inertial,
    image_plane_coordinates,
    image_plane_jacobian,
    image_plane_sigma_mm,
)
from planetnav_validation.numpy_ekf import BatchEKF

__all__ = [
    "METHODS",
    "ApproachResult",
    "NavConfig",
    "check_pulsars_visible",
    "run_method",
    "run_methods",
]

#: Which sensors each method uses: (optical, pulsar).
METHODS: dict[str, tuple[bool, bool]] = {"OPN": (True, False), "PN": (False, True), "OPHN": (True, True)}


@dataclass(frozen=True)
class NavConfig:
    """Sensors and filter of the navigation runs.

    camera: its ``focal_length_mm``, ``camera_to_body``, ``direction_noise_arcsec`` (centroiding, 1-sigma per
        axis) and field of view are used; optical_interval_s [s] between images;
    star_tracker_arcsec: 1-sigma per-axis error of the star tracker's attitude used in ``R_ci`` [arcsec];
    pointing_sigma_deg: 1-sigma per-axis error of the truth boresight about the Mars direction [deg] (the
        planet is imaged off-centre; the measured (p, l) carries the offset);
    pulsars: catalogue names; detector: area, integration time (= interval between TOAs), background;
    filter: P0, Q, gating (:class:`FilterConfig`), units km, km/s, km^2/s^3. Default: 100 km and 1 m/s per
        axis (1-sigma) a priori; white-acceleration PSD 1e-16 km^2/s^3 (~1e-10 km/s^2 over an hour, the
        order of unmodelled solar pressure); gate at chi-square probability 0.9999;
    ambiguity_k_sigma: a pulsar phase is used only if ``k sigma_pred < 1/2`` cycle.
    """

    camera: CameraConfig = DEFAULT_CAMERA
    optical_interval_s: float = 600.0
    star_tracker_arcsec: float = 3.0
    pointing_sigma_deg: float = 0.1
    pulsars: tuple[str, ...] = ("B0531+21",)
    detector: psr.XrayDetector = psr.DEFAULT_DETECTOR
    filter: FilterConfig = field(
        default_factory=lambda: FilterConfig(sigma_pos0=100.0, sigma_vel0=1e-3, accel_psd=1e-16)
    )
    ambiguity_k_sigma: float = 3.0

    def __post_init__(self) -> None:
        require_positive("NavConfig.optical_interval_s", self.optical_interval_s)
        for name in ("star_tracker_arcsec", "pointing_sigma_deg"):
            v = getattr(self, name)
            if not np.isfinite(v) or v < 0.0:
                raise InvalidParameterError(f"NavConfig.{name} must be >= 0, got {v!r}")
        object.__setattr__(self, "pulsars", tuple(psr.pulsar(p).bname for p in self.pulsars))
        if not self.pulsars:
            raise InvalidParameterError("NavConfig.pulsars must name at least one pulsar")
        require_positive("NavConfig.ambiguity_k_sigma", self.ambiguity_k_sigma)


@dataclass
class ApproachResult:
    """Histories of one method's Monte Carlo (time axis first, run axis second).

    t_h (K+1,) hours since the start; pos_err, vel_err (K+1, N, 3) [km, km/s] estimate minus truth;
    sigma_pos (K+1, N) ``sqrt(trace P_rr)`` [km] (1-sigma of the 3-D position error); nees (K+1, N);
    counts of optical / pulsar updates and of skipped pulsar phases (ambiguity), rejected (gated) updates.
    """

    method: str
    t_h: np.ndarray
    pos_err: np.ndarray
    vel_err: np.ndarray
    sigma_pos: np.ndarray
    nees: np.ndarray
    n_optical: int
    n_pulsar: int
    n_ambiguity_skipped: int
    n_pulsar_not_visible: int
    n_optical_not_visible: int
    rejected: np.ndarray

    @property
    def pos_err_norm(self) -> np.ndarray:
        """|position error| (K+1, N) [km]."""
        return np.linalg.norm(self.pos_err, axis=-1)

    @property
    def rms_over_runs(self) -> np.ndarray:
        """RMS over runs of |position error| (K+1,) [km]."""
        return np.sqrt(np.mean(self.pos_err_norm**2, axis=1))

    def time_to_km(self, threshold_km: float = 10.0) -> float | None:
        """Hours from the start after which the run-RMS position error stays below ``threshold_km`` to the
        end; None if it is above at the end."""
        e = self.rms_over_runs
        above = np.flatnonzero(e >= threshold_km)
        if above.size == 0:
            return float(self.t_h[0])
        if above[-1] == e.size - 1:
            return None
        return float(self.t_h[above[-1] + 1])

    def summary(self) -> dict[str, float | None]:
        """The reproduction's metrics: final_pos_err_km (RMS over runs at the end), rms_pos_err_km_last_half
        (RMS over runs and over the second half of the time span), time_to_10km_h (see :meth:`time_to_km`)."""
        e = self.pos_err_norm
        half = e[e.shape[0] // 2 :]
        return {
            "final_pos_err_km": float(np.sqrt(np.mean(e[-1] ** 2))),
            "rms_pos_err_km_last_half": float(np.sqrt(np.mean(half**2))),
            "time_to_10km_h": self.time_to_km(10.0),
            "final_3sigma_km": float(3.0 * np.sqrt(np.mean(self.sigma_pos[-1] ** 2))),
            "mean_final_nees": float(np.mean(self.nees[-1])),
        }


@dataclass
class _Draws:
    """Random numbers shared by every method (common random numbers): same seed, same draws."""

    x0_err: np.ndarray  # (N, 6)
    centroid: np.ndarray  # (n_opt, N, 2) standard normal
    pointing: np.ndarray  # (n_opt, N, 2) standard normal
    tracker: np.ndarray  # (n_opt, N, 3) standard normal
    phase: np.ndarray  # (n_psr, N, M) standard normal


def _schedule(n_steps: int, dt: float, interval: float) -> np.ndarray:
    """Step indices k (1..n_steps) at which a sensor with report ``interval`` [s] delivers: the first grid
    time at or after each multiple of the interval since the start."""
    due = np.arange(1, int(np.floor(n_steps * dt / interval + 1e-9)) + 1) * interval
    return np.unique(np.ceil(due / dt - 1e-9).astype(int))


def _small_rotation(angles: np.ndarray) -> np.ndarray:
    """Rotation matrices (N, 3, 3) of rotation vectors ``angles`` (N, 3) [rad] (Rodrigues)."""
    th = np.linalg.norm(angles, axis=-1)[:, None, None]
    k = np.zeros((angles.shape[0], 3, 3))
    k[:, 0, 1], k[:, 0, 2], k[:, 1, 2] = -angles[:, 2], angles[:, 1], -angles[:, 0]
    k[:, 1, 0], k[:, 2, 0], k[:, 2, 1] = angles[:, 2], -angles[:, 1], angles[:, 0]
    with np.errstate(invalid="ignore", divide="ignore"):
        a = np.where(th > 0, np.sin(th) / th, 1.0)
        b = np.where(th > 0, (1.0 - np.cos(th)) / th**2, 0.5)
    return np.eye(3) + a * k + b * (k @ k)


def _mars_disk_fits(scn: MarsApproach, camera: CameraConfig, margin_rad: float) -> np.ndarray:
    """Per grid time: the whole Mars disk (plus ``margin_rad`` of pointing error) fits in the sensor's
    smaller half field of view (a limb fit needs the whole limb)."""
    ang_rad = np.arcsin(np.clip(body("mars").radius / scn.range_km(), 0.0, 1.0))
    return ang_rad + margin_rad < min(camera.half_fov_rad)


def _sun_mars_angle_ok(scn: MarsApproach, camera: CameraConfig) -> np.ndarray:
    """Per grid time: Mars is outside the camera's Sun-exclusion cone."""
    r_helio = scn.mars_helio + scn.x_true[:, :3]
    to_sun = unit3(-r_helio)
    to_mars = unit3(-scn.x_true[:, :3])
    ang = np.arccos(np.clip(np.sum(to_sun * to_mars, axis=-1), -1.0, 1.0))
    return ang > camera.sun_exclusion_rad


def run_methods(
    scenario: MarsApproach,
    methods: tuple[str, ...] | list[str] = tuple(METHODS),
    runs: int = 20,
    seed: int = 0,
    nav: NavConfig | None = None,
) -> dict[str, ApproachResult]:
    """Monte Carlo of several navigation methods on ``scenario``, advanced together in one batched EKF.

    Runs differ in the initial estimation error (drawn from P0) and in the measurement noise; every method
    sees the same draws (common random numbers), so differences between methods are not sampling noise.
    Raises :class:`NotVisibleError` if a pulsar is Sun-blocked at any time of the approach (a pulsar the
    detector can never time is a configuration error, not a gap); occultations by Mars and images with Mars
    too large for the field of view or inside the Sun-exclusion cone are gaps (counted).
    """
    methods = tuple(methods)
    for m in methods:
        if m not in METHODS:
            raise InvalidParameterError(f"unknown method {m!r}; choose from {list(METHODS)}")
    if not methods or len(set(methods)) != len(methods):
        raise InvalidParameterError(f"methods must be distinct and non-empty, got {methods!r}")
    runs = int(runs)
    if runs < 1:
        raise InvalidParameterError(f"runs must be >= 1, got {runs}")
    nav = nav or NavConfig()
    scn = scenario
    cam = nav.camera
    n_steps, dt = scn.n_steps, scn.dt
    pulsars = [psr.pulsar(p) for p in nav.pulsars]
    m_psr = len(pulsars)
    g = len(methods)
    nb = g * runs
    uses_opt = np.repeat([METHODS[m][0] for m in methods], runs)
    uses_psr = np.repeat([METHODS[m][1] for m in methods], runs)

    r_helio_true = scn.mars_helio + scn.x_true[:, :3]
    if np.any(uses_psr):
        psr.check_visible(r_helio_true, pulsars, nav.detector)

    opt_steps = _schedule(n_steps, dt, nav.optical_interval_s)
    psr_steps = _schedule(n_steps, dt, nav.detector.integration_time_s)

    rng = np.random.default_rng(seed)
    p0 = nav.filter.initial_covariance()
    draws = _Draws(
        x0_err=rng.standard_normal((runs, 6)) @ np.linalg.cholesky(p0).T,
        centroid=rng.standard_normal((opt_steps.size, runs, 2)),
        pointing=rng.standard_normal((opt_steps.size, runs, 2)),
        tracker=rng.standard_normal((opt_steps.size, runs, 3)),
        phase=rng.standard_normal((psr_steps.size, runs, m_psr)),
    )

    def tile(a: np.ndarray) -> np.ndarray:
        return np.tile(a, (g,) + (1,) * (a.ndim - 1))

    x_true = scn.x_true
    ekf = BatchEKF(scn.model, tile(x_true[0] + draws.x0_err), p0, nav.filter, perturbers=scn.perturbers)

    sig_c = cam.sigma_direction_rad
    sig_st = np.deg2rad(nav.star_tracker_arcsec / 3600.0)
    sig_pt = np.deg2rad(nav.pointing_sigma_deg)
    r_opt = np.eye(2) * image_plane_sigma_mm(cam, nav.star_tracker_arcsec) ** 2
    sig_phase = np.array([psr.phase_sigma_cycles(p, nav.detector) for p in pulsars])
    r_psr = np.diag(sig_phase**2)

    opt_ok = _mars_disk_fits(scn, cam, 3.0 * sig_pt) & _sun_mars_angle_ok(scn, cam)
    psr_vis = np.all(
        psr.pulsar_visibility(
            r_helio_true, pulsars, nav.detector, scn.mars_helio, psr.mars_radius_km()
        ).visible,
        axis=1,
    )
    opt_index = {int(k): i for i, k in enumerate(opt_steps)}
    psr_index = {int(k): i for i, k in enumerate(psr_steps)}

    k_all = n_steps + 1
    pos_err = np.empty((k_all, nb, 3))
    vel_err = np.empty((k_all, nb, 3))
    sigma_pos = np.empty((k_all, nb))
    nees = np.empty((k_all, nb))

    def record(k: int) -> None:
        e = ekf.x - x_true[k]
        pos_err[k] = e[:, :3]
        vel_err[k] = e[:, 3:]
        sigma_pos[k] = np.sqrt(np.trace(ekf.P[:, :3, :3], axis1=1, axis2=2))
        nees_batch_kernel(
            ekf.x, np.broadcast_to(x_true[k], ekf.x.shape), np.ascontiguousarray(ekf.P), nees[k]
        )

    n_opt = np.zeros(nb, int)
    n_psr = np.zeros(nb, int)
    n_amb = np.zeros(nb, int)
    gaps = {"opt": 0, "psr": 0}
    mars = np.zeros(3)
    record(0)
    for k in range(n_steps):
        ekf.predict(scn.t[k], dt)
        kk = k + 1
        opt_now = kk in opt_index and np.any(uses_opt)
        psr_now = kk in psr_index and np.any(uses_psr)
        if opt_now and not opt_ok[kk]:
            gaps["opt"] += 1
            opt_now = False
        if psr_now and not psr_vis[kk]:
            gaps["psr"] += 1
            psr_now = False
        if opt_now:
            i = opt_index[kk]
            los_true = unit3(mars - x_true[kk, :3])
            # Truth camera: boresight on Mars, off by the pointing error; the star tracker reports the
            # attitude with its own error, and the filter's R_ci is built from the reported attitude.
            off = np.concatenate([sig_pt * draws.pointing[i], np.zeros((runs, 1))], axis=-1)
            r_ci_true = boresight_camera_to_inertial(np.broadcast_to(los_true, (runs, 3))) @ _small_rotation(
                off
            )
            r_ci_est = tile(r_ci_true @ _small_rotation(sig_st * draws.tracker[i]))
            pl_true = image_plane_coordinates(
                np.broadcast_to(x_true[kk, :3], (runs, 3)), mars, r_ci_true, cam
            )
            z_opt = tile(pl_true + cam.focal_length_mm * sig_c * draws.centroid[i])
            h_opt = image_plane_coordinates(ekf.x[:, :3], mars, r_ci_est, cam)
            j_opt = image_plane_jacobian(ekf.x[:, :3], mars, r_ci_est, cam)
        if psr_now:
            i = psr_index[kk]
            frac = psr.measure_phase(
                None, scn.mars_ssb[kk] + x_true[kk, :3], pulsars, nav.detector, noise=draws.phase[i]
            )
            h_psr = psr.phase_model(scn.mars_ssb[kk] + ekf.x[:, :3], pulsars)
            j_psr = psr.phase_jacobian(nb, pulsars)
            s_pred = np.einsum("nij,njk,nik->ni", j_psr, ekf.P, j_psr) + sig_phase**2
            # Per filter and pulsar: is the cycle count trustworthy (k sigma < 1/2 cycle)?
            resolvable = psr.ambiguity_resolvable(np.sqrt(s_pred), nav.ambiguity_k_sigma)
            z_psr = psr.resolve_cycle_ambiguity(tile(frac), h_psr)
            n_amb += np.sum(uses_psr[:, None] & ~resolvable, axis=1)
        psr_use = uses_psr[:, None] & resolvable if psr_now else np.zeros((nb, m_psr), bool)
        opt_on = uses_opt if opt_now else np.zeros(nb, bool)
        # Filters are grouped by which rows they measure now; each group gets one stacked update of the mixed
        # measurement z = [p, l, phases of the pulsars whose cycle count is trusted].
        key = np.column_stack([opt_on, psr_use])
        for pattern in np.unique(key[key.any(axis=1)], axis=0):
            group = np.all(key == pattern, axis=1)
            cols = np.flatnonzero(pattern[1:])
            zs, hs, js, rs = [], [], [], []
            if pattern[0]:
                zs, hs, js, rs = [z_opt], [h_opt], [j_opt], [r_opt]
            if cols.size:
                zs.append(z_psr[:, cols])
                hs.append(h_psr[:, cols])
                js.append(j_psr[:, cols])
                rs.append(r_psr[np.ix_(cols, cols)])
            ekf.update(
                np.concatenate(zs, axis=-1),
                np.concatenate(hs, axis=-1),
                np.concatenate(js, axis=-2),
                _block_diag(rs),
                active=group,
            )
        n_opt += opt_on
        n_psr += psr_use.any(axis=1)
        record(kk)

    out = {}
    for j, m in enumerate(methods):
        sl = slice(j * runs, (j + 1) * runs)
        out[m] = ApproachResult(
            method=m,
            t_h=scn.hours,
            pos_err=pos_err[:, sl],
            vel_err=vel_err[:, sl],
            sigma_pos=sigma_pos[:, sl],
            nees=nees[:, sl],
            n_optical=int(n_opt[sl].max()),
            n_pulsar=int(n_psr[sl].max()),
            n_ambiguity_skipped=int(n_amb[sl].sum()),
            n_pulsar_not_visible=gaps["psr"] if METHODS[m][1] else 0,
            n_optical_not_visible=gaps["opt"] if METHODS[m][0] else 0,
            rejected=ekf.rejected[sl].copy(),
        )
    return out


def run_method(
    scenario: MarsApproach, method: str, runs: int = 20, seed: int = 0, nav: NavConfig | None = None
) -> ApproachResult:
    """One method alone (see :func:`run_methods`; with the same seed it gives the same numbers)."""
    return run_methods(scenario, (method,), runs, seed, nav)[method]


def _block_diag(blocks: list[np.ndarray]) -> np.ndarray:
    m = sum(b.shape[0] for b in blocks)
    out = np.zeros((m, m))
    i = 0
    for b in blocks:
        out[i : i + b.shape[0], i : i + b.shape[0]] = b
        i += b.shape[0]
    return out


def check_pulsars_visible(scenario: MarsApproach, nav: NavConfig) -> None:
    """Raise :class:`NotVisibleError` if a configured pulsar is Sun-blocked anywhere on the approach."""
    r = scenario.mars_helio + scenario.x_true[:, :3]
    psr.check_visible(r, nav.pulsars, nav.detector)
