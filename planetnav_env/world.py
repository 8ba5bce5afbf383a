"""The world the truth is simulated in, apart from the onboard model the filter, the rules and the
observation use.

:class:`WorldConfig` is the ``world`` section of :class:`~planetnav_env.config.EnvConfig`. Its ``preset``
names a world; each effect has an option of its own, ``None`` to follow the preset or a value to set that
effect alone (a regime map's axis, or one effect's share of the flight world's error):

* ``"matched"`` (the default of every registered id): the truth is the onboard model. Every line of
  sight is geometric and instantaneous; the golden hashes of the ids are this world's.
* ``"flight"``: a truth that the onboard model only approximates, at flight-like magnitudes. Today it
  holds light time and stellar aberration on every line of sight, and the truth's own force model (every
  planet's point mass, cannonball SRP with a reflectivity drawn per episode) against the filter's
  (``docs/flight_world.md``), whose process noise is then tuned to what it omits. Two effects are modelled
  but off in both presets until a flight magnitude with a cited source joins: the centre-of-brightness
  centroid bias (``centroid_bias_max``) and the pulsar timing-model error (``pulsar_frequency_error_max``),
  each set on its own. The attitude loop of a flight world is in it too: disturbance torques (SRP from a
  centre-of-pressure offset, the central body's gravity gradient, the thrust's offset on the thrust arc),
  reaction wheels with friction and a speed limit, momentum dumps by thrusters with their delta-v error,
  and pointing from the estimate (a gyro with bias and random walk, an attitude filter fed by the star
  tracker). The other effects of a flight world (image-driven camera errors, oblate planets, a boresight
  drift, a newer ephemeris in truth) are not modelled yet and will join as options of this section.

On board, the filter applies the corrections flight optical navigation applies to each effect that is on
in truth, computed from its *estimated* state (``onboard_corrections``, default: on); switching them
off gives the filter that ignores the effect, the comparison that measures what it costs.

``EnvConfig(world="flight")``, ``gymnasium.make(id, world="flight")`` and YAML ``world: flight`` are
shorthand for ``world: {preset: flight}``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from planetnav_env.errors import OptionError, OptionTypeError
from planetnav_env.options import check_options, option

#: The world presets.
PRESETS = ("matched", "flight")

#: What ``EnvConfig.world`` accepts, as an error states it.
EXPECTED = (
    "one of 'matched', 'flight' (str), or a WorldConfig (in EnvConfig.from_dict / YAML a mapping of its "
    "options: preset, light_time, aberration, onboard_corrections, third_bodies, srp, area_to_mass_m2_kg, "
    "reflectivity_range, process_noise, centroid_bias_max, pulsar_frequency_error_max, cp_offset_m, "
    "srp_torque_area_m2, gravity_gradient, thrust_offset_m, wheel_coulomb_n_m, wheel_viscous_n_m_s, "
    "wheel_friction_compensation, wheel_inertia_kg_m2, wheel_speed_limit_rpm, momentum_dumping, "
    "dump_threshold_n_m_s, dump_lever_arm_m, "
    "mass_kg, dump_dv_error, dump_pointing_error_deg, dump_duration_s, gyro_bias_deg_h, "
    "gyro_rrw_deg_h_rt_h, gyro_arw_deg_rt_h, pointing_from_estimate)"
)

#: The flight preset's attitude magnitudes (docs/flight_world.md cites each): the centre-of-pressure offset
#: [m, body], the thrust line's offset from the centre of mass [m, body], Coulomb [N m] and viscous
#: [N m s] wheel friction, the wheel speed limit [rpm], the gyro's bias 1-sigma [deg/h], rate random walk
#: [deg/h/sqrt(h)] and angle random walk [deg/sqrt(h)].
FLIGHT_CP_OFFSET_M = (0.0, 0.02, 0.01)
FLIGHT_THRUST_OFFSET_M = (0.0, 0.001, 0.0)
FLIGHT_WHEEL_COULOMB_N_M = 1e-4
FLIGHT_WHEEL_VISCOUS_N_M_S = 2e-7
FLIGHT_WHEEL_SPEED_LIMIT_RPM = 6500.0
FLIGHT_GYRO_BIAS_DEG_H = 0.5
FLIGHT_GYRO_RRW_DEG_H_RT_H = 0.05
FLIGHT_GYRO_ARW_DEG_RT_H = 0.01
_DEG_H = math.radians(1.0) / 3600.0  # 1 deg/h in rad/s

#: The bodies of the ephemeris whose point masses act on the truth with third bodies on: every planet
#: DEEphemeris gives (the gas giants as their system barycentres, which hold their moons' mass), the Earth
#: and the Moon as two point masses (their barycentre is a point mass only far from them), and the Sun on
#: a planetary approach; the central body is left out.
GRAVITY_BODIES = ("sun", "mercury", "venus", "earth", "moon", "mars", "jupiter", "saturn")


def tuned_accel_psd(a_omit_km_s2: float, span_s: float, floor_km2_s3: float) -> float:
    """The filter's white-acceleration PSD q [km^2/s^3] for an omitted acceleration ``a_omit_km_s2``
    [km/s^2] over an episode of ``span_s`` [s]: q = a^2 T, whose velocity variance q T after T equals the
    omitted (a T)^2 (a position spread q T^3 / 3 against the bias's (a T^2 / 2)^2, the same order), and
    never below the configured ``floor_km2_s3`` (``filter.accel_psd``)."""
    return max(floor_km2_s3, a_omit_km_s2 * a_omit_km_s2 * span_s)


def truth_perturbers(central: str) -> tuple[str, ...]:
    """The truth's third bodies about ``central`` (every :data:`GRAVITY_BODIES` entry but it)."""
    return tuple(b for b in GRAVITY_BODIES if b != central)


@dataclass(frozen=True)
class WorldConfig:
    """The truth's world: a ``preset`` and its effects, each ``None`` (the preset's) or set on its own.

    The resolved values the core reads are :attr:`light_time_on`, :attr:`aberration_on`,
    :attr:`light_time_corrected`, :attr:`aberration_corrected`, :attr:`centroid_bias_bound` and
    :attr:`pulsar_frequency_error_bound`, and those of the attitude loop (:attr:`attitude_world_on`:
    :attr:`cp_offset`, :attr:`gravity_gradient_on`, :attr:`thrust_offset`, :attr:`wheel_coulomb`,
    :attr:`wheel_viscous`, :attr:`wheel_speed_limit_rad_s`, :attr:`dumping_on`, :meth:`dump_mass`,
    :attr:`gyro_bias_rad_s`, :attr:`gyro_rrw`, :attr:`gyro_arw`, :attr:`estimate_pointing_on`)."""

    preset: str = option(
        "matched",
        choices=PRESETS,
        doc="``matched``: the truth is the onboard model (every line of sight geometric and instantaneous). "
        "``flight``: a truth the onboard model only approximates: light time and stellar aberration on "
        "every line of sight (docs/flight_world.md). ``world: flight`` is shorthand for this option",
    )
    light_time: bool | None = option(
        None,
        kind="bool",
        doc="one-way light time in truth: the camera sees each planet where it was when the light left it "
        "(9-18 arcsec on the cruise). None: on in ``flight``, off in ``matched``",
    )
    aberration: bool | None = option(
        None,
        kind="bool",
        doc="stellar aberration in truth by the spacecraft's true heliocentric velocity, on the planets' and "
        "the star tracker's stars' directions (12-23 arcsec on the cruise). None: on in ``flight``, off in "
        "``matched``",
    )
    onboard_corrections: bool | None = option(
        None,
        kind="bool",
        doc="the filter corrects each effect that is on in truth, from its estimated state: the planet's "
        "light-time position from the estimated position, the predicted line of sight and the star "
        "catalogue aberrated by the estimated velocity. False: the filter ignores the effects (their "
        "bias). None: on",
    )

    centroid_bias_max: float | None = option(
        None,
        kind="float",
        ge=0,
        le=2,
        unit="fraction of the uniformly bright disk's offset",
        doc="centre-of-brightness centroid bias in truth, which the filter does not model (it takes the "
        "image's centroid for the centre of figure): at reset each planet draws a scale b uniformly from "
        "[0, centroid_bias_max], fixed for the episode and not observed, and every image of it is displaced "
        "toward the Sun by b * 4 / (3 pi) * (apparent radius) * (1 - cos phase angle), the offset of a "
        "uniformly bright illuminated disk (b = 1). 0: none (nothing is drawn). None: 0 in both presets",
    )
    pulsar_frequency_error_max: float | None = option(
        None,
        kind="float",
        ge=0,
        le=1e-6,
        unit="fractional frequency (delta nu / nu)",
        doc="pulsar timing-model error in truth, which the filter does not model (timing noise, or a glitch "
        "since the on-board model was fitted): at reset each pulsar draws the fractional error delta of the "
        "on-board spin frequency uniformly from [-pulsar_frequency_error_max, pulsar_frequency_error_max], "
        "fixed for the episode and not observed, and every phase of it is off by delta * (t - episode "
        "start) / period cycles, a range error of c * delta * (t - start) along the pulsar's direction "
        "(c * 1e-10 is ~10 km after 94 h). 0: none (nothing is drawn). None: 0 in both presets",
    )
    third_bodies: bool | None = option(
        None,
        kind="bool",
        doc="the truth's own force model: the point masses of every planet of the ephemeris (the Earth and "
        "the Moon apart, the gas giants' system barycentres; the Sun too on a planetary approach) in the "
        "central body's frame, direct minus indirect term. The filter keeps its own model (Sun-only on "
        "the cruises, the approach's Sun, Earth and Jupiter). None: on in ``flight``, off in ``matched``",
    )
    srp: bool | None = option(
        None,
        kind="bool",
        doc="cannonball solar radiation pressure in truth from ``area_to_mass_m2_kg`` and a reflectivity "
        "drawn per episode in ``reflectivity_range`` (heliocentric scenarios; not modelled on the Mars "
        "approach yet: there ``flight`` leaves it off and True is an error). The filter does not model "
        "it. None: on in ``flight``, off in ``matched``",
    )
    process_noise: str | None = option(
        None,
        kind="str",
        choices=("filter", "tuned"),
        doc="the filter's process noise: ``filter``, the white-acceleration PSD ``filter.accel_psd``; "
        "``tuned``, per episode q = max(accel_psd, a_omit^2 T) with a_omit the acceleration the filter's "
        "force model omits at the episode's initial state (the truth's third bodies and SRP at the top of "
        "``reflectivity_range``, minus the filter's) and T the episode's span (docs/flight_world.md). "
        "None: ``tuned`` when the truth flies its own force model, else ``filter``",
    )
    area_to_mass_m2_kg: float = option(
        0.01,
        unit="m^2/kg",
        gt=0.0,
        le=1.0,
        doc="the spacecraft's cross-section over its mass, for SRP (0.01: a 1,000 kg probe of 10 m^2)",
    )
    reflectivity_range: tuple[float, float] = option(
        (1.2, 1.5),
        kind="floats",
        length=2,
        ge=1.0,
        le=2.0,
        doc="[low, high] of the reflectivity coefficient C_R drawn uniformly per episode for SRP (1: "
        "absorbs all, 2: mirrors all back)",
    )
    # --- the attitude loop (docs/flight_world.md, "The attitude loop") ---------------------------------
    cp_offset_m: tuple[float, float, float] | None = option(
        None,
        kind="floats",
        length=3,
        unit="m (body)",
        doc="SRP torque's centre-of-pressure offset",
    )
    srp_torque_area_m2: float = option(2.0, gt=0.0, le=1000.0, unit="m^2", doc="SRP torque's sunlit area")
    gravity_gradient: bool | None = option(
        None, kind="bool", doc="the central body's gravity-gradient torque"
    )
    thrust_offset_m: tuple[float, float, float] | None = option(
        None,
        kind="floats",
        length=3,
        unit="m (body)",
        doc="thrust arc: the thrust line's offset",
    )
    wheel_coulomb_n_m: float | None = option(
        None,
        kind="float",
        ge=0.0,
        le=0.01,
        unit="N m",
        doc="wheel Coulomb friction",
    )
    wheel_viscous_n_m_s: float | None = option(
        None,
        kind="float",
        ge=0.0,
        le=1e-3,
        unit="N m s",
        doc="wheel viscous friction per rad/s",
    )
    wheel_friction_compensation: float = option(
        0.9,
        ge=0.0,
        le=1.0,
        unit="fraction",
        doc="friction share the drive cancels",
    )
    wheel_inertia_kg_m2: float = option(8e-4, gt=0.0, le=1.0, unit="kg m^2", doc="each wheel's axial inertia")
    wheel_speed_limit_rpm: float | None = option(
        None,
        kind="float",
        gt=0.0,
        le=1e5,
        unit="rpm",
        doc="wheel no-load speed (back EMF)",
    )
    momentum_dumping: bool | None = option(None, kind="bool", doc="momentum dumps by thrusters")
    dump_threshold_n_m_s: float = option(
        0.4, gt=0.0, unit="N m s", doc="dump threshold (below the wheel capacity)"
    )
    dump_lever_arm_m: float = option(0.5, gt=0.0, le=100.0, unit="m", doc="dump thrusters' lever arm")
    mass_kg: float | None = option(
        None,
        kind="float",
        gt=0.0,
        unit="kg",
        doc="mass a dump moves. None: operations.mass_kg, else srp_torque_area_m2 / area_to_mass_m2_kg",
    )
    dump_dv_error: float = option(0.05, ge=0.0, le=1.0, unit="fraction", doc="dump delta-v magnitude 1-sigma")
    dump_pointing_error_deg: float = option(
        2.0, ge=0.0, le=45.0, unit="deg", doc="dump delta-v direction 1-sigma per cross axis"
    )
    dump_duration_s: float = option(600.0, ge=0.0, unit="s", doc="thrust arc: engine-off time per dump")
    gyro_bias_deg_h: float | None = option(
        None,
        kind="float",
        ge=0.0,
        le=100.0,
        unit="deg/h",
        doc="gyro bias 1-sigma per axis",
    )
    gyro_rrw_deg_h_rt_h: float | None = option(
        None,
        kind="float",
        ge=0.0,
        le=10.0,
        unit="deg/h/sqrt(h)",
        doc="gyro rate random walk",
    )
    gyro_arw_deg_rt_h: float | None = option(
        None,
        kind="float",
        ge=0.0,
        le=10.0,
        unit="deg/sqrt(h)",
        doc="gyro angle random walk",
    )
    pointing_from_estimate: bool | None = option(
        None,
        kind="bool",
        doc="the PD law reads the attitude filter, not the truth",
    )

    def __post_init__(self) -> None:
        check_options(self, "world.")
        lo, hi = self.reflectivity_range
        if lo > hi:
            expected = "[low, high] with low <= high, each in [1, 2]"
            raise OptionError("world.reflectivity_range", expected, self.reflectivity_range)

    @classmethod
    def coerce(cls, value: Any) -> WorldConfig:
        """``value`` as a :class:`WorldConfig`: itself, or the preset a string names; else the named
        option error of ``world``."""
        if isinstance(value, WorldConfig):
            return value
        if isinstance(value, str):
            if value not in PRESETS:
                raise OptionError("world", EXPECTED, value)
            return cls(preset=value)
        raise OptionTypeError("world", EXPECTED, value)

    @property
    def flight(self) -> bool:
        return self.preset == "flight"

    @property
    def light_time_on(self) -> bool:
        """Light time in the truth's lines of sight."""
        return self.flight if self.light_time is None else self.light_time

    @property
    def aberration_on(self) -> bool:
        """Stellar aberration in the truth's lines of sight (planets and stars)."""
        return self.flight if self.aberration is None else self.aberration

    @property
    def corrections_on(self) -> bool:
        return True if self.onboard_corrections is None else self.onboard_corrections

    @property
    def light_time_corrected(self) -> bool:
        """The filter's model of a planet's direction uses its light-time position."""
        return self.light_time_on and self.corrections_on

    @property
    def aberration_corrected(self) -> bool:
        """The filter aberrates its predicted line of sight and the star catalogue by its velocity."""
        return self.aberration_on and self.corrections_on

    @property
    def centroid_bias_bound(self) -> float:
        """The largest centre-of-brightness scale a planet draws (0: no bias); neither preset sets one."""
        return 0.0 if self.centroid_bias_max is None else float(self.centroid_bias_max)

    @property
    def pulsar_frequency_error_bound(self) -> float:
        """The largest fractional frequency error |delta nu / nu| a pulsar's timing model draws (0: none);
        neither preset sets one."""
        return 0.0 if self.pulsar_frequency_error_max is None else float(self.pulsar_frequency_error_max)

    @property
    def third_bodies_on(self) -> bool:
        """Every planet's point mass in the truth's force model."""
        return self.flight if self.third_bodies is None else self.third_bodies

    @property
    def srp_on(self) -> bool:
        """Cannonball SRP in the truth's force model (where the scenario models it: see
        :meth:`srp_in`)."""
        return self.flight if self.srp is None else self.srp

    def srp_in(self, scenario: str) -> bool:
        """SRP in the truth on ``scenario`` (heliocentric scenarios only: the preset leaves it off on the
        Mars approach, where setting it is an error)."""
        return self.srp_on and scenario != "mars-approach"

    @property
    def truth_forces_on(self) -> bool:
        """The truth flies its own force model, apart from the filter's."""
        return self.third_bodies_on or self.srp_on

    @property
    def process_noise_tuned(self) -> bool:
        """The filter's process noise tuned per episode to what its force model omits."""
        if self.process_noise is None:
            return self.truth_forces_on
        return self.process_noise == "tuned"

    def _flight_or(self, value, flight_value, off_value):
        if value is not None:
            return value
        return flight_value if self.flight else off_value

    @property
    def cp_offset(self) -> tuple[float, float, float]:
        """The centre of pressure's offset [m, body] (zeros: no SRP torque)."""
        return tuple(self._flight_or(self.cp_offset_m, FLIGHT_CP_OFFSET_M, (0.0, 0.0, 0.0)))

    @property
    def srp_torque_on(self) -> bool:
        return any(v != 0.0 for v in self.cp_offset)

    @property
    def gravity_gradient_on(self) -> bool:
        return self.flight if self.gravity_gradient is None else self.gravity_gradient

    @property
    def thrust_offset(self) -> tuple[float, float, float]:
        """The thrust line's offset [m, body] on the thrust arc (zeros: no thrust torque)."""
        return tuple(self._flight_or(self.thrust_offset_m, FLIGHT_THRUST_OFFSET_M, (0.0, 0.0, 0.0)))

    @property
    def wheel_coulomb(self) -> float:
        return float(self._flight_or(self.wheel_coulomb_n_m, FLIGHT_WHEEL_COULOMB_N_M, 0.0))

    @property
    def wheel_viscous(self) -> float:
        return float(self._flight_or(self.wheel_viscous_n_m_s, FLIGHT_WHEEL_VISCOUS_N_M_S, 0.0))

    @property
    def wheel_speed_limit_rad_s(self) -> float:
        """The wheels' no-load speed [rad/s] (inf: no speed limit)."""
        rpm = self._flight_or(self.wheel_speed_limit_rpm, FLIGHT_WHEEL_SPEED_LIMIT_RPM, math.inf)
        return float(rpm) * 2.0 * math.pi / 60.0

    @property
    def dumping_on(self) -> bool:
        return self.flight if self.momentum_dumping is None else self.momentum_dumping

    def dump_mass(self, operations_mass_kg: float | None) -> float:
        """The mass [kg] a dump's impulse moves (see ``mass_kg``)."""
        if self.mass_kg is not None:
            return float(self.mass_kg)
        if operations_mass_kg is not None:
            return float(operations_mass_kg)
        return self.srp_torque_area_m2 / self.area_to_mass_m2_kg

    @property
    def gyro_bias_rad_s(self) -> float:
        """1-sigma of the gyro bias per axis [rad/s]."""
        return float(self._flight_or(self.gyro_bias_deg_h, FLIGHT_GYRO_BIAS_DEG_H, 0.0)) * _DEG_H

    @property
    def gyro_rrw(self) -> float:
        """Rate random walk [rad/s/sqrt(s)] (deg/h/sqrt(h) = _DEG_H / 60 rad/s/sqrt(s))."""
        return (
            float(self._flight_or(self.gyro_rrw_deg_h_rt_h, FLIGHT_GYRO_RRW_DEG_H_RT_H, 0.0)) * _DEG_H / 60.0
        )

    @property
    def gyro_arw(self) -> float:
        """Angle random walk [rad/sqrt(s)] (deg/sqrt(h) = pi/180 / 60 rad/sqrt(s))."""
        return (
            float(self._flight_or(self.gyro_arw_deg_rt_h, FLIGHT_GYRO_ARW_DEG_RT_H, 0.0))
            * math.radians(1.0)
            / 60.0
        )

    @property
    def estimate_pointing_on(self) -> bool:
        return self.flight if self.pointing_from_estimate is None else self.pointing_from_estimate

    @property
    def attitude_world_on(self) -> bool:
        """Any effect of the attitude loop is on (the row step then runs the flight world's sub-steps)."""
        return (
            self.srp_torque_on
            or self.gravity_gradient_on
            or any(v != 0.0 for v in self.thrust_offset)
            or self.wheel_coulomb > 0.0
            or self.wheel_viscous > 0.0
            or math.isfinite(self.wheel_speed_limit_rad_s)
            or self.dumping_on
            or self.gyro_bias_rad_s > 0.0
            or self.gyro_rrw > 0.0
            or self.gyro_arw > 0.0
            or self.estimate_pointing_on
        )

    @property
    def is_matched(self) -> bool:
        """No effect on: the truth is the onboard model (whatever the preset's name)."""
        return not (
            self.light_time_on
            or self.aberration_on
            or self.truth_forces_on
            or self.centroid_bias_bound > 0.0
            or self.pulsar_frequency_error_bound > 0.0
            or self.attitude_world_on
        )
