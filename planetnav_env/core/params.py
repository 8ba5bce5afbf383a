"""The core's parameter record, built once from an :class:`~planetnav_env.config.EnvConfig`.

:func:`build_params` turns the validated configuration into a :class:`CoreParams` (arrays only, shared
by every row); :class:`ChannelPlan` says which ephemeris channel of a row's table holds which body.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from planetnav_env.bodies import body
from planetnav_env.config import EnvConfig
from planetnav_env.core import layout as L
from planetnav_env.core.ephemeris_table import SEGMENT_S
from planetnav_env.core.records import CoreParams
from planetnav_env.estimation.ekf import process_noise
from planetnav_env.estimation.ekf_kernels import KIND_CODES
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
    s = np.zeros(L.NS)
    n = np.zeros(L.NN, dtype=np.int64)
    s[L.S_STEP_S] = cfg.step_s
    s[L.S_SUBSTEP_S] = cfg.attitude_substep_s
    coarse_s = cfg.settled_substep_s
    s[L.S_COARSE_S] = coarse_s
    s[L.S_K_A] = att.k_a
    s[L.S_K_W] = att.k_w
    s[L.S_MU] = mu_central
    s[L.S_SIG_DIR] = math.hypot(cam.sigma_direction_rad, cfg.star_tracker_sigma_arcsec * ARCSEC)
    s[L.S_SIG_SIZE] = cam.sigma_alpha_rad
    for m in (1, 2, 3):
        s[L.S_GATE1 + m - 1] = cfg.filter.gate_threshold(m)
    s[L.S_RATE_NOISE] = math.radians(att.rate_noise_deg_s)
    s[L.S_COS_HALF_DIAG] = math.cos(cam.half_fov_diagonal_rad)
    s[L.S_ALPHA_MAX] = 2.0 * min(cam.half_fov_rad)
    s[L.S_SIGMA_ALPHA] = cam.sigma_alpha_rad
    s[L.S_PSR_INT_S] = cfg.detector.integration_time_s
    s[L.S_DET_HALF_FOV] = math.radians(0.5 * cfg.detector_fov_deg)
    s[L.S_SUN_AVOID] = math.radians(cfg.detector.sun_avoidance_deg)
    s[L.S_AMBIG_K] = cfg.ambiguity_k_sigma
    s[L.S_CENTRAL_RADIUS] = body(plan.central_body).radius
    s[L.S_REWARD_SCALE] = cfg.reward_scale_km
    s[L.S_TORQUE_PENALTY] = cfg.torque_penalty
    s[L.S_TORQUE_SCALE] = cfg.torque_action_scale
    s[L.S_DIVERGENCE] = cfg.divergence_km
    s[L.S_POS_SCALE], s[L.S_VEL_SCALE] = L.observation_scales(cfg.scenario)
    s[L.S_SEGMENT_S] = SEGMENT_S
    s[L.S_SETTLE_ANGLE] = SETTLE_ANGLE_RAD
    s[L.S_SETTLE_RATE] = SETTLE_RATE_RAD_S
    n[L.N_MODE] = L.MODE_CODES[cfg.action_mode]
    n[L.N_NP] = cfg.n_planets
    n[L.N_NQ] = cfg.n_pulsars
    n[L.N_NT] = cfg.n_targets
    n[L.N_N_SUB] = cfg.n_substeps
    n[L.N_N_COARSE] = round(cfg.step_s / coarse_s) if coarse_s > 0 else 0
    n[L.N_KIND] = KIND_CODES[cfg.measurement_model]
    n[L.N_EULER] = cfg.filter.stm == "euler"
    n[L.N_IDEAL_STAR] = cfg.star_tracker == "ideal"
    n[L.N_REWARD_TRUTH] = cfg.reward == "truth"
    n[L.N_EPISODE_STEPS] = cfg.episode_steps
    n[L.N_CH_CENTRAL] = plan.central
    n[L.N_CH_PLANET0] = plan.planet0
    n[L.N_CH_PERT0] = plan.pert0
    n[L.N_N_PERT] = len(plan.perturbers)
    n[L.N_CH_SSB] = plan.ssb
    n[L.N_APPROACH] = approach
    n[L.N_OBS_PLANETS] = layout.planets_start
    n[L.N_OBS_PULSARS] = layout.pulsars_start
    n[L.N_OBS_TARGET] = layout.target_start
    n[L.N_OBS_ELAPSED] = layout.elapsed_index
    n[L.N_NOISE_PER_STEP] = cfg.noise_streams == "per_step"
    n[L.N_OBS_IN_FIELD] = layout.in_field_start if layout.in_field else -1
    ops = cfg.operations
    if ops is not None:
        n[L.N_OPS] = 1
        n[L.N_OPS_N_DL] = len(ops.deadlines_s)
        n[L.N_OBS_OPS] = layout.operations_start
        s[L.S_OPS_ACC] = ops.thrust_accel_km_s2
        s[L.S_OPS_Q_PAR], s[L.S_OPS_Q_PERP] = ops.psd_km2_s3
        s[L.S_OPS_COS_TOL] = math.cos(math.radians(ops.attitude_tolerance_deg))
        s[L.S_OPS_ENCOUNTER] = ops.encounter_s
        s[L.S_OPS_WEIGHT] = ops.cost_weight
        for k, t in enumerate(ops.deadlines_s):
            s[L.S_OPS_DL0 + k] = t
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
        s=s,
        n=n,
        jm=jm,
        jinv=np.linalg.inv(jm),
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
    angle = float(np.linalg.norm(v))
    if angle == 0.0:
        return np.array([1.0, 0.0, 0.0, 0.0])
    return np.concatenate([[math.cos(0.5 * angle)], math.sin(0.5 * angle) * v / angle])
