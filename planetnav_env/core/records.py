"""The records a row kernel receives: :class:`CoreParams` (shared, read-only parameters, its scalars in the
named record of :func:`scalars_dtype`), :class:`RowState` (the state arrays of the batch, each row's slices
read and written only by its own row), :class:`Actions` (the decoded actions of a step) and
:class:`Scratch` (work arrays of one chunk of rows, allocated once per call by :func:`make_scratch`; on a
device, where every row is a thread, one row of scratch per state row: :func:`scratch_rows` allocates the
(N, ...) arrays once and :func:`scratch_row` takes row ``n``'s slices).

Named tuples of arrays: numba passes one as its arrays, so a field read compiles to the same code as a
separate argument; the kernels take a few records instead of long positional lists."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from planetnav_env.core import rng as crng
from planetnav_env.core.layout import TARGET_FEATURES
from planetnav_env.numerics.jit import ROW_KERNEL_OPTIONS
from planetnav_env.sensors.camera_kernels import (
    N_VIS_SLOTS,
)
from planetnav_env.sensors.star_tracker import FIX_WORK_SHAPE

#: The scalar parameters the core computes, one definition each: (name, numpy type, meaning [unit]).
#: Kernels read every scalar by name from the one-element structured array ``CoreParams.scalars``:
#: ``c = prm.scalars[0]``, ``c.mu`` (numba compiles a field read to one load at a fixed offset, as fast as
#: numbered slots, and the dispatcher types the array as cheaply as any other). Flags are int64 0/1. The
#: record (:func:`scalars_dtype`) puts first the scalars that copy an option, whose fields the configuration
#: layer generates from the declarations and hands in (:data:`planetnav_env.kernel_params.SCALAR_FIELDS`);
#: these follow, computed from options in :func:`planetnav_env.kernel_params.build_params`, each listed
#: with the options it comes from.
CORE_SCALAR_FIELDS: tuple[tuple[str, str, str], ...] = (
    # time steps
    ("n_sub", "i8", "attitude sub-steps per step (step_s / attitude_substep_s)"),
    ("n_coarse", "i8", "coarse sub-steps per step (step_s / settled_substep_s; 0: no coarse stepping)"),
    ("segment_s", "f8", "span of one ephemeris-table segment [s]"),
    # attitude
    ("rate_noise", "f8", "gyro rate noise [rad/s] (attitude.rate_noise_deg_s)"),
    ("settle_angle", "f8", "pointing error below which a held target counts as settled [rad]"),
    ("settle_rate", "f8", "body rate below which a held target counts as settled [rad/s]"),
    ("mode", "i8", "action mode (layout.MODE_CODES of action_mode)"),
    ("relative", "i8", "1: relative target actions (target_actions 'relative'; core.decoding)"),
    # orbit and filter
    ("mu", "f8", "central body's GM [km^3/s^2] (scenario)"),
    ("central_radius", "f8", "central body's radius [km] (scenario)"),
    ("euler", "i8", "1: the filter's STM by one Euler step (filter.stm), 0: RK4"),
    ("kind", "i8", "measurement model (estimation.ekf_kernels.KIND_CODES of measurement_model)"),
    # camera
    ("sig_dir", "f8", "direction sigma of a planet fix [rad] (camera.direction_noise_arcsec and "
     "star_tracker_sigma_arcsec combined)"),
    ("sig_size", "f8", "apparent-size sigma of a planet fix [rad] (camera.diameter_noise_px / f_px)"),
    ("cos_half_diag", "f8", "cosine of the camera's half diagonal field of view (camera sensor, focus)"),
    ("alpha_max", "f8", "largest apparent diameter the camera measures [rad] (camera field of view)"),
    ("sigma_alpha", "f8", "apparent-diameter sigma, the observation's size scale [rad] (as sig_size)"),
    ("ideal_star", "i8", "1: the star tracker returns the true attitude (star_tracker 'ideal')"),
    # the truth's world (EnvConfig.world, resolved from its preset)
    ("world_lt", "i8", "1: light time in the truth's planet directions (world.light_time_on)"),
    ("world_ab", "i8", "1: aberration in the truth's planet and star directions (world.aberration_on)"),
    ("onboard_lt", "i8", "1: the filter models the light-time position (world.light_time_corrected)"),
    ("onboard_ab", "i8", "1: the filter aberrates its prediction and stars (world.aberration_corrected)"),
    ("cob_max", "f8", "largest centre-of-brightness scale a planet draws [fraction of the uniformly bright "
     "disk's offset] (world.centroid_bias_bound; 0: none)"),
    ("psr_df_max", "f8", "largest pulsar timing-model frequency error [delta nu / nu] "
     "(world.pulsar_frequency_error_bound; 0: none)"),
    ("img_on", "i8", "1: the camera's truth errors come from the image (world.image_errors_on)"),
    ("img_floor", "f8", "the image errors' centroid floor [px] (world.centroid_floor_px)"),
    ("img_limb", "f8", "the image errors' limb term [fraction of the diameter] (world.limb_scatter)"),
    ("img_collect", "f8", "aperture area times exposure [m^2 s] (world.aperture_mm, world.exposure_s)"),
    ("img_fw", "f8", "a pixel's full well [e-] (world.full_well_e)"),
    ("img_rn", "f8", "read noise per pixel [e-] (world.read_noise_e)"),
    ("img_psf", "f8", "the PSF's Gaussian sigma [px] (world.psf_sigma_px)"),
    ("cob_lam", "i8", "1: the Lambertian centre-of-brightness offset in truth (world.lambert_cob_on)"),
    ("cob_fix", "i8", "1: the filter subtracts its photometric model's offset (world.lambert_cob_corrected)"),
    ("oblate", "i8", "1: planets are spheroids in truth (world.oblate_on)"),
    ("drift_on", "i8", "1: the planet camera's boresight drifts in truth (world.drift_on)"),
    ("drift_sigma", "f8", "the drift's stationary sigma per axis [rad] (world.drift_sigma_arcsec)"),
    ("drift_tau", "f8", "the drift's correlation time [s] (world.drift_tau_s)"),
    # the flight world's attitude loop (world.attitude_world_on; all 0 otherwise)
    ("att_on", "i8", "1: the flight world's attitude sub-steps (world.attitude_world_on)"),
    ("est_on", "i8", "1: the PD law reads the attitude estimator (world.estimate_pointing_on)"),
    ("srp_tq", "i8", "1: SRP torque from the centre-of-pressure offset CoreParams.arms[0]"),
    ("srp_area", "f8", "the SRP torque's sunlit cross-section [m^2] (world.srp_torque_area_m2)"),
    ("gg_on", "i8", "1: the central body's gravity-gradient torque (world.gravity_gradient_on)"),
    ("thr_tq", "i8", "1: the thrust's torque from its offset CoreParams.arms[1] (thrust arc)"),
    ("thrust_n", "f8", "engine thrust [N] (operations.thrust_n; 0 without)"),
    ("fric_c", "f8", "wheel Coulomb friction [N m] (world.wheel_coulomb)"),
    ("fric_v", "f8", "wheel viscous friction [N m s] (world.wheel_viscous)"),
    ("fric_comp", "f8", "share of the friction the wheel drive cancels (world.wheel_friction_compensation)"),
    ("jw", "f8", "wheel axial inertia [kg m^2] (world.wheel_inertia_kg_m2)"),
    ("h_speed", "f8", "wheel momentum at the no-load speed [N m s] (inf: no speed limit)"),
    ("h_sat", "f8", "wheel momentum counted as saturated [N m s] (0.99 of the capacity)"),
    ("dump_on", "i8", "1: momentum dumping (world.dumping_on)"),
    ("dump_thr", "f8", "dump threshold [N m s] (world.dump_threshold_n_m_s)"),
    ("dump_arm", "f8", "dump thrusters' lever arm [m] (world.dump_lever_arm_m)"),
    ("mass", "f8", "spacecraft mass for a dump's delta-v [kg] (world.dump_mass)"),
    ("dump_sig_m", "f8", "1-sigma of a dump's delta-v magnitude error [fraction] (world.dump_dv_error)"),
    ("dump_sig_p", "f8", "1-sigma of a dump's delta-v direction error per cross axis [rad]"),
    ("dump_dur", "f8", "thrust arc: engine-off time per dump [s] (world.dump_duration_s)"),
    ("g_rrw", "f8", "gyro rate random walk [rad/s/sqrt(s)] (world.gyro_rrw)"),
    ("g_arw", "f8", "gyro angle random walk [rad/sqrt(s)] (world.gyro_arw)"),
    ("g_bias", "f8", "1-sigma of the gyro bias per axis [rad/s] (world.gyro_bias_rad_s)"),
    # pulsars
    ("det_half_fov", "f8", "detector half field of view [rad] (detector_fov_deg / 2)"),
    ("sun_avoid", "f8", "detector Sun-avoidance angle [rad] (detector.sun_avoidance_deg)"),
    # reward and termination
    ("reward_truth", "i8", "1: reward from the true error, 0: from the filter's sigma (reward)"),
    ("reward_base_n", "i8", "entries L of CoreParams.reward_base (reward_baseline_km; 0: no baseline)"),
    ("obs_unit", "i8", "1: the observation's columns scaled by CoreParams.obs_affine (observation_scaling "
     "'unit')"),
    # counts and ephemeris channels
    ("n_planets", "i8", "planets P"),
    ("n_pulsars", "i8", "pulsars Q"),
    ("n_targets", "i8", "targets of the observation's target block"),
    ("ch_central", "i8", "ephemeris channel of the central body (-1: the Sun)"),
    ("ch_planet0", "i8", "ephemeris channel of the first planet"),
    ("ch_pert0", "i8", "ephemeris channel of the first perturber"),
    ("n_pert", "i8", "perturbers"),
    ("truth_own", "i8", "1: the truth has its own force model (world.truth_forces_on), 0: the filter's"),
    ("ch_tpert0", "i8", "ephemeris channel of the truth's first perturber (its own force model)"),
    ("n_tpert", "i8", "the truth's perturbers (its own force model)"),
    ("srp_on", "i8", "1: cannonball SRP in truth of the row's coefficient SRP_K (world.srp_on)"),
    ("srp_sun", "i8", "the Sun's index among the truth's perturbers (-1: the Sun is the central body)"),
    ("truth_eph", "i8", "1: the truth follows its own ephemeris (world.truth_ephemeris_apart), in the "
     "channels ch_tcentral, ch_tplanet0, ch_tssb"),
    ("ch_tcentral", "i8", "ephemeris channel of the truth's central body (-1: the Sun; ch_central unless "
     "truth_eph)"),
    ("ch_tplanet0", "i8", "ephemeris channel of the truth's first planet (ch_planet0 unless truth_eph)"),
    ("ch_tssb", "i8", "ephemeris channel of the truth's barycentre offset (ch_ssb unless truth_eph)"),
    ("world_shapiro", "i8", "1: the Sun's Shapiro delay in the truth's pulsar phases (world.shapiro_on)"),
    ("onboard_shapiro", "i8", "1: the filter models the Shapiro delay (world.shapiro_corrected)"),
    ("thr_gm", "i8", "1: the thrust execution error in truth is Gauss-Markov (world.thrust_gauss_markov_on)"),
    ("ops_sig_mag", "f8", "1-sigma fractional thrust magnitude error (operations.thrust_mag_sigma)"),
    ("ops_sig_point", "f8", "1-sigma thrust pointing error per cross axis [rad] "
     "(operations.thrust_point_sigma_deg)"),
    ("ops_tau", "f8", "correlation time of the thrust execution error [s] (operations.thrust_corr_time_s)"),
    ("q_tuned", "i8", "1: the filter's process noise is the row's Q_PSD (world.process_noise_tuned)"),
    ("ch_ssb", "i8", "ephemeris channel of the Solar-system barycentre (-1: none)"),
    ("approach", "i8", "1: a planetary approach (central body not the Sun; scenario)"),
    ("noise_per_step", "i8", "1: noise from a per-step stream (noise_streams 'per_step')"),
    # observation
    ("pos_scale", "f8", "observation's position scale [km] (scenario)"),
    ("vel_scale", "f8", "observation's velocity scale [km/s] (scenario)"),
    ("obs_planets", "i8", "first index of the observation's planet block"),
    ("obs_pulsars", "i8", "first index of the observation's pulsar block"),
    ("obs_target", "i8", "first index of the observation's target block"),
    ("obs_elapsed", "i8", "index of the observation's elapsed fraction"),
    ("obs_ops", "i8", "first index of the observation's operations block"),
    # operations (EnvConfig.operations; zero without)
    ("ops", "i8", "1: an operations scenario"),
    ("ops_n_dl", "i8", "deadlines (the first ops_n_dl entries of CoreParams.ops_deadlines)"),
    ("ops_acc", "f8", "thrust acceleration [km/s^2] (operations.thrust_n / operations.mass_kg)"),
    ("ops_q_par", "f8", "thrust acceleration PSD along the thrust [km^2/s^3] (operations.psd_km2_s3)"),
    ("ops_q_perp", "f8", "thrust acceleration PSD across the thrust [km^2/s^3] (operations.psd_km2_s3)"),
    ("ops_cos_tol", "f8", "cosine of the thrust attitude tolerance (operations.attitude_tolerance_deg)"),
)  # fmt: skip


def scalars_dtype(fields: tuple[tuple[str, str, str], ...]) -> np.dtype:
    """The scalars' record of ``fields`` ((name, numpy type, meaning), in order; aligned: every field at a
    multiple of 8 bytes); a name given twice is an error."""
    names = [name for name, _, _ in fields]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise TypeError(f"scalars_dtype: fields given twice {twice}")
    return np.dtype([(name, kind) for name, kind, _ in fields], align=True)


def make_scalars(dtype: np.dtype, **values: float) -> np.ndarray:
    """The one-element ``dtype`` array (:func:`scalars_dtype`) of ``values``, given by keyword: every field
    exactly once (a missing or unknown name is an error, so no field is left at a silent zero)."""
    names = dtype.names
    missing = [k for k in names if k not in values]
    unknown = sorted(set(values) - set(names))
    if missing or unknown:
        raise TypeError(f"make_scalars: missing fields {missing}, unknown fields {unknown}")
    rec = np.zeros(1, dtype)
    for k in names:
        rec[k][0] = values[k]
    return rec


class CoreParams(NamedTuple):
    """Everything a row kernel needs that is the same for every row, built once from an ``EnvConfig``
    by :func:`planetnav_env.kernel_params.build_params`. Scalars sit in ``scalars``, read by name
    (:data:`CORE_SCALAR_FIELDS` and the option-copied fields before them)."""

    scalars: np.ndarray  # (1,) planetnav_env.kernel_params.SCALARS_DTYPE
    gate: np.ndarray  # (3,) chi-square gate thresholds of a 1-, 2- and 3-dimensional measurement
    ops_deadlines: np.ndarray  # (layout.MAX_DEADLINES,) deadline epochs [s from episode start] (operations)
    jm: np.ndarray  # (3, 3) inertia [kg m^2]
    jinv: np.ndarray  # (3, 3)
    tau_max: np.ndarray  # (3,) wheel torque limits [N m]
    h_max: np.ndarray  # (3,) wheel momentum capacities [N m s]
    boresight: np.ndarray  # (3,) camera boresight, body axes
    radii: np.ndarray  # (P,) planet radii [km]
    figure: np.ndarray  # (P, 5) polar radius [km], unit north pole (3, ICRF), geometric albedo
    mus: np.ndarray  # (K,) perturbers' GM [km^3/s^2]
    tmus: np.ndarray  # (Kt,) the truth's perturbers' GM [km^3/s^2] (its own force model; else empty)
    psr: np.ndarray  # (Q, 5) pulsar direction (3), wavelength [km], phase sigma [cycles]
    c2b: np.ndarray  # (3, 3) camera -> body
    cam: np.ndarray  # (11,) camera parameters (CameraConfig._params)
    qproc: np.ndarray  # (6, 6) process noise over one step
    qunit: np.ndarray  # (6, 6) process noise over one step of a unit PSD (1 km^2/s^3): a row's tuned Q / q
    stars: tuple  # star_tracker.StarFixTables
    q_bias: np.ndarray  # (4,) fixed star-tracker misalignment composed with every fix (identity: none)
    obs_blocks: np.ndarray  # (len(OBSERVATION_BLOCKS),) int64 first index of each optional block (-1: off)
    arms: np.ndarray  # (2, 3) [m, body]: the SRP centre-of-pressure offset, the thrust line's offset
    reward_base: (
        np.ndarray
    )  # (max(L, 1),) the reward's time-only baseline per bin of steps [km] (L = 0: none)
    obs_affine: np.ndarray  # (2, D) offset and scale of each observation column ('unit'; else (2, 0))


class RowState(NamedTuple):
    """The state arrays of ``N`` rows (leading axis; columns in :mod:`planetnav_env.core.layout`), built by
    keyword by :attr:`planetnav_env.batch.BatchCore.state`."""

    f: np.ndarray  # (N, NF) float state
    p: np.ndarray  # (N, 6, 6) filter covariance
    i: np.ndarray  # (N, NI) int64 state
    rng: np.ndarray  # (N, STATE_WORDS) uint64 random streams
    eph: np.ndarray  # (N, ...) per-row ephemeris tables
    obs: np.ndarray  # (N, obs_dim) observations


class Actions(NamedTuple):
    """The actions of one decision of ``N`` rows: the raw actions the environment validated, and their
    decoding (:func:`planetnav_env.core.decoding.decode_row`, written at the start of the decision)."""

    raw: np.ndarray  # (N, A) float64 the rows' actions as given (A: the action's size, 1 in target mode)
    targets: np.ndarray  # (N,) int64 decoded planet/pulsar index (-1: none)
    torques: np.ndarray  # (N, 3) float64 decoded fractions of the wheel torque limit
    active: np.ndarray  # (N,) bool: the rows to step


class Scratch(NamedTuple):
    """Work arrays of one chunk of rows (allocated once per call, reused by every row)."""

    work: np.ndarray  # (8, 7) attitude RK4
    rq: np.ndarray  # (3, 3)
    a: np.ndarray  # (3, 3)
    frame: np.ndarray  # (3, 3)
    y: np.ndarray  # (7,)
    u_cmd: np.ndarray  # (3,)
    bias: np.ndarray  # (3,)
    w6: np.ndarray  # (3, 6, 6) orbit RK4
    v6: np.ndarray  # (4, 6)
    phi: np.ndarray  # (6, 6)
    tmp: np.ndarray  # (6, 6)
    x_new: np.ndarray  # (6,)
    uw: np.ndarray  # (5, 6, 6) EKF update
    h: np.ndarray  # (3,)
    jac: np.ndarray  # (3, 6)
    rcov: np.ndarray  # (3, 3)
    z: np.ndarray  # (3,)
    basis: np.ndarray  # (2, 3)
    m: np.ndarray  # (3, 3) camera
    u6: np.ndarray  # (6,)
    vals: np.ndarray  # (N_VIS_SLOTS,)
    los: np.ndarray  # (3,)
    los_true: np.ndarray  # (3,)
    mm: np.ndarray  # (2,)
    pix: np.ndarray  # (2,)
    r1: np.ndarray  # (1, 3) one-element batches for the camera kernels
    q1: np.ndarray  # (1, 4)
    t1: np.ndarray  # (1, 3)
    central: np.ndarray  # (3,) central body, heliocentric
    ssb: np.ndarray  # (3,) central body relative to the barycentre
    dirv: np.ndarray  # (3,)
    roll: np.ndarray  # (3,)
    pert: np.ndarray  # (3, K, 3) perturbers at t, t + dt/2, t + dt
    tpert: np.ndarray  # (3, Kt, 3) the truth's perturbers at t, t + dt/2, t + dt (its own force model)
    qrow: np.ndarray  # (6, 6) the row's tuned process noise over one step (world.process_noise_tuned)
    planets: np.ndarray  # (P, 3)
    tcentral: np.ndarray  # (3,) the truth's central body, heliocentric (its own ephemeris: ch_tcentral)
    tplanets: np.ndarray  # (P, 3) the truth's planets (its own ephemeris: ch_tplanet0)
    r_tile: np.ndarray  # (P, 3)
    q_tile: np.ndarray  # (P, 4)
    feat: np.ndarray  # (P, TARGET_FEATURES)
    noise3: np.ndarray  # (3,)
    star_idx: np.ndarray  # (max_stars,) int64 catalogue indices in view
    star_noise: np.ndarray  # (max_stars, 3) per-star direction noise [rad]
    star_work: np.ndarray  # FIX_WORK_SHAPE
    q_fix: np.ndarray  # (4,)
    sub: np.ndarray  # (4,) uint64: a per-step noise stream (noise_streams "per_step")
    light: np.ndarray  # (5, 3) light path (core.light_path.LIGHT_ROWS): velocities, direction, estimate
    att_v: np.ndarray  # (5, 3) attitude loop: external torque, its part, estimated rate, work, total momentum
    att_q: np.ndarray  # (4, 4) attitude loop: the attitude at the step's and the sub-step's start, work
    att_m: np.ndarray  # (4, 6, 6) attitude filter: transition, work, gain (6 x 3 in the first columns)
    dump: np.ndarray  # (4, 3) the step's dump delta-v in truth and on board, and their position moments
    dump_p: np.ndarray  # (6, 6) the covariance of the step's dump delta-v errors


@njit(cache=True)
def make_scratch(prm: CoreParams) -> Scratch:  # pragma: no cover - compiled
    n_p = prm.radii.shape[0]
    n_k = prm.mus.shape[0]
    n_kt = prm.tmus.shape[0]
    n_s = prm.stars.max_stars
    # By keyword (a field is found by its name, not by its place among 44), a line per stage that uses them.
    return Scratch(
        work=np.empty((8, 7)), rq=np.empty((3, 3)), a=np.empty((3, 3)), frame=np.empty((3, 3)), y=np.empty(7),
        u_cmd=np.empty(3), bias=np.empty(3), dirv=np.empty(3), roll=np.empty(3),
        w6=np.empty((3, 6, 6)), v6=np.empty((4, 6)), phi=np.empty((6, 6)), tmp=np.empty((6, 6)),
        x_new=np.empty(6),
        uw=np.empty((5, 6, 6)), h=np.empty(3), jac=np.empty((3, 6)), rcov=np.empty((3, 3)), z=np.empty(3),
        basis=np.zeros((2, 3)),
        m=np.empty((3, 3)), u6=np.empty(6), vals=np.empty(N_VIS_SLOTS), los=np.empty(3), los_true=np.empty(3),
        mm=np.empty(2), pix=np.empty(2), r1=np.empty((1, 3)), q1=np.empty((1, 4)), t1=np.empty((1, 3)),
        central=np.empty(3), ssb=np.empty(3), pert=np.empty((3, n_k, 3)), planets=np.empty((n_p, 3)),
        tcentral=np.empty(3), tplanets=np.empty((n_p, 3)),
        tpert=np.empty((3, n_kt, 3)), qrow=np.empty((6, 6)),
        r_tile=np.empty((n_p, 3)), q_tile=np.empty((n_p, 4)), feat=np.empty((n_p, TARGET_FEATURES)),
        noise3=np.empty(3), sub=np.empty(crng.STATE_WORDS, np.uint64),
        star_idx=np.empty(n_s, np.int64), star_noise=np.empty((n_s, 3)), star_work=np.empty(FIX_WORK_SHAPE),
        q_fix=np.empty(4), light=np.empty((5, 3)),
        att_v=np.empty((5, 3)), att_q=np.empty((4, 4)), att_m=np.empty((4, 6, 6)), dump=np.empty((4, 3)),
        dump_p=np.empty((6, 6)),
    )  # fmt: skip


def rows_innermost(shape: tuple[int, ...], dtype: Any) -> np.ndarray:
    """Zeros of ``shape`` (rows first, indexed ``a[n, ...]`` as the row kernels index the state) with the
    rows innermost in memory: the stride of the row axis is one element, each column's rows are
    contiguous (a structure of arrays, by strides). The device's layout: when thread ``n`` of a warp reads
    ``a[n, c]``, its 32 threads read 32 adjacent elements (coalesced: 8 sectors of 32 bytes for float64),
    where rows outermost would touch a sector per thread. The arithmetic is unchanged (the same elements,
    addressed by strides), so the numbers are bit for bit those of the rows-outermost layout."""
    return np.moveaxis(np.zeros((*shape[1:], shape[0]), dtype), -1, 0)


def rows_innermost_like(record: Any) -> Any:
    """``record`` (a named tuple of arrays with rows first, or one array) copied into
    :func:`rows_innermost` arrays (0- and 1-dimensional arrays are already so)."""

    def copy(a: np.ndarray) -> np.ndarray:
        out = rows_innermost(a.shape, a.dtype) if a.ndim > 1 else np.zeros(a.shape, a.dtype)
        out[...] = a
        return out

    return map_arrays(copy, record)


def scratch_rows(prm: CoreParams, rows: int) -> Scratch:
    """A :class:`Scratch` of ``rows`` rows: each field zeros of shape ``(rows, *shape)``, the shapes and
    dtypes those of :func:`make_scratch` (the one place they are written), rows innermost in memory
    (:func:`rows_innermost`). For one thread per row (the device's layout), where a thread cannot
    allocate: allocated once, row ``n`` read by :func:`scratch_row` (views with strides)."""
    one = make_scratch(prm)
    return Scratch(**{name: rows_innermost((rows, *a.shape), a.dtype) for name, a in one._asdict().items()})


def map_arrays(fn: Callable[[np.ndarray], Any], record: Any) -> Any:
    """``record`` (a named tuple, nested ones included) with ``fn`` applied to each of its numpy arrays and
    the other fields kept: how a record's arrays are uploaded to a device, or stood in for."""
    if isinstance(record, np.ndarray):
        return fn(record)
    if isinstance(record, tuple) and hasattr(record, "_fields"):
        return type(record)(*(map_arrays(fn, v) for v in record))
    return record


@njit(inline="always", **ROW_KERNEL_OPTIONS)
def scratch_row(rows: Scratch, n: int) -> Scratch:  # pragma: no cover - compiled
    """Row ``n`` of :func:`scratch_rows`' record: a :class:`Scratch` of views, no copy (inlined into the
    caller, so no record of arrays is returned across a call).

    The fields sized by the task (perturbing bodies, truth perturbers, planets) are sliced ``[n, ::1]``,
    not indexed ``[n]``: numba types a view by the layout flags of the whole array, and a dimension of 0 or
    1 makes ``rows_innermost`` arrays C- or F-contiguous, so ``[n]`` would give each task family its own
    view types and every row kernel below would be compiled again for it. A stepped slice types every
    view as non-contiguous (``A``), the same for every task (the same elements: the numbers are
    unchanged)."""
    return Scratch(
        work=rows.work[n], rq=rows.rq[n], a=rows.a[n], frame=rows.frame[n], y=rows.y[n],
        u_cmd=rows.u_cmd[n], bias=rows.bias[n], w6=rows.w6[n], v6=rows.v6[n],
        phi=rows.phi[n], tmp=rows.tmp[n], x_new=rows.x_new[n], uw=rows.uw[n], h=rows.h[n], jac=rows.jac[n],
        rcov=rows.rcov[n], z=rows.z[n], basis=rows.basis[n], m=rows.m[n], u6=rows.u6[n], vals=rows.vals[n],
        los=rows.los[n], los_true=rows.los_true[n], mm=rows.mm[n], pix=rows.pix[n], r1=rows.r1[n],
        q1=rows.q1[n], t1=rows.t1[n], central=rows.central[n], ssb=rows.ssb[n], dirv=rows.dirv[n],
        roll=rows.roll[n], pert=rows.pert[n, ::1], tpert=rows.tpert[n, ::1], qrow=rows.qrow[n],
        planets=rows.planets[n, ::1], tcentral=rows.tcentral[n], tplanets=rows.tplanets[n, ::1],
        r_tile=rows.r_tile[n, ::1],
        q_tile=rows.q_tile[n, ::1], feat=rows.feat[n, ::1], noise3=rows.noise3[n], star_idx=rows.star_idx[n],
        star_noise=rows.star_noise[n], star_work=rows.star_work[n], q_fix=rows.q_fix[n], sub=rows.sub[n],
        light=rows.light[n], att_v=rows.att_v[n], att_q=rows.att_q[n], att_m=rows.att_m[n],
        dump=rows.dump[n], dump_p=rows.dump_p[n],
    )  # fmt: skip
