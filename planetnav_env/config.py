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
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from planetnav_env.astro.bodies import BODIES
from planetnav_env.astro.ephemeris import DEEphemeris
from planetnav_env.core.ephemeris_table import SEGMENT_S
from planetnav_env.errors import ConfigError, OptionError, PlanetNavError, UnknownOptionError
from planetnav_env.estimation.ekf import FilterConfig
from planetnav_env.estimation.measurements import MODELS
from planetnav_env.options import check_options, declared, option, option_table, replace_table, section
from planetnav_env.scenarios.approach import DEFAULT_CLOSEST_APPROACH_TDB
from planetnav_env.scenarios.episodes import CRUISE_EPOCH, RANDOM_EPOCHS
from planetnav_env.sensors.camera_config import CameraConfig
from planetnav_env.sensors.pulsar import XrayDetector, pulsar
from planetnav_env.world import WorldConfig

SCENARIOS = ("cruise", "random-cruise", "mars-approach")
ACTION_MODES = ("target", "torque", "target+torque", "hybrid")
REWARDS = ("truth", "covariance")
TARGET_ACTIONS = ("absolute", "relative")
#: How the env scales its observation: ``raw`` (each block's own scale, the v0-v2 observation) or ``unit``
#: (every column brought to order 1 by the fixed per-block constants of
#: :func:`planetnav_env.core.layout.unit_scaling`).
OBSERVATION_SCALINGS = ("raw", "unit")
NOISE_STREAMS = ("sequential", "per_step")


@dataclass(frozen=True)
class AttitudeSettings:
    """Spacecraft mass properties, wheels and the PD law (see :mod:`planetnav_env.attitude.pointing`)."""

    inertia: tuple[float, float, float] = option(
        (10.0, 12.0, 8.0), kind="floats", length=3, gt=0, unit="kg m^2", doc="principal moments of inertia"
    )
    wheel_torque_limit: float = option(0.01, gt=0, unit="N m", doc="torque limit of each reaction wheel")
    wheel_momentum_capacity: float = option(0.5, gt=0, unit="N m s", doc="momentum capacity of each wheel")
    k_a: float = option(0.02, gt=0, unit="N m", kernel="k_a", doc="PD pointing law: angle gain")
    k_w: float = option(1.0, gt=0, unit="N m s", kernel="k_w", doc="PD pointing law: rate gain")
    rate_noise_deg_s: float = option(1e-4, ge=0, unit="deg/s", doc="1-sigma of the reported body rates")

    def __post_init__(self) -> None:
        check_options(self, "attitude.")


#: Most knowledge deadlines an operations scenario may list (the core keeps one slot per deadline).
MAX_DEADLINES = 8


@dataclass(frozen=True)
class OperationsSettings:
    """A navigation-operations scenario: a mission attitude that imaging interrupts, and knowledge
    deadlines. ``None`` in :attr:`EnvConfig.operations` is the plain cruise.

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

    thrust_n: float = option(0.092, gt=0, unit="N", doc="engine thrust T")
    mass_kg: float = option(486.0, gt=0, unit="kg", doc="spacecraft mass m (constant)")
    thrust_mag_sigma: float = option(0.02, ge=0, unit="fraction of a", doc="1-sigma thrust magnitude error")
    thrust_point_sigma_deg: float = option(
        1.0, ge=0, unit="deg", doc="1-sigma thrust pointing error per cross axis"
    )
    thrust_corr_time_s: float = option(
        86400.0, gt=0, unit="s", doc="correlation time of the execution errors (first-order Gauss-Markov)"
    )
    attitude_tolerance_deg: float = option(
        1.0, gt=0, lt=90, unit="deg", doc="the engine thrusts while the thrust axis is this close to u"
    )
    deadlines_s: tuple[float, ...] = option(
        (604800.0, 1382400.0, 1684800.0),
        kind="floats",
        length=(1, MAX_DEADLINES),
        gt=0,
        unit="s from episode start",
        doc="knowledge deadlines (TCM epochs), strictly increasing, each at most encounter_s",
    )
    encounter_s: float = option(
        1814400.0, gt=0, kernel="ops_encounter", unit="s from episode start", doc="encounter epoch E"
    )
    cost_weight: float = option(
        129.6, ge=0, kernel="ops_weight", unit="km per m/s", doc="exchange rate w of delta-v lost in J"
    )

    def __post_init__(self) -> None:
        check_options(self, "operations.")
        dl = self.deadlines_s
        if not all(v <= self.encounter_s for v in dl) or any(b <= a for a, b in itertools.pairwise(dl)):
            raise ConfigError(
                "operations.deadlines_s must be strictly increasing epochs in (0, encounter_s = "
                f"{self.encounter_s}] s, got {list(dl)}"
            )

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


#: Options of the world (planetnav_env.world.WorldConfig) that a top-level key's error points to.
WORLD_OPTIONS_NAMED = ("centroid_bias_max", "pulsar_frequency_error_max")


def _unknown_option_hint(key: str) -> str:
    """What the error of the unknown top-level option ``key`` adds: the option to set instead, if any."""
    if key == "max_episode_steps":
        return " (planetnav's name for it is 'episode_steps')"
    if key in WORLD_OPTIONS_NAMED:
        return f" (an effect of the world: set world.{key}, in YAML 'world: {{{key}: ...}}')"
    return ""


@dataclass(frozen=True)
class EnvConfig:
    """Everything that defines an episode. Units: s, km, rad unless the name says otherwise.

    Each option is declared once, below, with its type, unit, range and description
    (:func:`planetnav_env.options.option`); ``docs/environment.md`` ("Options") holds the table generated
    from these declarations. ``__post_init__`` checks each option against its declaration, then the rules
    that tie several together (sub-steps that divide the step, an episode inside the ephemeris, the
    modes that operations and pulsars need).
    """

    scenario: str = option(
        "cruise",
        choices=SCENARIOS,
        doc="``cruise`` (the thesis's Venus-to-Mars transfer from 2020-08-01, fixed), ``random-cruise`` "
        "(epoch, transfer arc and initial estimate error drawn from the reset seed) or ``mars-approach`` "
        "(the patent's case: Mars-centred dynamics with Sun, Earth and Jupiter perturbations; the episode "
        "ends ``approach_end_before_ca_h`` before closest approach)",
    )
    planets: tuple[str, ...] = option(
        ("venus", "mars", "earth"),
        kind="strs",
        length=(1, None),
        doc="bodies the camera may target, no repeats, any of planetnav_env.astro.bodies but the Sun "
        "(their order is the action index)",
    )
    step_s: float = option(
        60.0,
        gt=0,
        unit="s",
        kernel="step_s",
        doc="environment step. Its upper bound depends on scenario and episode_steps: the episode's "
        "ephemeris table, (episode_steps + 1) steps rounded up to whole table segments, must lie inside "
        "the DE421 ephemeris from every start epoch the scenario draws (the error names the bound)",
    )
    attitude_substep_s: float = option(
        1.0, gt=0, unit="s", kernel="substep_s", doc="attitude integration step (must divide step_s)"
    )
    settled_substep_s: float = option(
        10.0,
        ge=0,
        unit="s",
        kernel="coarse_s",
        doc="the attitude step while a held target is already settled (pointing error below 1e-4 rad, "
        "rates below 1e-5 rad/s, PD law only): the closed loop is then near equilibrium and coarse steps "
        'follow the 1 s integration within 1" (median 0.1", far below the star tracker\'s 1.4" per axis) '
        "and leave the estimate within 1 m (tested), at a tenth of the cost. Must be a multiple of "
        "attitude_substep_s that divides step_s; 0 disables it",
    )
    episode_steps: int = option(
        1440, ge=1, unit="steps", kernel="episode_steps", doc="steps before truncation"
    )
    action_mode: str = option(
        "target",
        choices=ACTION_MODES,
        doc="see PlanetNavEnv; ``hybrid``: each step either the PD law slews to a planet or the agent's "
        "torque drives the wheels",
    )
    measurement_model: str = option(
        "los+size", choices=MODELS, doc="filter model (planetnav_env.estimation.measurements.MODELS)"
    )
    reward: str = option(
        "truth",
        choices=REWARDS,
        doc="``truth`` (-|r_est - r_true| / reward_scale_km, privileged) or ``covariance`` "
        "(-sqrt(trace P_rr) / reward_scale_km, computable on board). With ``operations`` the reward is the "
        "objective's increment instead, -(w * delta-v lost this step + the deadline terms reached this step) "
        "/ reward_scale_km (summing to -J / reward_scale_km), and this option picks the deadline term: the "
        "true error mapped to the encounter (``truth``) or its 1-sigma the filter predicts (``covariance``)",
    )
    reward_scale_km: float = option(1000.0, gt=0, unit="km", kernel="reward_scale", doc="reward scale")
    reward_baseline_km: tuple[float, ...] = option(
        (),
        kind="floats",
        unit="km",
        doc="a baseline that depends on time only, subtracted from each physics step's error term before "
        "the scale: the reward becomes -(e_k - b(k)) / reward_scale_km, e_k the step's error (or, with "
        "``operations``, the objective's increment), b the entry of physics step k when the L entries "
        "split the episode's ``episode_steps`` physics steps into L equal bins (entry floor((k - 1) L / "
        "episode_steps) for k = 1..episode_steps). Its sum over an episode is a constant, so the optimal "
        "policy is unchanged, and the return measures what the policy controls instead of the error's "
        "decay. Empty: no baseline (the v0-v2 reward)",
    )
    torque_penalty: float = option(
        0.0, ge=0, kernel="torque_penalty", doc="reward penalty per squared commanded torque fraction"
    )
    torque_action_scale: float = option(
        1.0,
        gt=0,
        le=1,
        unit="fraction of the wheel torque limit",
        kernel="torque_scale",
        doc="the torque a torque action of 1 commands (``torque``, ``target+torque`` modes). The agent's "
        "torque is held for a whole step, so a pointing law needs torques of ~1e-3 of the limit while a "
        "slew needs ~1e-1: a smaller scale gives a learner's [-1, 1] outputs that resolution, at the cost "
        "of slower slews (0.02: a 90-degree slew takes ~10 steps). Agents convert with it "
        "(``TargetAgent.torque_toward``)",
    )
    divergence_km: float = option(
        1.0e5, gt=0, unit="km", kernel="divergence", doc="the episode terminates when the true position "
        "error exceeds it"
    )  # fmt: skip
    observation: str = option("box", choices=("box", "dict"), doc="``box`` (flat float32) or ``dict``")
    observe_in_field: bool = option(
        False,
        doc="add the ``in_field`` block to the observation (last, one 0/1 per planet: the camera's "
        "visibility rule passes for it at the current star-tracker attitude and estimated position; "
        "``ObservationLayout``). Off by default, so existing ids keep their observation",
    )
    idle_action: bool = option(
        False,
        doc='add a last discrete action "camera off" (for the idle floor agent); with ``operations`` it '
        'is "stay at the mission attitude" (the engine thrusts). Needs action_mode ``target``',
    )
    decision_steps: int = option(
        1,
        ge=1,
        unit="steps",
        kernel="decision_steps",
        doc="physics steps per environment step: the action is held that long and the rewards summed, so one "
        "decision spans ``decision_steps * step_s`` seconds while the physics step stays ``step_s``. An "
        "episode that ends inside a decision ends it; ``episode_steps`` still counts physics steps (the "
        "spec's ``max_episode_steps`` counts decisions)",
    )
    target_actions: str = option(
        "absolute",
        choices=TARGET_ACTIONS,
        doc="``absolute``: action k points at target k; ``relative``: 0 keeps the current target and k moves "
        "k places along the target order (planets, then pulsars; from target 0 after a reset). Needs "
        "action_mode ``target`` and no idle_action",
    )
    observation_scaling: str = option(
        "raw",
        choices=OBSERVATION_SCALINGS,
        doc="``raw``: each block in its own scale (the table of ``ObservationLayout``); ``unit``: every "
        "column c written as (value - offset_c) / scale_c with fixed constants per block and scenario "
        "(``planetnav_env.core.layout.unit_scaling``, docs/tasks_v3.md), so a learner sees values of order "
        "1. Part of the decision interface: the rule agents read the raw observation",
    )
    observe_since_measured: bool = option(
        False,
        doc="add the ``since_measured`` block to the observation (last, one per target: log1p(physics steps "
        "since that target was last measured) / log1p(1440), capped at 1; 1 when not measured this "
        "episode). What the spacecraft knows of its own history, which the filter snapshot does not hold",
    )
    image_success_min: float = option(
        1.0,
        ge=0,
        le=1,
        unit="probability",
        kernel="img_min",
        doc="image-processing failures the filter does not model (stray light, faint or low-contrast "
        "beacons): at reset each planet draws the probability that an image of it in view yields a fix, "
        "uniformly from [image_success_min, 1], fixed for the episode and not observed; an image that fails "
        "gives no measurement (``info['visibility']`` ``image_failed``). 1: every image succeeds (the v0 and "
        "v1 physics; nothing is drawn)",
    )
    prior_long_sigma_km: float = option(
        0.0,
        ge=0,
        unit="km",
        doc="the prior's shape after a navigation history that left one direction poorly known (e.g. the "
        "range along the line of sight of the beacon it used, or the along-track error of an aged orbit "
        "determination): at reset a direction is drawn uniformly on the sphere, the position prior's "
        "1-sigma along it is prior_long_sigma_km (across it stays filter.sigma_pos0), and the initial "
        "estimate error is drawn from that covariance. The filter starts from it (it is its P0, not an "
        "unmodelled event), so a rule that reads P sees which way the error lies. 0: the spherical prior of "
        "filter.sigma_pos0 (the v0 and v1 physics; nothing is drawn); else at least filter.sigma_pos0",
    )
    observe_momentum: bool = option(
        False,
        doc="add the ``momentum`` block to the observation (last, four values: the largest wheel momentum "
        "over the dump threshold, then the total angular momentum in inertial axes / wheel capacity), so "
        "that a policy can plan around momentum dumps (world.momentum_dumping)",
    )
    observe_position_correlation: bool = option(
        False,
        doc="add the ``position_correlation`` block to the observation (last, three values: the "
        "correlation coefficients rho_xy, rho_xz, rho_yz of the filter's position covariance; with "
        "``log_sigma`` they give the whole P_rr, which way the position error lies, as a rule reading "
        "``info['filter']['P']`` sees it)",
    )
    observe_residual_log: bool = option(
        False,
        doc="add the ``residual_log`` block to the observation (last, one per target, planets then pulsars: "
        "the mean normalized NIS of this episode's fixes of it, with a prior of two consistent ones, capped "
        "at 10, / 10): the filter's own consistency check per beacon. Kept although no id sets it: when the "
        "world's truth departs from the onboard model (``world``), the filter's residuals are what a policy "
        "can read of the departure",
    )
    observe_image_log: bool = option(
        False,
        doc="add the ``image_log`` block to the observation (last, two per planet: (fixes + 1) / (images "
        "+ 2) and log1p(images) / log1p(1440), over this episode's images of it in view): what the "
        "spacecraft knows of its own image processing",
    )
    star_tracker: str = option(
        "qmethod",
        choices=("qmethod", "ideal"),
        doc="``qmethod`` (q-method fix from the synthetic sky each step) or ``ideal``",
    )
    star_tracker_sigma_arcsec: float = option(
        1.5,
        ge=0,
        unit="arcsec",
        doc="attitude error per axis the filter assumes on top of the camera's direction noise (the star "
        "tracker's error rotates every measured line of sight). The star fix comes from the camera's own "
        'field (5" per star, ~15 stars): its error across the boresight measures 1.4" per axis',
    )
    star_tracker_bias_arcsec: tuple[float, float, float] = option(
        (0.0, 0.0, 0.0),
        kind="floats",
        length=3,
        unit="arcsec",
        doc="a fixed misalignment of the attitude fix, a small rotation vector in body axes composed with "
        "every fix (``q_est = q_fix * q_bias``); the filter does not know it. For studying how attitude "
        "errors reach navigation",
    )
    noise_streams: str = option(
        "sequential",
        choices=NOISE_STREAMS,
        doc="how sensor noise is drawn from the episode seed. ``sequential``: one stream per episode, "
        "consumed in the order the sensors ask. ``per_step``: each sensor's noise at step k comes from "
        "its own stream keyed by (episode seed, k, sensor) (``planetnav_env.core.rng.substream``): two "
        "policies run on the same seed see the same noise whenever they make the same measurement at the "
        "same step, so their paired difference measures the policies rather than two noise draws "
        "(``train.py compare --noise-streams per_step``). Same distribution either way",
    )
    pulsars: tuple[str, ...] = option(
        (),
        kind="strs",
        doc="X-ray pulsars the detector may target (names or B names of planetnav_env.sensors.pulsar), "
        "after the planets in the action index; need action_mode ``target``",
    )
    detector_fov_deg: float = option(2.0, gt=0, unit="deg", doc="X-ray detector field of view (full angle)")
    ambiguity_k_sigma: float = option(
        3.0, gt=0, kernel="ambig_k", doc="k-sigma threshold above which a pulsar phase is ambiguous (skipped)"
    )
    approach_end_before_ca_h: float = option(
        2.0, gt=0, unit="h", doc="``mars-approach``: the episode ends this long before closest approach"
    )
    camera: CameraConfig = section(CameraConfig, doc="star camera (docs/camera.md)")
    filter: FilterConfig = section(FilterConfig, doc="navigation filter (docs/filter.md)")
    attitude: AttitudeSettings = section(AttitudeSettings, doc="mass properties, wheels, PD law")
    detector: XrayDetector = section(XrayDetector, doc="X-ray timing detector (pulsars)")
    operations: OperationsSettings | None = section(
        OperationsSettings,
        optional=True,
        doc="thrust arc and knowledge deadlines (the ThrustArc-TCM-v0 scenario), or None: no mission "
        "attitude, the reward above. Needs action_mode ``target``, idle_action true and no pulsars",
    )
    world: WorldConfig = section(
        WorldConfig,
        doc="the world the truth is simulated in, apart from the onboard model (planetnav_env.world, "
        "docs/flight_world.md): a preset and its effects. ``world: flight`` (a preset's name) is shorthand "
        "for ``world: {preset: flight}``",
    )

    def __post_init__(self) -> None:
        object.__setattr__(self, "world", WorldConfig.coerce(self.world))  # a preset's name is shorthand
        check_options(self, "")
        planets = tuple(p.lower() for p in self.planets)
        for p in planets:
            if p not in BODIES or p == "sun":
                raise ConfigError(
                    f"planets: unknown or unusable body {p!r}; choose from {sorted(set(BODIES) - {'sun'})}"
                )
        if len(set(planets)) != len(planets):
            raise ConfigError(f"planets must not repeat, got {list(planets)}")
        object.__setattr__(self, "planets", planets)
        if 0.0 < self.prior_long_sigma_km < self.filter.sigma_pos0:
            raise ConfigError(
                f"prior_long_sigma_km must be 0 (a spherical prior) or at least filter.sigma_pos0 "
                f"({self.filter.sigma_pos0} km), got {self.prior_long_sigma_km}"
            )
        _check_ephemeris_span(self)
        if self.world.dumping_on and self.world.dump_threshold_n_m_s >= self.attitude.wheel_momentum_capacity:
            raise OptionError(
                "world.dump_threshold_n_m_s",
                f"a momentum below attitude.wheel_momentum_capacity ({self.attitude.wheel_momentum_capacity} "
                "N m s) with momentum dumping on",
                self.world.dump_threshold_n_m_s,
            )
        ratio = self.step_s / self.attitude_substep_s
        if abs(ratio - round(ratio)) > 1e-9:
            raise ConfigError(
                f"attitude_substep_s ({self.attitude_substep_s}) must divide step_s ({self.step_s}) exactly"
            )
        coarse = self.settled_substep_s
        if coarse > 0:
            r1, r2 = self.step_s / coarse, coarse / self.attitude_substep_s
            if abs(r1 - round(r1)) > 1e-9 or abs(r2 - round(r2)) > 1e-9 or coarse < self.attitude_substep_s:
                raise ConfigError(
                    f"settled_substep_s ({coarse}) must be a multiple of attitude_substep_s "
                    f"({self.attitude_substep_s}) that divides step_s ({self.step_s}), or 0 to disable"
                )
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
        if self.idle_action and self.action_mode != "target":
            raise ConfigError("idle_action is only available with action_mode 'target'")
        if self.target_actions == "relative" and (self.action_mode != "target" or self.idle_action):
            raise ConfigError(
                "target_actions 'relative' needs action_mode 'target' and idle_action false, got action_mode "
                f"{self.action_mode!r}, idle_action {self.idle_action!r}"
            )
        ops_ready = self.action_mode == "target" and self.idle_action and not self.pulsars
        if self.operations is not None and not ops_ready:
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

    def at_physics_step(self) -> EnvConfig:
        """This configuration with the decision interface at its defaults (one physics step per decision,
        absolute target actions, no ``since_measured`` block, the raw observation): the same physics, seeds
        and objective, in the interface the rule agents act through (a ``-v1`` id's references run there)."""
        interface = (
            self.decision_steps,
            self.target_actions,
            self.observe_since_measured,
            self.observation_scaling,
        )
        if interface == (1, "absolute", False, "raw"):
            return self
        return dataclasses.replace(
            self, decision_steps=1, target_actions="absolute", observe_since_measured=False,
            observation_scaling="raw",
        )  # fmt: skip

    @property
    def episode_decisions(self) -> int:
        """Environment steps (decisions) of a full episode: ``episode_steps`` physics steps in holds of
        ``decision_steps``, the last one possibly shorter."""
        return -(-self.episode_steps // self.decision_steps)

    @property
    def n_targets(self) -> int:
        """Planets and pulsars: the discrete target actions (before the optional idle action)."""
        return len(self.planets) + len(self.pulsars)

    @property
    def n_target_actions(self) -> int:
        """The target mode's ``Discrete`` actions: the targets, and no target with ``idle_action``."""
        return self.n_targets + (1 if self.idle_action else 0)

    # ------------------------------------------------------------------------------------------
    @classmethod
    def from_dict(cls, data: Mapping[str, Any] | None = None, **overrides: Any) -> EnvConfig:
        """Build from a (YAML) mapping; nested ``camera``/``filter``/``attitude``/``world`` mappings allowed.

        An override of a section given as a mapping updates that section of ``data`` key by key, as
        ``gym.make(id, filter={"accel_psd": q})`` means: it changes ``accel_psd`` and keeps the id's other
        filter options (its prior, say). Over a preset's name (``world: flight``) it is that preset with
        the keys given. Any other override replaces ``data``'s value."""
        merged = dict(data or {})
        for key, value in overrides.items():
            merged[key] = _override(key, merged.get(key), value)
        known = {f.name: f for f in fields(cls)}
        kwargs: dict[str, Any] = {}
        for key, value in merged.items():
            if key not in known:
                # Worded as Python words a bad keyword, and a TypeError too: clients probe optional
                # keywords (TorchRL's GymEnv passes frameskip) and retry only on that error.
                hint = _unknown_option_hint(key)
                raise UnknownOptionError(
                    f"unknown environment option: got an unexpected keyword argument {key!r}{hint}; "
                    f"known options: {sorted(known)}"
                )
            sub = _SECTIONS.get(key)
            if sub is not None and isinstance(value, Mapping):
                value = _build(sub, value, key)
            kwargs[key] = value
        try:
            return cls(**kwargs)
        except ConfigError:
            raise  # OptionError and the cross-option rules already name the option
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


#: The nested settings records (``camera``: CameraConfig, ...), from their declarations.
_SECTIONS = {name: opt.section for name, opt in declared(EnvConfig) if opt.kind == "section"}


def _override(key: str, base: Any, value: Any) -> Any:
    """``value`` over ``base`` for option ``key`` (:meth:`EnvConfig.from_dict`): a section's mapping
    updates a mapping or a preset's name; anything else replaces."""
    if key not in _SECTIONS or not isinstance(value, Mapping):
        return value
    if isinstance(base, Mapping):
        return {**base, **value}
    if isinstance(base, str):  # a preset's name is shorthand for {preset: name}
        return {"preset": base, **value}
    return value


def _plain(v: Any) -> Any:
    if isinstance(v, tuple):
        return [_plain(x) for x in v]
    return v


def _build(cls: type, data: Mapping[str, Any], prefix: str) -> Any:
    known = {f.name for f in fields(cls) if f.init and not f.name.startswith("_")}
    for key in data:
        if key not in known:
            raise ConfigError(f"unknown option {prefix}.{key!r}; known: {sorted(known)}")
    try:
        return cls(**data)
    except ConfigError:
        raise  # OptionError: already named by its dotted path
    except PlanetNavError as exc:
        raise ConfigError(f"{prefix}: {exc}") from None


def _check_ephemeris_span(cfg: EnvConfig) -> None:
    """Raise a ConfigError naming step_s and its bound when an episode of ``cfg`` would reach outside the
    DE421 ephemeris (the first reset would fail on an ephemeris time deep in the core instead).

    The row's ephemeris table spans (episode_steps + 1) steps rounded up to whole table segments
    (``TableSpec.for_duration``), from every start epoch the scenario can draw; the bound is found by
    bisection on :meth:`DEEphemeris.covers`, the test the ephemeris itself applies.
    """
    n = cfg.episode_steps + 1

    def window(step_s: float) -> tuple[float, float]:
        span = max(1, math.ceil(n * step_s / SEGMENT_S)) * SEGMENT_S
        if cfg.scenario == "mars-approach":
            start = DEFAULT_CLOSEST_APPROACH_TDB - cfg.approach_end_before_ca_h * 3600.0 - n * step_s
            return start, start + span
        first, last = (CRUISE_EPOCH, CRUISE_EPOCH) if cfg.scenario == "cruise" else RANDOM_EPOCHS
        return first, last + span

    eph = DEEphemeris()
    if eph.covers(np.array(window(cfg.step_s))):
        return
    lo, hi = 0.0, float(cfg.step_s)
    for _ in range(60):  # the largest step whose window the ephemeris covers, to 1e-18 of step_s
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if eph.covers(np.array(window(mid))) else (lo, mid)
    bound = math.floor(lo * 1000.0) / 1000.0  # rounded down: the bound itself must pass
    raise OptionError(
        "step_s",
        f"a finite number (float, s) in (0, {bound!r}] for scenario {cfg.scenario!r} and episode_steps "
        f"{cfg.episode_steps} (the episode must lie inside the DE421 ephemeris)",
        cfg.step_s,
    )


#: The generated option tables of the docs: the page (from the repository root) -> its table. The world's
#: options have a page of their own (they outgrew environment.md's size limit).
OPTION_PAGES = {
    "docs/environment.md": lambda: option_table(EnvConfig, elsewhere={"world": "world_options.md"}),
    "docs/world_options.md": lambda: option_table(WorldConfig, prefix="world."),
}


if __name__ == "__main__":  # python -m planetnav_env.config: rewrite the docs' option tables
    root = Path(__file__).resolve().parents[1]
    for page, table in OPTION_PAGES.items():
        doc = root / page
        doc.write_text(replace_table(doc.read_text(), table()))
