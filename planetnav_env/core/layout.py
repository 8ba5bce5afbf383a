"""Array layouts of the batch core: the per-row state columns and the observation.

The compiled kernels take a handful of arrays instead of dozens of arguments (numba's dispatcher pays
per argument: a named tuple of 80 fields costs ~17 us a call, more than a whole environment step).
Each array's columns are named here, once; kernels index them with these module-level constants,
which numba folds at compile time.

:class:`ObservationLayout` is the one description of the observation vector: the kernels write it at its
offsets, the environments build their spaces and decode observations from it, and the docstring table
of :class:`~planetnav_env.envs.env.PlanetNavEnv` is generated from it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from planetnav_env.codes import RowStatus, VisibilityReason


def _slots(*names: str) -> dict[str, int]:
    return {n: i for i, n in enumerate(names)}


# ------------------------------------------------------------------------------------------------
# Per-row float state (BatchState.f): name -> (offset, width)
# ------------------------------------------------------------------------------------------------
_F_FIELDS = (
    ("X", 6),  # true position [km] and velocity [km/s] relative to the central body
    ("XE", 6),  # the filter's estimate
    ("P", 36),  # the filter's covariance (6 x 6, row-major)
    ("Q", 4),  # true attitude, scalar-first, body -> inertial
    ("W", 3),  # true body rates [rad/s]
    ("HW", 3),  # wheel momentum [N m s]
    ("U", 3),  # last applied wheel torque [N m]
    ("QE", 4),  # star-tracker attitude
    ("ATT_ERR", 1),  # star-tracker error angle [rad] (NaN: no fix this step)
    ("WM", 3),  # reported body rates [rad/s]
    ("T0", 1),  # episode epoch [TDB s since J2000]
    ("INTEGRATED", 1),  # X-ray photons accumulated on the current pulsar [s]
    # outputs of the last step
    ("POS_ERR", 1),  # |r_est - r_true| [km]
    ("VEL_ERR", 1),  # [km/s]
    ("NEES", 1),
    ("POS_SIGMA", 1),  # sqrt(trace P_rr) [km]
    ("REWARD", 1),
    ("NIS", 1),
    ("PIX", 2),  # pixel of the last planet image
    ("HOLD_REWARD", 1),  # the rewards of the decision's physics steps so far (decision_steps > 1)
    # operations scenarios (EnvConfig.operations; zero / NaN otherwise)
    ("DV_STEP", 1),  # delta-v lost in the last step [m/s]
    ("DV_LOST", 1),  # delta-v lost in the episode [m/s]
    ("OBJECTIVE", 1),  # J so far [km]: sum of the deadline terms reached + w * DV_LOST
    ("THRUSTING", 1),  # 1: the thrust axis was within tolerance at the end of the last step
    ("DL_SIGMA", 8),  # per deadline: sqrt(trace) of the position covariance coasted to E [km]; 0 before
    ("DL_ERR", 8),  # per deadline: |dr + t_go dv| of the filter's true error mapped to E [km]; 0 before
    # image-processing failures (EnvConfig.image_success_min < 1; unused, 0, otherwise): per planet, the
    # probability, drawn at reset and fixed for the episode, that an image of it in view yields a fix
    ("IMG_P", 7),
    # centroid bias (world.centroid_bias_max > 0; unused, 0, otherwise): per planet, the scale of its
    # centre-of-brightness offset drawn at reset (sensors.camera_kernels.centroid_bias_kernel)
    ("COB", 7),
    ("COB_LAST", 1),  # the offset of the last image [rad] (0: none)
    # the onboard photometric model's scale (world.lambert_cob_corrected; unused, 0, otherwise): per
    # planet, 1 + e with e drawn at reset, what the filter's centre-of-brightness correction is scaled by
    ("COB_MODEL", 7),
    # the planet camera's boresight drift (world.drift_on; unused, 0, otherwise): its small rotation
    # about the camera's X and Y axes [rad], a Gauss-Markov process drawn at reset, stepped every step
    ("DRIFT", 2),
    # pulsar timing-model error (world.pulsar_frequency_error_max > 0; unused, 0, otherwise): per
    # pulsar, the range drift c * delta [km/s] of its phases, drawn at reset (every catalogue pulsar fits)
    ("PSR_DRIFT", 4),
    # solar radiation pressure in truth (world.srp_on; unused, 0, otherwise): the row's cannonball SRP
    # coefficient k [km^3/s^2] (dynamics.srp.srp_gm; a = k s / |s|^3, s from the Sun), its reflectivity
    # drawn at reset
    ("SRP_K", 1),
    # the filter's process noise tuned to what its force model omits (world.process_noise_tuned; unused, 0,
    # otherwise): the row's white-acceleration PSD q [km^2/s^3], set at reset
    ("Q_PSD", 1),
    # the thrust execution error as a Gauss-Markov process in truth (world.thrust_gauss_markov_on, an
    # operations scenario; unused, 0, otherwise): the fractional magnitude error along the thrust, then
    # the pointing errors [rad] about the two cross axes (core.operations.thrust_axes), drawn stationary
    # at reset and stepped every step
    ("THR_GM", 3),
    # counters of the observation blocks that keep a history (ObservationLayout; written by
    # core/observation.py's count kernels, cleared at reset); unused otherwise. Widths: MAX_TARGETS = 7
    # planets + 4 pulsars.
    ("SINCE", 11),  # per target: physics steps since it was last measured (inf: not this episode)
    ("IMG_LOG", 14),  # per planet: images of it in view, then (at + MAX_PLANETS) the fixes they gave
    ("RES_LOG", 22),  # per target: fixes of it, then (at + MAX_TARGETS) the sum of their NIS / dof
    # the flight world's attitude loop (world.attitude_world_on; unused, 0, otherwise)
    ("QH", 4),  # the attitude estimator's quaternion (scalar first, body -> inertial)
    ("BH", 3),  # its estimate of the gyro bias [rad/s]
    ("GB", 3),  # the gyro's true bias [rad/s] (drawn at reset, random walk)
    ("PA", 36),  # its covariance of (attitude error [rad], bias error [rad/s]), 6 x 6 row-major
    ("SRP_CR", 1),  # the reflectivity C_R the SRP torque uses (the episode's SRP draw, else mid-range)
    ("DUMPS", 1),  # momentum dumps this episode
    ("DUMP_DV", 1),  # nominal delta-v of this episode's dumps [m/s]
    ("DUMP_LEFT", 1),  # thrust arc: time the engine is still off for a dump [s]
    ("SAT_S", 1),  # time this episode a wheel spent at its momentum capacity [s]
    ("POINT_ERR", 1),  # both worlds: true boresight to the PD direction at the step end [rad] (NaN: none)
)
F_OFFSETS: dict[str, tuple[int, int]] = {}
_o = 0
for _name, _w in _F_FIELDS:
    F_OFFSETS[_name] = (_o, _w)
    _o += _w
NF = _o
F_X, F_XE, F_P, F_Q, F_W, F_HW, F_U, F_QE = (
    F_OFFSETS[k][0] for k in ("X", "XE", "P", "Q", "W", "HW", "U", "QE")
)
F_ATT_ERR, F_WM, F_T0, F_INTEGRATED = (F_OFFSETS[k][0] for k in ("ATT_ERR", "WM", "T0", "INTEGRATED"))
F_POS_ERR, F_VEL_ERR, F_NEES, F_POS_SIGMA = (
    F_OFFSETS[k][0] for k in ("POS_ERR", "VEL_ERR", "NEES", "POS_SIGMA")
)
F_REWARD, F_NIS, F_PIX, F_HOLD_REWARD = (F_OFFSETS[k][0] for k in ("REWARD", "NIS", "PIX", "HOLD_REWARD"))
F_DV_STEP, F_DV_LOST, F_OBJECTIVE, F_THRUSTING, F_DL_SIGMA, F_DL_ERR = (
    F_OFFSETS[k][0] for k in ("DV_STEP", "DV_LOST", "OBJECTIVE", "THRUSTING", "DL_SIGMA", "DL_ERR")
)
F_IMG_P = F_OFFSETS["IMG_P"][0]
F_COB, F_COB_LAST = F_OFFSETS["COB"][0], F_OFFSETS["COB_LAST"][0]
F_PSR_DRIFT = F_OFFSETS["PSR_DRIFT"][0]
F_COB_MODEL, F_DRIFT = F_OFFSETS["COB_MODEL"][0], F_OFFSETS["DRIFT"][0]
F_SRP_K, F_Q_PSD = F_OFFSETS["SRP_K"][0], F_OFFSETS["Q_PSD"][0]
F_THR_GM = F_OFFSETS["THR_GM"][0]
F_SINCE, F_IMG_LOG, F_RES_LOG = (F_OFFSETS[k][0] for k in ("SINCE", "IMG_LOG", "RES_LOG"))
F_QH, F_BH, F_GB, F_PA = (F_OFFSETS[k][0] for k in ("QH", "BH", "GB", "PA"))
F_SRP_CR, F_DUMPS, F_DUMP_DV, F_DUMP_LEFT, F_SAT_S, F_POINT_ERR = (
    F_OFFSETS[k][0] for k in ("SRP_CR", "DUMPS", "DUMP_DV", "DUMP_LEFT", "SAT_S", "POINT_ERR")
)
#: Pulsar slots of PSR_DRIFT.
MAX_PULSARS = F_OFFSETS["PSR_DRIFT"][1]
#: Planet slots of IMG_P: every body a camera may target (``astro.bodies.BODIES`` but the Sun).
MAX_PLANETS = F_OFFSETS["IMG_P"][1]
#: Deadline slots of the state (``config.MAX_DEADLINES``; the width of DL_SIGMA and DL_ERR).
MAX_DEADLINES = F_OFFSETS["DL_SIGMA"][1]
#: Target slots of the per-target counters (planets, then pulsars).
MAX_TARGETS = F_OFFSETS["SINCE"][1]
assert MAX_TARGETS == MAX_PLANETS + MAX_PULSARS
assert F_OFFSETS["IMG_LOG"][1] == 2 * MAX_PLANETS and F_OFFSETS["RES_LOG"][1] == 2 * MAX_TARGETS

# ------------------------------------------------------------------------------------------------
# Per-row integer state (BatchState.i)
# ------------------------------------------------------------------------------------------------
_I = _slots(
    "K",  # steps taken in the episode
    "TARGET",  # current target index (planets, then pulsars) or -1
    "SKIPPED",  # pulsar phases skipped for cycle ambiguity
    "SETTLED",  # 1: the attitude is settled on the target (coarse sub-steps allowed)
    "MEASURED",
    "REJECTED",
    "REASON",  # REASON_* code of the last step
    "SLEWING",
    "SENSOR",  # SENSOR_* code
    "TERMINATED",
    "TRUNCATED",
    "STATUS",  # STATUS_* code: 0 ok
    "STARS",  # stars in the star tracker's field at the last fix
)
NI = len(_I)
I_K, I_TARGET, I_SKIPPED, I_SETTLED, I_MEASURED, I_REJECTED = (
    _I[k] for k in ("K", "TARGET", "SKIPPED", "SETTLED", "MEASURED", "REJECTED")
)
I_REASON, I_SLEWING, I_SENSOR, I_TERMINATED, I_TRUNCATED, I_STATUS, I_STARS = (
    _I[k] for k in ("REASON", "SLEWING", "SENSOR", "TERMINATED", "TRUNCATED", "STATUS", "STARS")
)

#: ``info["visibility"]`` strings by code (:class:`~planetnav_env.codes.VisibilityReason` labels).
REASONS = tuple(r.label for r in VisibilityReason)
# The REASON_* ints the kernels compare (derived: numba folds int globals into constants).
(
    REASON_VISIBLE,
    REASON_OUT_OF_FOV,
    REASON_OCCULTED,
    REASON_SUN_EXCLUSION,
    REASON_TOO_SMALL,
    REASON_TOO_LARGE,
    REASON_NONE,
    REASON_INTEGRATING,
    REASON_AMBIGUOUS,
    REASON_IMAGE_FAILED,
) = (int(r) for r in VisibilityReason)
SENSORS = (None, "camera", "xray")
SENSOR_NONE, SENSOR_CAMERA, SENSOR_XRAY = range(3)
#: Row status codes (:class:`~planetnav_env.codes.RowStatus` as ints, BatchState.i[:, I_STATUS]); the
#: shells turn non-zero ones into named errors.
STATUS_OK, STATUS_ATTITUDE_NONFINITE, STATUS_CAMERA = (int(s) for s in RowStatus)

MODE_TARGET, MODE_TORQUE, MODE_TARGET_TORQUE, MODE_HYBRID = range(4)
MODE_CODES = {
    "target": MODE_TARGET, "torque": MODE_TORQUE, "target+torque": MODE_TARGET_TORQUE, "hybrid": MODE_HYBRID,
}  # fmt: skip

# ------------------------------------------------------------------------------------------------
# Observation
# ------------------------------------------------------------------------------------------------
#: Width of the per-target block (planets; pulsars use the same width).
TARGET_FEATURES = 7
#: Columns of one target block (planets and pulsars share the width and columns 0-2, 5 and 6; see
#: PLANET_FEATURE_TEXT and PULSAR_FEATURE_TEXT). The compiled builders and the agents index with these.
TF_DIR = 0  #: direction in body axes, 3 columns (0, 1, 2)
TF_LOG_DISTANCE = 3  #: planets: log10(estimated distance / AU)
TF_PROGRESS = 3  #: pulsars: integration progress 0..1 (current target only)
TF_SIZE = 4  #: planets: estimated apparent diameter / diameter noise
TF_LOG_PHASE_SIGMA = 4  #: pulsars: log10 of the predicted phase 1-sigma [cycles]
TF_OBSERVABLE = 5  #: 1 if a measurement of it is possible now (Sun, occultation, size), else 0
TF_LOG_SIGMA = 6  #: log10 of the position 1-sigma [km] / 4 across its line of sight (planets), along it
#: (pulsars): what a measurement of it would shrink
#: The spacecraft block: (name, width, content, scale), in order from index 0.
SPACECRAFT_BLOCK = (
    ("position", 3, "estimated position relative to the central body (the Sun; Mars on approach), ICRF",
     "/ 1 AU (10^6 km on approach)"),
    ("velocity", 3, "estimated velocity", "/ 30 km/s (5 on approach)"),
    ("log_sigma", 6, "log10 of the filter's position 1-sigma per axis, then velocity 1-sigma per axis",
     "log10(km) / 4, log10(m/s) / 4"),
    ("attitude", 4, "attitude quaternion from the star tracker (scalar first)", "-"),
    ("rates", 3, "reported body rates", "deg/s"),
    ("wheel_momentum", 3, "wheel momentum", "/ capacity"),
)  # fmt: skip


def _block_starts() -> dict[str, int]:
    starts, i = {}, 0
    for name, w, _, _ in SPACECRAFT_BLOCK:
        starts[name] = i
        i += w
    return starts


#: First index of each spacecraft-block field in the flat observation (the compiled builder writes there).
(SC_POSITION, SC_VELOCITY, SC_LOG_SIGMA, SC_ATTITUDE, SC_RATES, SC_WHEEL_MOMENTUM) = (
    _block_starts()[k] for k in ("position", "velocity", "log_sigma", "attitude", "rates", "wheel_momentum")
)
PLANET_FEATURE_TEXT = (
    "planet p: estimated direction in body axes (3), log10(estimated distance / AU), estimated apparent "
    "diameter / diameter noise, observable if pointed at (Sun exclusion, occultation, size) 0/1, log10 of "
    "the position 1-sigma across its line of sight [km] / 4 (what a measurement of it would shrink)"
)
PULSAR_FEATURE_TEXT = (
    "pulsar j: direction in body axes (3), integration progress 0..1, log10 predicted phase 1-sigma "
    "[cycles], observable (Sun, occultation) 0/1, log10 of the position 1-sigma along its direction [km] / 4"
)


#: Scales of the operations block (EnvConfig.operations): time to each deadline [d] / OPS_DAYS_SCALE,
#: delta-v lost [m/s] / OPS_DV_SCALE (values of order 1 for a 21-day arc and ~10 m/s of sessions).
OPS_DAYS_SCALE = 10.0
OPS_DV_SCALE = 10.0
OPERATIONS_TEXT = (
    "operations (with EnvConfig.operations, D deadlines): time to each deadline [d] (0 once reached), "
    "delta-v lost so far [m/s], thrusting at the end of the step 0/1"
)


#: Scale of the per-target history counts [steps]: a constant (one cruise day of 60-s steps), not the
#: episode length, so that a policy evaluated on shorter episodes than it was trained on sees the same
#: values (``since_measured``, the image counts of ``image_log``: log1p(count) / log1p(SINCE_SCALE_STEPS)).
SINCE_SCALE_STEPS = 1440
#: Cap of the residual log's mean normalized NIS (the observation is its value / the cap).
RESIDUAL_CAP = 10.0


@dataclass(frozen=True)
class ObservationBlock:
    """An optional block of the observation, after the fixed ones: present when the option
    ``observe_<name>`` of :class:`~planetnav_env.config.EnvConfig` is on, written by its kernel in
    :mod:`planetnav_env.core.observation` at ``CoreParams.obs_blocks[code]`` (its place in
    :data:`OBSERVATION_BLOCKS`). Everything else (offsets, spaces, the dict observation, decoding, the
    documentation table, the kernels' offsets) is derived from this declaration.

    Width ``per_planet * P + per_target * T + fixed`` values; ``rows`` > 1 gives the dict observation the
    shape ``(rows, width // rows)``."""

    name: str
    per_planet: int
    per_target: int
    fixed: int
    text: str  #: what the values are (the documentation table's content column)
    index: str  #: the documentation table's index column
    scale: str  #: the documentation table's scale column
    bounds: tuple[float, float]  #: bounds of the dict observation's Box
    rows: int = 1
    flags: bool = False  #: decoded as booleans (value > 0.5) by ``spaces.decode_observation``

    @property
    def option(self) -> str:
        """The ``EnvConfig`` option that switches the block on."""
        return f"observe_{self.name}"

    def width(self, n_planets: int, n_pulsars: int) -> int:
        return self.per_planet * n_planets + self.per_target * (n_planets + n_pulsars) + self.fixed

    def shape(self, n_planets: int, n_pulsars: int) -> tuple[int, ...]:
        w = self.width(n_planets, n_pulsars)
        return (w,) if self.rows == 1 else (self.rows, w // self.rows)


#: The optional blocks, in the order they follow the fixed blocks (and ``operations``).
OBSERVATION_BLOCKS: tuple[ObservationBlock, ...] = (
    ObservationBlock(
        "in_field", 1, 0, 0,
        "in field (with EnvConfig.observe_in_field), one per planet: 1 if the camera's visibility rule "
        "(field of view, occultation, Sun exclusion, size) passes for that planet at the star-tracker "
        "attitude and the estimated position now, and its disk fits the field; the camera measures the "
        "one of them nearest the boresight",
        "..+P", "0/1", (0.0, 1.0), flags=True,
    ),
    ObservationBlock(
        "since_measured", 0, 1, 0,
        "since measured (with EnvConfig.observe_since_measured), one per target: log1p(physics steps "
        "since it was last measured) / log1p(1440), capped at 1; 1 when not measured this episode",
        "..+T", "0..1", (0.0, 1.0),
    ),
    ObservationBlock(
        "image_log", 2, 0, 0,
        "image log (with EnvConfig.observe_image_log), two rows of one per planet: (fixes + 1) / (images "
        "+ 2), the mean of the planet's image success rate under a uniform prior, then log1p(images) / "
        "log1p(1440) capped at 1, over this episode's images of it in view (an image that yields no fix "
        "counts; one out of view or behind the Sun does not)",
        "..+2P", "0..1", (0.0, 1.0), rows=2,
    ),
    ObservationBlock(
        "residual_log", 0, 1, 0,
        "residual log (with EnvConfig.observe_residual_log), one per target (planets, then pulsars): the "
        "mean over this episode's fixes of it of the filter's NIS divided by its degrees of freedom (a "
        "phase has one), with a prior of two consistent fixes (1: consistent with the filter's noise "
        "model), capped at 10, / 10",
        "..+T", "0..1", (0.0, 1.0),
    ),
    ObservationBlock(
        "position_correlation", 0, 0, 3,
        "position correlation (with EnvConfig.observe_position_correlation): the correlation "
        "coefficients rho_xy, rho_xz, rho_yz of the filter's position covariance P_rr (with log_sigma's "
        "diagonal they give the whole P_rr: which way the position error lies)",
        "last 3", "-1..1", (-1.0, 1.0),
    ),
    ObservationBlock(
        "momentum", 0, 0, 4,
        "momentum (with EnvConfig.observe_momentum): the largest wheel |momentum| over the dump "
        "threshold (world.dump_threshold_n_m_s; the wheel capacity without dumping: a dump comes at 1), "
        "then the total angular momentum of body and wheels in inertial axes (the star-tracker attitude, "
        "the reported rates) / the wheel capacity: what the disturbance torques build and a dump removes",
        "last 4", "-, / capacity", (-10.0, 10.0),
    ),
)  # fmt: skip
#: Index of each optional block in :data:`OBSERVATION_BLOCKS` (and in ``CoreParams.obs_blocks``).
BLOCK_CODES = {b.name: k for k, b in enumerate(OBSERVATION_BLOCKS)}
#: The codes the kernels index ``CoreParams.obs_blocks`` with (numba folds int globals into constants).
OB_IN_FIELD = BLOCK_CODES["in_field"]
OB_SINCE_MEASURED = BLOCK_CODES["since_measured"]
OB_IMAGE_LOG = BLOCK_CODES["image_log"]
OB_RESIDUAL_LOG = BLOCK_CODES["residual_log"]
OB_POSITION_CORRELATION = BLOCK_CODES["position_correlation"]
OB_MOMENTUM = BLOCK_CODES["momentum"]


@dataclass(frozen=True)
class ObservationLayout:
    """Offsets of every block of the flat observation for ``n_planets`` planets and ``n_pulsars`` pulsars,
    and, with ``n_deadlines`` set (an operations scenario), the ``operations`` block of ``n_deadlines + 2``
    values after ``elapsed``; then each optional block of :data:`OBSERVATION_BLOCKS` whose flag (a field
    of the block's name) is set, in that order.

    ``blocks`` lists ``(name, start, stop, shape)``; the ``dict`` observation uses the same names and
    shapes, so one table serves the builders, the spaces, :func:`decode` and the documentation.
    ``<name>_start`` (e.g. ``image_log_start``) is :meth:`start` of an optional block.
    """

    n_planets: int
    n_pulsars: int
    n_deadlines: int | None = None
    # One flag per optional block (OBSERVATION_BLOCKS), in its order.
    in_field: bool = False
    since_measured: bool = False
    image_log: bool = False
    residual_log: bool = False
    position_correlation: bool = False
    momentum: bool = False

    @classmethod
    def for_config(cls, cfg) -> ObservationLayout:
        """The layout of an :class:`~planetnav_env.config.EnvConfig`."""
        ops = getattr(cfg, "operations", None)
        flags = {b.name: bool(getattr(cfg, b.option, False)) for b in OBSERVATION_BLOCKS}
        return cls(cfg.n_planets, cfg.n_pulsars, None if ops is None else len(ops.deadlines_s), **flags)

    @property
    def n_targets(self) -> int:
        return self.n_planets + self.n_pulsars

    @property
    def planets_start(self) -> int:
        return sum(w for _, w, _, _ in SPACECRAFT_BLOCK)

    @property
    def pulsars_start(self) -> int:
        return self.planets_start + TARGET_FEATURES * self.n_planets

    @property
    def target_start(self) -> int:
        return self.pulsars_start + TARGET_FEATURES * self.n_pulsars

    @property
    def elapsed_index(self) -> int:
        return self.target_start + self.n_targets

    @property
    def operations_start(self) -> int:
        """First index of the operations block (== size without one)."""
        return self.elapsed_index + 1

    def has(self, name: str) -> bool:
        """Whether the optional block ``name`` is present."""
        return bool(getattr(self, OBSERVATION_BLOCKS[BLOCK_CODES[name]].name))

    def start(self, name: str) -> int:
        """First index of the optional block ``name`` (where it would start, when absent)."""
        i = self.operations_start + (0 if self.n_deadlines is None else self.n_deadlines + 2)
        for b in OBSERVATION_BLOCKS[: BLOCK_CODES[name]]:
            i += b.width(self.n_planets, self.n_pulsars) if getattr(self, b.name) else 0
        return i

    def __getattr__(self, attr: str) -> int:
        # <name>_start of an optional block (called only for names the class does not define).
        name = attr.removesuffix("_start")
        if attr.endswith("_start") and name in BLOCK_CODES:
            return self.start(name)
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {attr!r}")

    def block_starts(self) -> np.ndarray:
        """(len(OBSERVATION_BLOCKS),) int64: each optional block's first index, -1 when absent (the
        kernels' ``CoreParams.obs_blocks``)."""
        return np.array([self.start(b.name) if getattr(self, b.name) else -1 for b in OBSERVATION_BLOCKS],
                        dtype=np.int64)  # fmt: skip

    @property
    def size(self) -> int:
        last = OBSERVATION_BLOCKS[-1]
        width = last.width(self.n_planets, self.n_pulsars) if self.has(last.name) else 0
        return self.start(last.name) + width

    @property
    def blocks(self) -> tuple[tuple[str, int, int, tuple[int, ...]], ...]:
        out = []
        i = 0
        for name, w, _, _ in SPACECRAFT_BLOCK:
            out.append((name, i, i + w, (w,)))
            i += w
        out.append(("planets", self.planets_start, self.pulsars_start, (self.n_planets, TARGET_FEATURES)))
        if self.n_pulsars:
            out.append(("pulsars", self.pulsars_start, self.target_start, (self.n_pulsars, TARGET_FEATURES)))
        out.append(("target", self.target_start, self.elapsed_index, (self.n_targets,)))
        out.append(("elapsed", self.elapsed_index, self.operations_start, (1,)))
        if self.n_deadlines is not None:
            stop = self.operations_start + self.n_deadlines + 2
            out.append(("operations", self.operations_start, stop, (self.n_deadlines + 2,)))
        for b in OBSERVATION_BLOCKS:
            if getattr(self, b.name):
                a = self.start(b.name)
                out.append((b.name, a, a + b.width(self.n_planets, self.n_pulsars),
                            b.shape(self.n_planets, self.n_pulsars)))  # fmt: skip
        return tuple(out)

    def to_dict(self, flat: np.ndarray) -> dict[str, np.ndarray]:
        """Split a flat observation (..., size) into the named blocks (views, shapes of ``blocks``)."""
        lead = flat.shape[:-1]
        return {name: flat[..., a:b].reshape(lead + shape) for name, a, b, shape in self.blocks}

    def from_dict(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        """Inverse of :meth:`to_dict` for one observation; missing ``pulsars`` reads as none."""
        parts = []
        for name, a, b, _ in self.blocks:
            parts.append(np.asarray(obs[name], dtype=float).reshape(-1))
            if parts[-1].size != b - a:
                raise ValueError(f"observation block {name!r} has {parts[-1].size} values, expected {b - a}")
        return np.concatenate(parts)

    def doc_table(self) -> str:
        """The reStructuredText table of the flat layout (generated into the environment's docstring)."""
        rows = []
        i = 0
        for name, w, text, scale in SPACECRAFT_BLOCK:
            rows.append((f"{i}-{i + w - 1}", f"{name}: {text}", scale))
            i += w
        rows.append(("22+7p..28+7p", PLANET_FEATURE_TEXT, "-, log10(AU), / sigma_alpha, 0/1, log10(km)/4"))
        rows.append(("22+7P+7j..", PULSAR_FEATURE_TEXT, "-, 0..1, log10, 0/1, log10(km)/4"))
        rows.append(("22+7T..", "current target, one-hot (T = P + Q)", "0/1"))
        rows.append(("22+8T", "elapsed fraction of the episode", "0..1"))
        rows.append(("..+D+2", OPERATIONS_TEXT, f"/ {OPS_DAYS_SCALE:g} d, / {OPS_DV_SCALE:g} m/s, 0/1"))
        rows += [(b.index, b.text, b.scale) for b in OBSERVATION_BLOCKS]
        w0 = max(len(r[0]) for r in rows)
        w1 = max(len(r[1]) for r in rows)
        w2 = max(len(r[2]) for r in rows)
        sep = f"{'=' * w0} {'=' * w1} {'=' * w2}"
        lines = [sep, f"{'index':<{w0}} {'content':<{w1}} {'scale':<{w2}}", sep]
        lines += [f"{a:<{w0}} {b:<{w1}} {c:<{w2}}" for a, b, c in rows]
        lines.append(sep)
        return "\n".join(lines)


def observation_scales(scenario: str) -> tuple[float, float]:
    """Position [km] and velocity [km/s] scales of the observation: 1 AU and 30 km/s in cruise; 10^6 km and
    5 km/s on approach (Mars-centred)."""
    from planetnav_env.astro.bodies import AU_KM

    return (1.0e6, 5.0) if scenario == "mars-approach" else (AU_KM, 30.0)


#: The fixed constants of ``observation_scaling: unit`` (:func:`unit_scaling`): per scenario kind
#: (``heliocentric``: the cruises and the thrust arc; ``approach``: Mars-centred) and block, one
#: ``(offset, scale)`` per column, a column written as ``(raw - offset) / scale``; a block or column not
#: listed keeps ``(0, 1)`` (its raw scale is already of order 1: unit vectors, quaternions, 0/1 flags,
#: fractions, the history blocks). Chosen from the raw columns' ranges under uniform random actions in the
#: flight world (``research/tasks_v3/probe_obs.py``), so that each listed column spans about -2..2, and
#: then fixed: they are part of a task version's definition, not a running statistic.
UNIT_SCALING: dict[str, dict[str, tuple[tuple[float, float], ...]]] = {
    "heliocentric": {
        # log10(km) / 4 of the position 1-sigma (~0.4-0.9 over a cruise), then log10(m/s) / 4 (~0).
        "log_sigma": ((0.6, 0.15),) * 3 + ((0.0, 0.05),) * 3,
        "rates": ((0.0, 2.0),) * 3,  # deg/s: torque tasks' tumbles reach ~3.6
        # direction (3), log10(distance / AU), size / noise (sub-pixel disks: ~0-1), observable, log sigma.
        "planet": ((0.0, 1.0),) * 3 + ((0.0, 0.5), (0.0, 1.0), (0.0, 1.0), (0.6, 0.15)),
        # days to each deadline / 10 (0-2 on the thrust arc), delta-v lost / 10 m/s (~27 if always imaging),
        # thrusting: the delta-v column divided by 5 more (~0.2 for the rules' sessions).
        "operations_dv": ((0.0, 5.0),),
    },
    "approach": {
        "log_sigma": ((0.2, 0.15),) * 3 + ((-0.3, 0.15),) * 3,
        "rates": ((0.0, 2.0),) * 3,
        # log10(distance / AU) from -3.8 to -2.2 on the last 94 h; Mars's disk from 10 to 385 noise widths.
        "planet": ((0.0, 1.0),) * 3 + ((-3.0, 0.5), (100.0, 100.0), (0.0, 1.0), (0.2, 0.2)),
        # direction (3), progress 0..1, log10 phase 1-sigma [cycles] (-4..-0.7), observable, log sigma.
        "pulsar": ((0.0, 1.0),) * 3 + ((0.0, 1.0), (-2.0, 1.0), (0.0, 1.0), (0.2, 0.2)),
    },
}


def unit_scaling(layout: ObservationLayout, scenario: str) -> np.ndarray:
    """(2, size) offset and scale of every column of ``layout``'s observation under ``observation_scaling:
    unit`` for ``scenario`` (:data:`UNIT_SCALING`; the kernels write ``(raw - offset) / scale``)."""
    table = UNIT_SCALING["approach" if scenario == "mars-approach" else "heliocentric"]
    out = np.zeros((2, layout.size))
    out[1] = 1.0

    def put(start: int, pairs: tuple[tuple[float, float], ...]) -> None:
        for j, (off, scale) in enumerate(pairs):
            out[0, start + j], out[1, start + j] = off, scale

    starts = _block_starts()
    for name in ("log_sigma", "rates"):
        put(starts[name], table[name])
    for p in range(layout.n_planets):
        put(layout.planets_start + TARGET_FEATURES * p, table["planet"])
    for q in range(layout.n_pulsars):
        put(layout.pulsars_start + TARGET_FEATURES * q, table.get("pulsar", ()))
    if layout.n_deadlines is not None and "operations_dv" in table:
        put(layout.operations_start + layout.n_deadlines, table["operations_dv"])
    return out
