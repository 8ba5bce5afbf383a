"""The world the truth is simulated in, apart from the onboard model the filter, the rules and the
observation use.

:class:`WorldConfig` is the ``world`` section of :class:`~planetnav_env.config.EnvConfig`. Its ``preset``
names a world; each effect has an option of its own, ``None`` to follow the preset or a value to set that
effect alone (a regime map's axis, or one effect's share of the flight world's error):

* ``"matched"`` (the default of every registered id): the truth is the onboard model. Every line of
  sight is geometric and instantaneous; the golden hashes of the ids are this world's.
* ``"flight"``: a truth that the onboard model only approximates, at flight-like magnitudes. Today it
  holds light time and stellar aberration on every line of sight; the truth's own force model (every
  planet's point mass, cannonball SRP with a reflectivity drawn per episode, on every scenario) against
  the filter's (``docs/flight_world.md``), whose process noise is then tuned to what it omits; a newer
  ephemeris in truth (DE440) than on board (DE421); the thrust arc's execution error as its documented
  first-order Gauss-Markov process; the pulsars' Shapiro delay in the arrival times; and the camera's
  truth: errors from the image (``image_errors``: centroid and diameter sigmas from the disk's size in
  pixels and the image's SNR), the Lambertian centre-of-brightness offset at the true phase with an
  onboard photometric correction of a scale error drawn per episode (``lambert_cob``), oblate planets
  (``oblate_planets``) and a Gauss-Markov boresight drift of the planet camera (``boresight_drift``).
  Two effects are modelled but off in both presets: the uniform-disk centroid bias the filter does not
  correct (``centroid_bias_max``, for regime maps) and the pulsar timing-model error
  (``pulsar_frequency_error_max``), each set on its own. The attitude loop of a flight world is in
  it too: disturbance torques (SRP from a centre-of-pressure offset, the central body's gravity gradient,
  the thrust's offset on the thrust arc), reaction wheels with friction and a speed limit, momentum dumps
  by thrusters with their delta-v error, and pointing from the estimate (a gyro with bias and random walk,
  an attitude filter fed by the star tracker).

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
    "reflectivity_range, process_noise, truth_ephemeris, thrust_gauss_markov, pulsar_shapiro, "
    "image_errors, centroid_floor_px, limb_scatter, aperture_mm, exposure_s, full_well_e, read_noise_e, "
    "psf_sigma_px, lambert_cob, cob_model_error, oblate_planets, boresight_drift, drift_sigma_arcsec, "
    "drift_tau_s, centroid_bias_max, pulsar_frequency_error_max, cp_offset_m, "
    "srp_torque_area_m2, gravity_gradient, thrust_offset_m, wheel_coulomb_n_m, wheel_viscous_n_m_s, "
    "wheel_friction_compensation, wheel_inertia_kg_m2, wheel_speed_limit_rpm, momentum_dumping, "
    "dump_threshold_n_m_s, dump_lever_arm_m, "
    "mass_kg, dump_dv_error, dump_pointing_error_deg, dump_duration_s, gyro_bias_deg_h, "
    "gyro_rrw_deg_h_rt_h, gyro_arw_deg_rt_h, pointing_from_estimate")

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

#: The JPL ephemerides the truth can follow (``truth_ephemeris``); the onboard model always carries DE421.
EPHEMERIDES = ("de421", "de440")

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
    :attr:`light_time_corrected`, :attr:`aberration_corrected`, :attr:`third_bodies_on`, :attr:`srp_on`,
    :attr:`truth_ephemeris_name`, :attr:`thrust_gauss_markov_on`, :attr:`shapiro_on`,
    :attr:`shapiro_corrected`, :attr:`process_noise_tuned`, :attr:`centroid_bias_bound`,
    :attr:`pulsar_frequency_error_bound`, :attr:`image_errors_on`, :attr:`lambert_cob_on`,
    :attr:`lambert_cob_corrected`, :attr:`oblate_on` and :attr:`drift_on` (with the camera effects'
    parameters as set), and those of the attitude loop (:attr:`attitude_world_on`: :attr:`cp_offset`,
    :attr:`gravity_gradient_on`, :attr:`thrust_offset`, :attr:`wheel_coulomb`, :attr:`wheel_viscous`,
    :attr:`wheel_speed_limit_rad_s`, :attr:`dumping_on`, :meth:`dump_mass`, :attr:`gyro_bias_rad_s`,
    :attr:`gyro_rrw`, :attr:`gyro_arw`, :attr:`estimate_pointing_on`)."""

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
        doc="a uniformly bright disk's centre-of-brightness bias in truth, uncorrected (docs/camera.md): "
        "each planet draws a scale b uniformly in [0, centroid_bias_max] per episode, its images move toward "
        "the Sun by b 4 / (3 pi) R (1 - cos phase). 0: none (nothing drawn). None: 0 in both presets",
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
    image_errors: bool | None = option(
        None,
        kind="bool",
        doc="camera errors from the image in truth: centroid and diameter sigmas from the disk's size [px] "
        "and the image's SNR (sensors/image_noise.py); the filter keeps its R. None: on in ``flight``",
    )
    centroid_floor_px: float = option(
        0.05, unit="px", ge=0.0, le=1.0, doc="image errors: a bright point image's centroid sigma per axis"
    )
    limb_scatter: float = option(
        1e-3, unit="-", ge=0.0, le=0.1, doc="image errors: centroid sigma / diameter of a resolved disk"
    )
    aperture_mm: float = option(10.0, unit="mm", gt=0.0, le=1000.0, doc="image errors: the camera's aperture")
    exposure_s: float = option(
        0.1,
        unit="s",
        gt=0.0,
        le=1000.0,
        doc="image errors: the longest exposure",
    )
    full_well_e: float = option(20000.0, unit="e-", gt=0.0, le=1e7, doc="image errors: a pixel's full well")
    read_noise_e: float = option(10.0, unit="e-", ge=0.0, le=1e4, doc="image errors: read noise per pixel")
    psf_sigma_px: float = option(
        0.7, unit="px", gt=0.0, le=10.0, doc="image errors: the PSF's Gaussian sigma"
    )
    lambert_cob: bool | None = option(
        None,
        kind="bool",
        doc="a Lambertian sphere's centre-of-brightness offset in truth at the true phase; on board "
        "a photometric model takes it off at the estimated geometry, scaled by 1 + e drawn per planet and "
        "episode. None: on in ``flight``",
    )
    cob_model_error: float = option(
        0.05,
        unit="-",
        ge=0.0,
        le=1.0,
        doc="the bound of e (uniform)",
    )
    oblate_planets: bool | None = option(
        None,
        kind="bool",
        doc="planets are spheroids in truth (the limb-fit size at the true sub-camera latitude), spheres on "
        "board. None: on in ``flight``",
    )
    boresight_drift: bool | None = option(
        None,
        kind="bool",
        doc="a Gauss-Markov drift of the planet image against the stars about the camera's X and Y axes, in "
        "truth, unknown to the filter. None: on in ``flight``",
    )
    drift_sigma_arcsec: float = option(
        1.0, unit="arcsec", gt=0.0, le=3600.0, doc="the drift's sigma per axis"
    )
    drift_tau_s: float = option(21600.0, unit="s", gt=0.0, le=1e9, doc="the drift's correlation time")
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
        doc="cannonball solar radiation pressure in truth (every scenario) from ``area_to_mass_m2_kg`` "
        "and a reflectivity drawn per episode in ``reflectivity_range``. The filter does not model it. "
        "None: on in ``flight``, off in ``matched``",
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
    truth_ephemeris: str | None = option(
        None,
        kind="str",
        choices=EPHEMERIDES,
        doc="the JPL ephemeris the truth follows (its third bodies, central body, the planets the camera "
        "sees, the pulsars' barycentre); the filter, the rules and the observation keep DE421. None: "
        "``de440`` in ``flight``, ``de421`` in ``matched``",
    )
    thrust_gauss_markov: bool | None = option(
        None,
        kind="bool",
        doc="the thrust execution error in truth as its first-order Gauss-Markov process (the "
        "operations' sigmas and thrust_corr_time_s); False: white noise of the filter's PSD 2 sigma^2 "
        "tau, which the filter keeps either way. None: on in ``flight``, off in ``matched``",
    )
    pulsar_shapiro: bool | None = option(
        None,
        kind="bool",
        doc="the Sun's Shapiro delay in the pulsars' arrival times in truth (~10 km of range at 1 AU); "
        "the filter models it from its estimate (``onboard_corrections``). None: on in ``flight``, off "
        "in ``matched``",
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
        ge=0.0,
        le=1e5,
        unit="rpm",
        doc="wheel no-load speed (back EMF); 0: no speed limit",
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
    def image_errors_on(self) -> bool:
        """The camera's errors come from the image (sensors/image_noise.py) in truth."""
        return self.flight if self.image_errors is None else self.image_errors

    @property
    def lambert_cob_on(self) -> bool:
        """The Lambertian centre-of-brightness offset in truth."""
        return self.flight if self.lambert_cob is None else self.lambert_cob

    @property
    def lambert_cob_corrected(self) -> bool:
        """The filter subtracts its photometric model's offset from each image."""
        return self.lambert_cob_on and self.corrections_on

    @property
    def oblate_on(self) -> bool:
        """Planets are spheroids in truth."""
        return self.flight if self.oblate_planets is None else self.oblate_planets

    @property
    def drift_on(self) -> bool:
        """The planet camera's boresight drifts in truth."""
        return self.flight if self.boresight_drift is None else self.boresight_drift

    @property
    def third_bodies_on(self) -> bool:
        """Every planet's point mass in the truth's force model."""
        return self.flight if self.third_bodies is None else self.third_bodies

    @property
    def srp_on(self) -> bool:
        """Cannonball SRP in the truth's force model (every scenario)."""
        return self.flight if self.srp is None else self.srp

    @property
    def truth_ephemeris_name(self) -> str:
        """The JPL ephemeris the truth follows (:data:`EPHEMERIDES`)."""
        if self.truth_ephemeris is not None:
            return self.truth_ephemeris
        return "de440" if self.flight else "de421"

    @property
    def truth_ephemeris_apart(self) -> bool:
        """The truth follows another ephemeris than the onboard model's DE421."""
        return self.truth_ephemeris_name != "de421"

    @property
    def truth_forces_on(self) -> bool:
        """The truth flies its own force model, apart from the filter's (its own bodies, SRP, or the same
        bodies from its own ephemeris)."""
        return self.third_bodies_on or self.srp_on or self.truth_ephemeris_apart

    @property
    def thrust_gauss_markov_on(self) -> bool:
        """The thrust execution error in truth is the Gauss-Markov process (else the filter's white noise)."""
        return self.flight if self.thrust_gauss_markov is None else self.thrust_gauss_markov

    @property
    def shapiro_on(self) -> bool:
        """The Sun's Shapiro delay in the truth's pulsar arrival times."""
        return self.flight if self.pulsar_shapiro is None else self.pulsar_shapiro

    @property
    def shapiro_corrected(self) -> bool:
        """The filter's pulsar phase model holds the Shapiro delay, from its estimate."""
        return self.shapiro_on and self.corrections_on

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
        if rpm == 0.0:
            return math.inf
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
            or self.thrust_gauss_markov_on
            or self.shapiro_on
            or self.centroid_bias_bound > 0.0
            or self.image_errors_on
            or self.lambert_cob_on
            or self.oblate_on
            or self.drift_on
            or self.pulsar_frequency_error_bound > 0.0
            or self.attitude_world_on
        )


#: Each effect of the flight world, by name, and the options that switch it off alone (their matched
#: values); what a study of one effect's share sets (:func:`flight_effects`). The attitude loop's options
#: come in groups: the disturbance torques, the wheels' friction and speed limit, the gyro's errors.
EFFECTS_OFF: dict[str, dict[str, Any]] = {
    "light_time": {"light_time": False},
    "aberration": {"aberration": False},
    "third_bodies": {"third_bodies": False},
    "srp": {"srp": False},
    "truth_ephemeris": {"truth_ephemeris": "de421"},
    "thrust_gauss_markov": {"thrust_gauss_markov": False},
    "pulsar_shapiro": {"pulsar_shapiro": False},
    "image_errors": {"image_errors": False},
    "lambert_cob": {"lambert_cob": False},
    "oblate_planets": {"oblate_planets": False},
    "boresight_drift": {"boresight_drift": False},
    "disturbance_torques": {
        "cp_offset_m": (0.0, 0.0, 0.0),
        "gravity_gradient": False,
        "thrust_offset_m": (0.0, 0.0, 0.0),
    },
    "wheel_friction_and_speed_limit": {
        "wheel_coulomb_n_m": 0.0,
        "wheel_viscous_n_m_s": 0.0,
        "wheel_speed_limit_rpm": 0.0,
    },
    "momentum_dumping": {"momentum_dumping": False},
    "gyro_errors": {"gyro_bias_deg_h": 0.0, "gyro_rrw_deg_h_rt_h": 0.0, "gyro_arw_deg_rt_h": 0.0},
    "pointing_from_estimate": {"pointing_from_estimate": False},
}

#: The effects that act only where the scenario has the sensor or the manoeuvre they concern.
_NEEDS = {"thrust_gauss_markov": "thrust", "pulsar_shapiro": "pulsars"}


def flight_effects(thrust: bool = True, pulsars: bool = True) -> dict[str, dict[str, Any]]:
    """The effects the ``flight`` preset turns on, each name mapped to the options that switch it off
    alone; ``thrust`` / ``pulsars`` False leaves out those that act only on a thrust arc / on pulsar
    timing (a scenario without them, where switching them off changes nothing)."""
    has = {"thrust": thrust, "pulsars": pulsars}
    return {name: off for name, off in EFFECTS_OFF.items() if name not in _NEEDS or has[_NEEDS[name]]}
