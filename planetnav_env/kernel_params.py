"""The core's parameter record of an environment configuration: :func:`build_params`.

The one place where the configuration meets the core. The core (:mod:`planetnav_env.core`) imports
nothing of the configuration: this module reads a validated :class:`~planetnav_env.config.EnvConfig` and
hands the core plain records. :data:`SCALAR_FIELDS` are the scalars' fields, first those that copy an
option (generated from the declarations, ``option(..., kernel=<name>)``, by
:func:`~planetnav_env.options.kernel_fields`), then the core's own
(:data:`~planetnav_env.core.records.CORE_SCALAR_FIELDS`); :func:`build_params` fills them and the
parameter arrays into a :class:`~planetnav_env.core.records.CoreParams` (shared by every row).
"""

from __future__ import annotations

import math

import numpy as np

from planetnav_env.astro.bodies import body
from planetnav_env.config import EnvConfig
from planetnav_env.core import layout as L
from planetnav_env.core.ephemeris_table import SEGMENT_S
from planetnav_env.core.params import (
    ARCSEC,
    SETTLE_ANGLE_RAD,
    SETTLE_RATE_RAD_S,
    ChannelPlan,
    bias_quaternion,
)
from planetnav_env.core.records import CORE_SCALAR_FIELDS, CoreParams, make_scalars, scalars_dtype
from planetnav_env.estimation.ekf import process_noise
from planetnav_env.estimation.ekf_kernels import KIND_CODES
from planetnav_env.options import kernel_fields, kernel_values
from planetnav_env.sensors import pulsar as psr
from planetnav_env.sensors.photometry import GEOMETRIC_ALBEDO
from planetnav_env.sensors.star_tracker import StarTrackerConfig, star_fix_tables

#: The flight world's attitude loop settles at an offset (the PD law against friction's residual and the
#: disturbance torques: ~50" with the shipped gains): its coarse sub-steps start once the pointing error is
#: below this many times SETTLE_ANGLE_RAD (the rates below SETTLE_RATE_RAD_S, as in the matched world).
FLIGHT_SETTLE_FACTOR = 10.0

#: Every scalar of ``CoreParams.scalars``: (name, numpy type, meaning [unit]), the option-copied ones first.
SCALAR_FIELDS: tuple[tuple[str, str, str], ...] = (*kernel_fields(EnvConfig), *CORE_SCALAR_FIELDS)
#: The record of :data:`SCALAR_FIELDS`.
SCALARS_DTYPE = scalars_dtype(SCALAR_FIELDS)


def episode_duration_s(cfg: EnvConfig) -> float:
    """Span a row's table covers: the episode plus one step (the last RK4 stage reaches t_K + dt)."""
    return (cfg.episode_steps + 1) * cfg.step_s


def build_params(
    cfg: EnvConfig,
    plan: ChannelPlan,
    mu_central: float,
    mus: np.ndarray,
    truth_mus: np.ndarray | None = None,
) -> CoreParams:
    """The record of everything the kernels read, from a validated config and its channel plan
    (``truth_mus``: the GMs of ``plan.truth_perturbers`` [km^3/s^2], with the truth's own force model)."""
    att = cfg.attitude
    world = cfg.world
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
    world = cfg.world
    scalars = make_scalars(
        SCALARS_DTYPE,
        **kernel_values(cfg),  # the scalars that copy an option (declared with kernel=)
        n_sub=cfg.n_substeps,
        n_coarse=round(cfg.step_s / coarse_s) if coarse_s > 0 else 0,
        segment_s=SEGMENT_S,
        rate_noise=math.radians(att.rate_noise_deg_s),
        settle_angle=SETTLE_ANGLE_RAD * (FLIGHT_SETTLE_FACTOR if cfg.world.attitude_world_on else 1.0),
        settle_rate=SETTLE_RATE_RAD_S,
        mode=L.MODE_CODES[cfg.action_mode],
        relative=cfg.target_actions == "relative",
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
        cob_max=cfg.world.centroid_bias_bound,
        psr_df_max=cfg.world.pulsar_frequency_error_bound,
        img_on=world.image_errors_on,
        img_floor=world.centroid_floor_px,
        img_limb=world.limb_scatter,
        img_collect=math.pi * (0.5e-3 * world.aperture_mm) ** 2 * world.exposure_s,
        img_fw=world.full_well_e,
        img_rn=world.read_noise_e,
        img_psf=world.psf_sigma_px,
        cob_lam=world.lambert_cob_on,
        cob_fix=world.lambert_cob_corrected,
        oblate=world.oblate_on,
        drift_on=world.drift_on,
        drift_sigma=world.drift_sigma_arcsec * ARCSEC,
        drift_tau=world.drift_tau_s,
        att_on=world.attitude_world_on,
        est_on=world.attitude_world_on and world.estimate_pointing_on,
        srp_tq=world.srp_torque_on,
        srp_area=world.srp_torque_area_m2,
        gg_on=world.gravity_gradient_on,
        thr_tq=ops is not None and any(v != 0.0 for v in world.thrust_offset),
        thrust_n=ops.thrust_n if ops is not None else 0.0,
        fric_c=world.wheel_coulomb,
        fric_v=world.wheel_viscous,
        fric_comp=world.wheel_friction_compensation,
        jw=world.wheel_inertia_kg_m2,
        h_speed=world.wheel_inertia_kg_m2 * world.wheel_speed_limit_rad_s,
        h_sat=0.99 * att.wheel_momentum_capacity,
        dump_on=world.dumping_on,
        dump_thr=world.dump_threshold_n_m_s,
        dump_arm=world.dump_lever_arm_m,
        mass=world.dump_mass(ops.mass_kg if ops is not None else None),
        dump_sig_m=world.dump_dv_error,
        dump_sig_p=math.radians(world.dump_pointing_error_deg),
        dump_dur=world.dump_duration_s,
        g_rrw=world.gyro_rrw,
        g_arw=world.gyro_arw,
        g_bias=world.gyro_bias_rad_s,
        det_half_fov=math.radians(0.5 * cfg.detector_fov_deg),
        sun_avoid=math.radians(cfg.detector.sun_avoidance_deg),
        reward_truth=cfg.reward == "truth",
        reward_base_n=len(cfg.reward_baseline_km),
        obs_unit=cfg.observation_scaling == "unit",
        n_planets=cfg.n_planets,
        n_pulsars=cfg.n_pulsars,
        n_targets=cfg.n_targets,
        ch_central=plan.central,
        ch_planet0=plan.planet0,
        ch_pert0=plan.pert0,
        n_pert=len(plan.perturbers),
        truth_own=cfg.world.truth_forces_on,
        ch_tpert0=plan.truth0,
        n_tpert=len(plan.truth_perturbers),
        srp_on=cfg.world.srp_on,
        srp_sun=plan.truth_perturbers.index("sun") if "sun" in plan.truth_perturbers else -1,
        truth_eph=plan.truth_apart,
        ch_tcentral=plan.tcentral,
        ch_tplanet0=plan.tplanet0,
        ch_tssb=plan.tssb,
        world_shapiro=cfg.world.shapiro_on,
        onboard_shapiro=cfg.world.shapiro_corrected,
        thr_gm=cfg.world.thrust_gauss_markov_on and ops is not None,
        ops_sig_mag=ops.thrust_mag_sigma if ops is not None else 0.0,
        ops_sig_point=math.radians(ops.thrust_point_sigma_deg) if ops is not None else 0.0,
        ops_tau=ops.thrust_corr_time_s if ops is not None else 1.0,
        q_tuned=cfg.world.process_noise_tuned,
        ch_ssb=plan.ssb,
        approach=approach,
        noise_per_step=cfg.noise_streams == "per_step",
        pos_scale=pos_scale,
        vel_scale=vel_scale,
        obs_planets=layout.planets_start,
        obs_pulsars=layout.pulsars_start,
        obs_target=layout.target_start,
        obs_elapsed=layout.elapsed_index,
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
        figure=np.array(
            [[body(p).polar_radius, *body(p).pole, GEOMETRIC_ALBEDO[p]] for p in cfg.planets], dtype=float
        ).reshape(-1, 5),
        mus=np.ascontiguousarray(mus, dtype=float),
        tmus=np.ascontiguousarray(truth_mus if truth_mus is not None else np.zeros(0), dtype=float),
        psr=np.ascontiguousarray(psr_rows),
        c2b=np.ascontiguousarray(cam._c2b),
        cam=np.ascontiguousarray(cam._params),
        qproc=process_noise(cfg.step_s, cfg.filter.accel_psd),
        qunit=process_noise(cfg.step_s, 1.0),
        stars=tables,
        q_bias=bias_quaternion(cfg.star_tracker_bias_arcsec),
        obs_blocks=layout.block_starts(),
        arms=np.array([world.cp_offset, world.thrust_offset], dtype=float),
        reward_base=np.array(cfg.reward_baseline_km or (0.0,), dtype=float),
        obs_affine=(
            np.ascontiguousarray(L.unit_scaling(layout, cfg.scenario), dtype=float)
            if cfg.observation_scaling == "unit"
            else np.zeros((2, 0))
        ),
    )
