"""The core's parameter record, built once from an :class:`~planetnav_env.config.EnvConfig`.

:func:`build_params` turns the validated configuration into a :class:`CoreParams` (arrays, shared by
every row; its scalars in the named record ``scalars``); :class:`ChannelPlan` says which ephemeris channel
of a row's table holds which body.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from planetnav_env.astro.bodies import body
from planetnav_env.config import EnvConfig
from planetnav_env.core import layout as L
from planetnav_env.core.ephemeris_table import SEGMENT_S
from planetnav_env.core.records import CoreParams, make_scalars
from planetnav_env.estimation.ekf import process_noise
from planetnav_env.estimation.ekf_kernels import KIND_CODES
from planetnav_env.numerics.portable_math import norm3
from planetnav_env.options import kernel_values
from planetnav_env.sensors import pulsar as psr
from planetnav_env.sensors.star_tracker import StarTrackerConfig, star_fix_tables

ARCSEC = math.pi / 648_000.0
#: Pointing error [rad] and rate [rad/s] below which a held target's attitude counts as settled (see
#: docs/architecture.md: the coarse sub-steps are tested to stay within 1" of the fine integration).
SETTLE_ANGLE_RAD = 1e-4
SETTLE_RATE_RAD_S = 1e-5


@dataclass(frozen=True)
class ChannelPlan:
    """Ephemeris channels of a row's table: ``central`` (heliocentric; -1 for the Sun, always zero),
    ``planets`` (heliocentric, in config order), ``perturbers`` (relative to the central body) and ``ssb``
    (central body relative to the Solar-system barycentre; -1 without pulsars)."""

    central_body: str
    planets: tuple[str, ...]
    perturbers: tuple[str, ...]
    with_ssb: bool

    @property
    def central(self) -> int:
        return -1 if self.central_body == "sun" else 0

    @property
    def planet0(self) -> int:
        return self.central + 1

    @property
    def pert0(self) -> int:
        return self.planet0 + len(self.planets)

    @property
    def ssb(self) -> int:
        return self.pert0 + len(self.perturbers) if self.with_ssb else -1

    @property
    def n_channels(self) -> int:
        return self.pert0 + len(self.perturbers) + (1 if self.with_ssb else 0)

    def positions(self, ephemeris, times: np.ndarray) -> np.ndarray:
        """(T, C, 3) [km] of every channel at ``times`` [TDB s] (what the table is fitted to)."""
        cols = []
        central = (
            ephemeris.position(self.central_body, times)
            if self.central_body != "sun"
            else np.zeros((times.size, 3))
        )
        if self.central >= 0:
            cols.append(central)
        cols += [ephemeris.position(p, times) for p in self.planets]
        cols += [ephemeris.position(b, times) - central for b in self.perturbers]
        if self.with_ssb:
            cols.append(central + ephemeris.sun_barycentric_position(times))
        return np.stack(cols, axis=1)


def episode_duration_s(cfg: EnvConfig) -> float:
    """Span a row's table covers: the episode plus one step (the last RK4 stage reaches t_K + dt)."""
    return (cfg.episode_steps + 1) * cfg.step_s


def build_params(cfg: EnvConfig, plan: ChannelPlan, mu_central: float, mus: np.ndarray) -> CoreParams:
    """The record of everything the kernels read, from a validated config and its channel plan."""
    att = cfg.attitude
    cam = cfg.camera
    layout = L.ObservationLayout.for_config(cfg)
    approach = cfg.scenario == "mars-approach"
    coarse_s = cfg.settled_substep_s
    ops = cfg.operations
    deadlines = np.zeros(L.MAX_DEADLINES)
    if ops is not None:
        deadlines[: len(ops.deadlines_s)] = ops.deadlines_s
    pos_scale, vel_scale = L.observation_scales(cfg.scenario)
    ops_q_par, ops_q_perp = ops.psd_km2_s3 if ops is not None else (0.0, 0.0)
    scalars = make_scalars(
        **kernel_values(cfg),  # the scalars that copy an option (declared with kernel=)
        n_sub=cfg.n_substeps,
        n_coarse=round(cfg.step_s / coarse_s) if coarse_s > 0 else 0,
        segment_s=SEGMENT_S,
        rate_noise=math.radians(att.rate_noise_deg_s),
        settle_angle=SETTLE_ANGLE_RAD,
        settle_rate=SETTLE_RATE_RAD_S,
        mode=L.MODE_CODES[cfg.action_mode],
        mu=mu_central,
        central_radius=body(plan.central_body).radius,
        euler=cfg.filter.stm == "euler",
        kind=KIND_CODES[cfg.measurement_model],
        sig_dir=math.hypot(cam.sigma_direction_rad, cfg.star_tracker_sigma_arcsec * ARCSEC),
        sig_size=cam.sigma_alpha_rad,
        cos_half_diag=math.cos(cam.half_fov_diagonal_rad),
        alpha_max=2.0 * min(cam.half_fov_rad),
        sigma_alpha=cam.sigma_alpha_rad,
        ideal_star=cfg.star_tracker == "ideal",
        world_lt=cfg.world.light_time_on,
        world_ab=cfg.world.aberration_on,
        onboard_lt=cfg.world.light_time_corrected,
        onboard_ab=cfg.world.aberration_corrected,
        det_half_fov=math.radians(0.5 * cfg.detector_fov_deg),
        sun_avoid=math.radians(cfg.detector.sun_avoidance_deg),
        reward_truth=cfg.reward == "truth",
        n_planets=cfg.n_planets,
        n_pulsars=cfg.n_pulsars,
        n_targets=cfg.n_targets,
        ch_central=plan.central,
        ch_planet0=plan.planet0,
        ch_pert0=plan.pert0,
        n_pert=len(plan.perturbers),
        ch_ssb=plan.ssb,
        approach=approach,
        noise_per_step=cfg.noise_streams == "per_step",
        pos_scale=pos_scale,
        vel_scale=vel_scale,
        obs_planets=layout.planets_start,
        obs_pulsars=layout.pulsars_start,
        obs_target=layout.target_start,
        obs_elapsed=layout.elapsed_index,
        obs_in_field=layout.in_field_start if layout.in_field else -1,
        obs_ops=layout.operations_start if ops is not None else 0,
        ops=ops is not None,
        ops_n_dl=len(ops.deadlines_s) if ops is not None else 0,
        ops_acc=ops.thrust_accel_km_s2 if ops is not None else 0.0,
        ops_q_par=ops_q_par,
        ops_q_perp=ops_q_perp,
        ops_cos_tol=math.cos(math.radians(ops.attitude_tolerance_deg)) if ops is not None else 0.0,
    )
    # The thesis's star camera is one instrument: the stars in the planet image give the attitude.
    # Sharing the boresight matters: a tracker's weak axis is roll about its own boresight, which would
    # swing a camera mounted elsewhere by ~14" (measured) instead of ~1.4".
    tracker = StarTrackerConfig(
        boresight_body=tuple(float(v) for v in cam.boresight_body),
        fov_deg=float(np.degrees(2.0 * min(cam.half_fov_rad))),
    )
    tables = star_fix_tables(tracker)
    pulsars = [psr.pulsar(name) for name in cfg.pulsars]
    psr_rows = np.array(
        [[*p.direction, p.wavelength_km, psr.phase_sigma_cycles(p, cfg.detector)] for p in pulsars]
    ).reshape(-1, 5)
    jm = np.diag(np.asarray(att.inertia, dtype=float))
    return CoreParams(
        scalars=scalars,
        gate=np.array([cfg.filter.gate_threshold(m) for m in (1, 2, 3)], dtype=float),
        ops_deadlines=deadlines,
        jm=jm,
        jinv=np.diag(1.0 / np.diagonal(jm)),
        tau_max=np.full(3, att.wheel_torque_limit),
        h_max=np.full(3, att.wheel_momentum_capacity),
        boresight=np.ascontiguousarray(cam.boresight_body, dtype=float),
        radii=np.array([body(p).radius for p in cfg.planets]),
        mus=np.ascontiguousarray(mus, dtype=float),
        psr=np.ascontiguousarray(psr_rows),
        c2b=np.ascontiguousarray(cam._c2b),
        cam=np.ascontiguousarray(cam._params),
        qproc=process_noise(cfg.step_s, cfg.filter.accel_psd),
        stars=tables,
        q_bias=bias_quaternion(cfg.star_tracker_bias_arcsec),
    )


def bias_quaternion(bias_arcsec: tuple[float, float, float]) -> np.ndarray:
    """Unit quaternion of the rotation vector ``bias_arcsec`` (body axes) [arcsec]."""
    v = np.asarray(bias_arcsec, dtype=float) * ARCSEC
    angle = float(norm3(v))
    if angle == 0.0:
        return np.array([1.0, 0.0, 0.0, 0.0])
    return np.concatenate([[math.cos(0.5 * angle)], math.sin(0.5 * angle) * v / angle])
