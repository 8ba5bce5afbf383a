"""Environment configuration: typed, validated dataclasses that YAML files in ``configs/`` map onto.

An unknown key or an invalid value raises :class:`~planetnav_env.errors.ConfigError` naming it,
never a silent default (an unknown top-level option raises its subclass
:class:`~planetnav_env.errors.UnknownOptionError`, also a ``TypeError``).
``EnvConfig.from_dict`` accepts the nested mapping of a YAML file::

    scenario: cruise
    planets: [venus, mars, earth]
    step_s: 60
    camera: {direction_noise_arcsec: 3.5}
    filter: {sigma_pos0: 1000.0}
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from planetnav_env.bodies import BODIES
from planetnav_env.errors import ConfigError, PlanetNavError, UnknownOptionError
from planetnav_env.estimation.ekf import FilterConfig
from planetnav_env.estimation.measurements import MODELS
from planetnav_env.sensors.camera_config import CameraConfig
from planetnav_env.sensors.pulsar import XrayDetector, pulsar

SCENARIOS = ("cruise", "random-cruise", "mars-approach")
ACTION_MODES = ("target", "torque", "target+torque", "hybrid")
REWARDS = ("truth", "covariance")
NOISE_STREAMS = ("sequential", "per_step")


@dataclass(frozen=True)
class AttitudeSettings:
    """Spacecraft mass properties, wheels and the PD law (see :mod:`planetnav_env.attitude.pointing`).

    inertia [kg m^2] (3 principal moments), wheel_torque_limit [N m], wheel_momentum_capacity [N m s],
    k_a [N m], k_w [N m s]: PD gains, rate_noise_deg_s: 1-sigma of the reported body rates [deg/s].
    """

    inertia: tuple[float, float, float] = (10.0, 12.0, 8.0)
    wheel_torque_limit: float = 0.01
    wheel_momentum_capacity: float = 0.5
    k_a: float = 0.02
    k_w: float = 1.0
    rate_noise_deg_s: float = 1e-4

    def __post_init__(self) -> None:
        _positive(self, "wheel_torque_limit", "wheel_momentum_capacity", "k_a", "k_w")
        if len(self.inertia) != 3 or any(
            not (math.isfinite(float(v)) and float(v) > 0) for v in self.inertia
        ):
            raise ConfigError(f"attitude.inertia must be 3 positive moments [kg m^2], got {self.inertia!r}")
        if not (math.isfinite(self.rate_noise_deg_s) and self.rate_noise_deg_s >= 0):
            raise ConfigError(f"attitude.rate_noise_deg_s must be >= 0, got {self.rate_noise_deg_s!r}")


#: Most knowledge deadlines an operations scenario may list (the core keeps one slot per deadline).
MAX_DEADLINES = 8


@dataclass(frozen=True)
class OperationsSettings:
    """A navigation-operations scenario (issue 17, docs/operations.md §3): a mission attitude that imaging
    interrupts, and knowledge deadlines. ``None`` in :attr:`EnvConfig.operations` is the plain cruise.

    Mission attitude: the thrust axis is the camera boresight body axis (the engine sits on the opposite
    face, so the thrust acts along +boresight); the planned thrust direction ``u`` is the filter's estimated
    velocity direction relative to the central body (a tangential thrust arc) at the start of each step.
    The engine thrusts while the thrust axis is within ``attitude_tolerance_deg`` of ``u`` (checked at every
    attitude sub-step).

    thrust_n [N], mass_kg [kg] (constant: a 21-d arc at 92 mN uses ~1 % of DS1's mass in xenon): thrust
    acceleration a = thrust_n / mass_kg. thrust_mag_sigma [fraction of a] and thrust_point_sigma_deg [deg
    per cross axis]: 1-sigma execution errors of a first-order Gauss-Markov process with correlation time
    thrust_corr_time_s [s], modelled as white noise of its low-frequency PSD 2 sigma^2 tau
    (q_par = 2 (sigma_m a)^2 tau along u, q_perp = 2 (sigma_p a)^2 tau across, km^2/s^3).
    deadlines_s: knowledge deadlines (TCM epochs) [s from episode start], strictly increasing, at most
    :data:`MAX_DEADLINES`, each at most encounter_s; encounter_s: the encounter epoch E [s from episode
    start] to which the position knowledge is mapped (t_go = E - t). cost_weight [km per m/s]: the
    exchange rate w between delta-v lost and knowledge error in the objective
    J = sum_k e_k + w * dv_lost.
    """

    thrust_n: float = 0.092
    mass_kg: float = 486.0
    thrust_mag_sigma: float = 0.02
    thrust_point_sigma_deg: float = 1.0
    thrust_corr_time_s: float = 86400.0
    attitude_tolerance_deg: float = 1.0
    deadlines_s: tuple[float, ...] = (604800.0, 1382400.0, 1684800.0)
    encounter_s: float = 1814400.0
    cost_weight: float = 129.6

    def __post_init__(self) -> None:
        for name in ("thrust_n", "mass_kg", "thrust_corr_time_s", "encounter_s"):
            _positive(self, name, prefix="operations.")
        for name in ("thrust_mag_sigma", "thrust_point_sigma_deg", "cost_weight"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and v >= 0):
                raise ConfigError(f"operations.{name} must be a finite number >= 0, got {v!r}")
        tol = self.attitude_tolerance_deg
        if isinstance(tol, bool) or not isinstance(tol, (int, float)) or not (0.0 < tol < 90.0):
            raise ConfigError(f"operations.attitude_tolerance_deg must be in (0, 90) deg, got {tol!r}")
        dl = self.deadlines_s
        if isinstance(dl, (int, float)):
            dl = (dl,)
        try:
            dl = tuple(float(v) for v in dl)
        except (TypeError, ValueError):
            raise ConfigError(f"operations.deadlines_s must be a list of numbers [s], got {dl!r}") from None
        if not 1 <= len(dl) <= MAX_DEADLINES:
            raise ConfigError(
                f"operations.deadlines_s must list 1 to {MAX_DEADLINES} epochs, got {len(dl)}: {list(dl)}"
            )
        if not all(math.isfinite(v) and 0.0 < v <= self.encounter_s for v in dl) or any(
            b <= a for a, b in itertools.pairwise(dl)
        ):
            raise ConfigError(
                "operations.deadlines_s must be strictly increasing epochs in (0, encounter_s = "
                f"{self.encounter_s}] s, got {list(dl)}"
            )
        object.__setattr__(self, "deadlines_s", dl)

    @property
    def thrust_accel_km_s2(self) -> float:
        """a = T / m [km/s^2]."""
        return self.thrust_n / self.mass_kg / 1000.0

    @property
    def psd_km2_s3(self) -> tuple[float, float]:
        """(q_par, q_perp) [km^2/s^3]: white-noise PSDs of the thrust execution error along and across u."""
        a, tau = self.thrust_accel_km_s2, self.thrust_corr_time_s
        sp = math.radians(self.thrust_point_sigma_deg)
        return 2.0 * (self.thrust_mag_sigma * a) ** 2 * tau, 2.0 * (sp * a) ** 2 * tau


@dataclass(frozen=True)
class EnvConfig:
    """Everything that defines an episode. Units: s, km, rad unless the name says otherwise.

    scenario: ``cruise`` (the thesis's Venus-to-Mars transfer from 2020-08-01, fixed),
        ``random-cruise`` (epoch, transfer arc and initial estimate error drawn from the reset seed) or
        ``mars-approach`` (the patent's case: Mars-centred dynamics with Sun, Earth and Jupiter
        perturbations; the episode ends ``approach_end_before_ca_h`` before closest approach).
    planets: bodies the camera may target (their order is the action index).
    step_s: environment step; attitude_substep_s: attitude integration step (must divide step_s).
    settled_substep_s: the attitude step while a held target is already settled (pointing error below
        1e-4 rad, rates below 1e-5 rad/s, PD law only): the closed loop is then near equilibrium and
        coarse steps follow the 1 s integration within 1" (median 0.1", far below the star tracker's
        1.4" per axis) and leave the estimate within 1 m (tested), at a tenth of the cost. Must be a
        multiple of attitude_substep_s that divides step_s; 0 disables it.
    episode_steps: steps before truncation.
    action_mode: ``target``, ``torque``, ``target+torque`` or ``hybrid`` (see :class:`PlanetNavEnv`;
        ``hybrid``: each step either the PD law slews to a planet or the agent's torque drives the wheels).
    measurement_model: filter model, one of :data:`planetnav_env.estimation.measurements.MODELS`.
    reward: ``truth`` (-|r_est - r_true| / reward_scale_km, privileged) or ``covariance``
        (-sqrt(trace P_rr) / reward_scale_km, computable on board); torque_penalty multiplies
        the squared commanded torque fraction.
    torque_action_scale: the fraction of each wheel's torque limit that a torque action of 1 commands
        (``torque`` and ``target+torque`` modes), in (0, 1]. The agent's torque is held for a whole
        step, so a pointing law needs torques of ~1e-3 of the limit while a slew needs ~1e-1: a
        smaller scale gives a learner's [-1, 1] outputs that resolution, at the cost of slower slews
        (0.02: a 90-degree slew takes ~10 steps). Agents convert with it (``TargetAgent.torque_toward``).
    divergence_km: the episode terminates when the true position error exceeds it.
    observation: ``box`` (flat float32) or ``dict``.
    observe_in_field: add the ``in_field`` block to the observation (last, one 0/1 per planet: the
        camera's visibility rule passes for it at the current star-tracker attitude and estimated
        position; ``ObservationLayout``). Off by default, so existing ids keep their observation.
    idle_action: add a last discrete action "camera off" (for the idle floor agent); with ``operations``
        it is "stay at the mission attitude" (the engine thrusts).
    star_tracker: ``qmethod`` (q-method fix from the synthetic sky each step) or ``ideal``.
    star_tracker_sigma_arcsec: attitude error per axis the filter assumes on top of the camera's
        direction noise (the star tracker's error rotates every measured line of sight). The star
        fix comes from the camera's own field (5" per star, ~15 stars): its error across the
        boresight measures 1.4" per axis.
    star_tracker_bias_arcsec: a fixed misalignment of the attitude fix, a small rotation vector in
        body axes [arcsec] composed with every fix (``q_est = q_fix * q_bias``); the filter does not know
        it. Zero by default; for studying how attitude errors reach navigation.
    noise_streams: how sensor noise is drawn from the episode seed. ``sequential`` (default): one stream
        per episode, consumed in the order the sensors ask. ``per_step``: each sensor's noise at step k
        comes from its own stream keyed by (episode seed, k, sensor), independent of what happened
        before (``planetnav_env.core.rng.substream``). The noise has the same distribution either way;
        ``per_step`` gives common random numbers: two policies run on the same seed see the same noise
        whenever they make the same measurement at the same step, so their paired difference measures
        the policies rather than two noise draws (``train.py compare --noise-streams per_step``).
    operations: an :class:`OperationsSettings` (thrust arc, knowledge deadlines; docs/operations.md) or
        None (default: no mission attitude, the reward above). Needs ``action_mode="target"``,
        ``idle_action=True`` and no pulsars.
    """

    scenario: str = "cruise"
    planets: tuple[str, ...] = ("venus", "mars", "earth")
    step_s: float = 60.0
    attitude_substep_s: float = 1.0
    settled_substep_s: float = 10.0
    episode_steps: int = 1440
    action_mode: str = "target"
    measurement_model: str = "los+size"
    reward: str = "truth"
    reward_scale_km: float = 1000.0
    torque_penalty: float = 0.0
    torque_action_scale: float = 1.0
    divergence_km: float = 1.0e5
    observation: str = "box"
    observe_in_field: bool = False
    idle_action: bool = False
    star_tracker: str = "qmethod"
    star_tracker_sigma_arcsec: float = 1.5
    star_tracker_bias_arcsec: tuple[float, float, float] = (0.0, 0.0, 0.0)
    noise_streams: str = "sequential"
    pulsars: tuple[str, ...] = ()
    detector_fov_deg: float = 2.0
    ambiguity_k_sigma: float = 3.0
    approach_end_before_ca_h: float = 2.0
    camera: CameraConfig = field(default_factory=CameraConfig)
    filter: FilterConfig = field(default_factory=FilterConfig)
    attitude: AttitudeSettings = field(default_factory=AttitudeSettings)
    detector: XrayDetector = field(default_factory=XrayDetector)
    operations: OperationsSettings | None = None

    def __post_init__(self) -> None:
        if self.scenario not in SCENARIOS:
            raise ConfigError(f"scenario must be one of {SCENARIOS}, got {self.scenario!r}")
        planets = tuple(str(p).lower() for p in self.planets)
        if not planets:
            raise ConfigError("planets must name at least one body")
        for p in planets:
            if p not in BODIES or p == "sun":
                raise ConfigError(
                    f"planets: unknown or unusable body {p!r}; choose from {sorted(set(BODIES) - {'sun'})}"
                )
        if len(set(planets)) != len(planets):
            raise ConfigError(f"planets must not repeat, got {list(planets)}")
        object.__setattr__(self, "planets", planets)
        _positive(self, "step_s", "attitude_substep_s", "reward_scale_km", "divergence_km")
        ratio = self.step_s / self.attitude_substep_s
        if abs(ratio - round(ratio)) > 1e-9:
            raise ConfigError(
                f"attitude_substep_s ({self.attitude_substep_s}) must divide step_s ({self.step_s}) exactly"
            )
        coarse = self.settled_substep_s
        if not (isinstance(coarse, (int, float)) and math.isfinite(coarse) and coarse >= 0):
            raise ConfigError(f"settled_substep_s must be a number >= 0, got {coarse!r}")
        if coarse > 0:
            r1, r2 = self.step_s / coarse, coarse / self.attitude_substep_s
            if abs(r1 - round(r1)) > 1e-9 or abs(r2 - round(r2)) > 1e-9 or coarse < self.attitude_substep_s:
                raise ConfigError(
                    f"settled_substep_s ({coarse}) must be a multiple of attitude_substep_s "
                    f"({self.attitude_substep_s}) that divides step_s ({self.step_s}), or 0 to disable"
                )
        if int(self.episode_steps) != self.episode_steps or self.episode_steps < 1:
            raise ConfigError(f"episode_steps must be a positive integer, got {self.episode_steps!r}")
        if self.action_mode not in ACTION_MODES:
            raise ConfigError(f"action_mode must be one of {ACTION_MODES}, got {self.action_mode!r}")
        if self.measurement_model not in MODELS:
            raise ConfigError(f"measurement_model must be one of {MODELS}, got {self.measurement_model!r}")
        if self.reward not in REWARDS:
            raise ConfigError(f"reward must be one of {REWARDS}, got {self.reward!r}")
        if not (math.isfinite(self.torque_penalty) and self.torque_penalty >= 0):
            raise ConfigError(f"torque_penalty must be >= 0, got {self.torque_penalty!r}")
        scale = self.torque_action_scale
        if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not (0.0 < scale <= 1.0):
            raise ConfigError(f"torque_action_scale must be in (0, 1], got {scale!r}")
        if self.observation not in ("box", "dict"):
            raise ConfigError(f"observation must be 'box' or 'dict', got {self.observation!r}")
        if not isinstance(self.observe_in_field, bool):
            raise ConfigError(f"observe_in_field must be true or false, got {self.observe_in_field!r}")
        if self.noise_streams not in NOISE_STREAMS:
            raise ConfigError(f"noise_streams must be one of {NOISE_STREAMS}, got {self.noise_streams!r}")
        if self.star_tracker not in ("qmethod", "ideal"):
            raise ConfigError(f"star_tracker must be 'qmethod' or 'ideal', got {self.star_tracker!r}")
        if not (math.isfinite(self.star_tracker_sigma_arcsec) and self.star_tracker_sigma_arcsec >= 0):
            raise ConfigError(
                f"star_tracker_sigma_arcsec must be >= 0, got {self.star_tracker_sigma_arcsec!r}"
            )
        bias = tuple(self.star_tracker_bias_arcsec)
        if len(bias) != 3 or not all(isinstance(v, (int, float)) and math.isfinite(v) for v in bias):
            raise ConfigError(f"star_tracker_bias_arcsec must be 3 finite numbers, got {bias!r}")
        object.__setattr__(self, "star_tracker_bias_arcsec", tuple(float(v) for v in bias))
        names = []
        for name in self.pulsars:
            try:
                names.append(pulsar(name).bname)
            except PlanetNavError as exc:
                raise ConfigError(f"pulsars: {exc}") from None
        if len(set(names)) != len(names):
            raise ConfigError(f"pulsars must not repeat, got {list(self.pulsars)}")
        object.__setattr__(self, "pulsars", tuple(names))
        if names and self.action_mode != "target":
            raise ConfigError("pulsars (sensor tasking) need action_mode 'target'")
        _positive(self, "detector_fov_deg", "ambiguity_k_sigma", "approach_end_before_ca_h")
        if self.idle_action and self.action_mode != "target":
            raise ConfigError("idle_action is only available with action_mode 'target'")
        ops = self.operations
        if ops is not None:
            if not isinstance(ops, OperationsSettings):
                raise ConfigError(f"operations must be a mapping of settings or None, got {ops!r}")
            if self.action_mode != "target" or not self.idle_action or self.pulsars:
                raise ConfigError(
                    "operations needs action_mode 'target', idle_action true (its last action is 'stay at "
                    "the mission attitude') and no pulsars, got action_mode "
                    f"{self.action_mode!r}, idle_action {self.idle_action!r}, pulsars {list(self.pulsars)}"
                )

    @property
    def n_substeps(self) -> int:
        return round(self.step_s / self.attitude_substep_s)

    @property
    def n_planets(self) -> int:
        return len(self.planets)

    @property
    def n_pulsars(self) -> int:
        return len(self.pulsars)

    @property
    def n_targets(self) -> int:
        """Planets and pulsars: the discrete target actions (before the optional idle action)."""
        return len(self.planets) + len(self.pulsars)

    # ------------------------------------------------------------------------------------------
    @classmethod
    def from_dict(cls, data: Mapping[str, Any] | None = None, **overrides: Any) -> EnvConfig:
        """Build from a (YAML) mapping; nested ``camera``/``filter``/``attitude`` mappings allowed."""
        merged = dict(data or {})
        merged.update(overrides)
        known = {f.name: f for f in fields(cls)}
        kwargs: dict[str, Any] = {}
        for key, value in merged.items():
            if key not in known:
                # Worded as Python words a bad keyword, and a TypeError too: clients probe optional
                # keywords (TorchRL's GymEnv passes frameskip) and retry only on that error.
                hint = " (planetnav's name for it is 'episode_steps')" if key == "max_episode_steps" else ""
                raise UnknownOptionError(
                    f"unknown environment option: got an unexpected keyword argument {key!r}{hint}; "
                    f"known options: {sorted(known)}"
                )
            sub = _NESTED.get(key)
            if sub is not None and isinstance(value, Mapping):
                value = _build(sub, value, key)
            elif key in ("planets", "pulsars", "star_tracker_bias_arcsec"):
                if isinstance(value, str):
                    value = (value,)
                value = tuple(value)
            kwargs[key] = value
        try:
            return cls(**kwargs)
        except PlanetNavError as exc:
            raise ConfigError(str(exc)) from None
        except TypeError as exc:
            raise ConfigError(f"invalid environment option: {exc}") from None

    @classmethod
    def from_yaml(cls, path: str | Path) -> EnvConfig:
        """Load the ``env`` section of a YAML file (or the whole file if it has none)."""
        import yaml

        with open(path) as fh:
            data = yaml.safe_load(fh) or {}
        if not isinstance(data, Mapping):
            raise ConfigError(f"{path}: expected a mapping at the top level")
        return cls.from_dict(data.get("env", data))

    def to_dict(self) -> dict[str, Any]:
        """A plain mapping (YAML-serialisable) that :meth:`from_dict` turns back into this config."""
        out: dict[str, Any] = {}
        for f in fields(self):
            v = getattr(self, f.name)
            if dataclasses.is_dataclass(v):
                v = {
                    g.name: _plain(getattr(v, g.name))
                    for g in fields(v)
                    if g.init and not g.name.startswith("_")
                }
            out[f.name] = _plain(v)
        return out


_NESTED = {
    "camera": CameraConfig,
    "filter": FilterConfig,
    "attitude": AttitudeSettings,
    "detector": XrayDetector,
    "operations": OperationsSettings,
}


def _plain(v: Any) -> Any:
    if isinstance(v, tuple):
        return [_plain(x) for x in v]
    return v


def _build(cls: type, data: Mapping[str, Any], prefix: str) -> Any:
    known = {f.name for f in fields(cls) if f.init and not f.name.startswith("_")}
    for key in data:
        if key not in known:
            raise ConfigError(f"unknown option {prefix}.{key!r}; known: {sorted(known)}")
    kwargs = {
        k: (tuple(tuple(r) if isinstance(r, list) else r for r in v) if isinstance(v, list) else v)
        for k, v in data.items()
    }
    try:
        return cls(**kwargs)
    except PlanetNavError as exc:
        raise ConfigError(f"{prefix}: {exc}") from None


def _positive(obj: Any, *names: str, prefix: str = "") -> None:
    for name in names:
        v = getattr(obj, name)
        try:
            ok = math.isfinite(float(v)) and float(v) > 0
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise ConfigError(f"{prefix}{name} must be a positive finite number, got {v!r}")
