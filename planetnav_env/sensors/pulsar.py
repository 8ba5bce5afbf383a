"""X-ray pulsar timing: catalogue, TOA noise, phase/range measurement, Sun blocking, cycle ambiguity.

Measurement (patent 003, step 1, rebuilt from ERRATA 003 item 1)
-----------------------------------------------------------------
A pulse that reaches the Solar-system barycentre (SSB) at ``t_b`` reaches a spacecraft at ``r`` (relative to
the SSB, ICRF) earlier by ``n . r / c`` (plane wave from the pulsar's unit direction ``n``). The spacecraft
folds its photons with the pulsar's timing model and measures the phase offset of the observed pulse train
relative to the one predicted at the SSB:

    n . r = lambda (delta_phi + delta_N),        lambda = c P,

``delta_phi`` in [0, 1) the measured fractional phase [cycles], ``delta_N`` the unknown whole number of
cycles, ``lambda`` [km] the distance light travels in one period ``P``. The filter's measurement model is the
total phase ``h(x) = n . r_ssb(x) / lambda`` [cycles] with ``r_ssb = r_mars_ssb(t) + r_sc`` (state relative to
Mars), which is *linear* in the position: ``dh/dr = n^T / lambda``. Only the ambiguity is nonlinear.

The Sun's Shapiro delay (:func:`shapiro_range_km`, ~10 km of range at 1 AU: the flight world's
``world.pulsar_shapiro``) joins the truth's phase, and the filter's model computes it from its own estimate;
in the matched world both leave it out. The curvature of the wavefront (``(r^2 - (n . r)^2) / 2D``, 0.2 km
for a pulsar 2 kpc away at 1 AU) and the spacecraft clock's relativistic terms are left out of both. The
SSB position of the central body comes from the truth's ephemeris for the truth (DE440 in the flight world,
``world.truth_ephemeris``) and from DE421 for the filter's prediction: the ephemeris' error is then a bias
of ``n . delta r`` (``docs/flight_world.md``).

Cycle ambiguity
---------------
``delta_N`` is resolved against the prediction: ``delta_N = round(h(x_pred) - delta_phi)``, i.e. the phase
innovation is wrapped to (-1/2, 1/2] cycle (:func:`resolve_cycle_ambiguity`). This is right when the predicted
1-sigma of ``n . r`` is small against ``lambda``; :func:`ambiguity_resolvable` states the rule used here,
``k sigma_pred < lambda / 2`` (k = 3 by default). For the Crab (lambda ~ 10,000 km) the a-priori uncertainty
of an approach (~100 km) satisfies it from the start; for B1937+21 (lambda ~ 467 km) it does not, and the
harness skips (and counts) such measurements rather than guessing a cycle.

Noise (Sheikh et al. 2006)
--------------------------
S. I. Sheikh, D. J. Pines, P. S. Ray, K. S. Wood, M. N. Lovellette, M. T. Wolff, "Spacecraft Navigation Using
X-Ray Pulsars", J. Guidance, Control, and Dynamics 29(1), 49-63 (2006), section on TOA accuracy:

    d     = W / P                                          (duty cycle)
    SNR   = F_x p_f A t / sqrt( [B_x + F_x (1 - p_f)] A t d + F_x p_f A t )
    sigma_TOA = W / (2 SNR)                                 [s]

``F_x`` source flux [ph/cm^2/s] (2-10 keV), ``p_f`` pulsed fraction, ``W`` pulse width (FWHM) [s], ``B_x``
diffuse X-ray background [ph/cm^2/s] (Sheikh: 0.005), ``A`` detector area [cm^2], ``t`` integration time [s].
The background (and the unpulsed source flux) counts only in the on-pulse window (fraction ``d``). The range
noise is ``sigma_r = c sigma_TOA`` and the phase noise ``sigma_TOA / P`` cycles. This is the idealised
(top-hat profile) estimate; real profiles and detector dead time give larger errors.

Frames, units: ICRF axes; km, s; phases in cycles; angles in degrees in the catalogue, radians elsewhere.
"""

from __future__ import annotations

import functools
import math
import re
from dataclasses import dataclass

import numpy as np
from numba import vectorize

from planetnav_env.astro.apparent import SPEED_OF_LIGHT_KM_S
from planetnav_env.astro.bodies import GM_SUN, body
from planetnav_env.codes import VisibilityReason
from planetnav_env.errors import (
    InvalidParameterError,
    NotVisibleError,
    UnknownBodyError,
    require_finite,
    require_positive,
)
from planetnav_env.numerics import portable_math as pm
from planetnav_env.numerics.jit import row_kernel
from planetnav_env.options import check_options, option

__all__ = [
    "DEFAULT_DETECTOR",
    "PULSARS",
    "SHAPIRO_SCALE_KM",
    "SPEED_OF_LIGHT_KM_S",
    "Pulsar",
    "PulsarVisibility",
    "UnknownPulsarError",
    "XrayDetector",
    "ambiguity_resolvable",
    "check_visible",
    "mars_radius_km",
    "measure_phase",
    "phase_jacobian",
    "phase_model",
    "phase_sigma_cycles",
    "pulsar",
    "pulsar_toa_sigma_s",
    "pulsar_visibility",
    "radec_to_unit",
    "range_sigma_km",
    "resolve_cycle_ambiguity",
    "shapiro_range_km",
    "sun_ssb_position",
    "toa_sigma_s",
]


class UnknownPulsarError(UnknownBodyError):
    """A pulsar name that the catalogue does not know (a :class:`UnknownBodyError`, hence a KeyError and a
    ValueError too)."""


# ---------------------------------------------------------------------------------------------------------
# Catalogue
# ---------------------------------------------------------------------------------------------------------


def _hms_to_deg(text: str) -> float:
    h, m, s = (float(x) for x in text.split(":"))
    return 15.0 * (h + m / 60.0 + s / 3600.0)


def _dms_to_deg(text: str) -> float:
    t = text.strip()
    sign = -1.0 if t.startswith("-") else 1.0
    d, m, s = (float(x) for x in t.lstrip("+-").split(":"))
    return sign * (d + m / 60.0 + s / 3600.0)


def radec_to_unit(ra_deg: np.ndarray | float, dec_deg: np.ndarray | float) -> np.ndarray:
    """Unit vector(s) ``(..., 3)``, ICRF/J2000 equatorial axes, from right ascension and declination [deg]."""
    ra = np.deg2rad(np.asarray(ra_deg, float))
    dec = np.deg2rad(np.asarray(dec_deg, float))
    return np.stack([pm.cos(dec) * pm.cos(ra), pm.cos(dec) * pm.sin(ra), pm.sin(dec)], axis=-1)


@dataclass(frozen=True)
class Pulsar:
    """One catalogue pulsar.

    Attributes
    ----------
    bname, jname
        B1950 and J2000 names (ATNF spelling, ASCII minus).
    raj, decj
        J2000 position as published (``hh:mm:ss.s``, ``+dd:mm:ss.s``), ATNF pulsar catalogue.
    period_s
        Barycentric spin period P0 [s] at the catalogue's epoch (ATNF). It sets the cycle length
        ``lambda = c P``; the spin-down over decades (<1 % for the Crab) does not matter for navigation here.
    flux_ph_cm2_s
        X-ray photon flux F_x, 2-10 keV [ph/cm^2/s] (Sheikh et al. 2006, table 1).
    pulsed_fraction
        p_f in (0, 1] (Sheikh et al. 2006, table 1).
    pulse_width_s
        Pulse width W (FWHM) [s] (Sheikh et al. 2006, table 1).
    """

    bname: str
    jname: str
    raj: str
    decj: str
    period_s: float
    flux_ph_cm2_s: float
    pulsed_fraction: float
    pulse_width_s: float

    def __post_init__(self) -> None:
        require_positive(f"{self.bname}.period_s", self.period_s)
        require_positive(f"{self.bname}.flux_ph_cm2_s", self.flux_ph_cm2_s)
        require_positive(f"{self.bname}.pulse_width_s", self.pulse_width_s)
        if not 0.0 < self.pulsed_fraction <= 1.0:
            raise InvalidParameterError(
                f"{self.bname}.pulsed_fraction must be in (0, 1], got {self.pulsed_fraction}"
            )
        if self.pulse_width_s >= self.period_s:
            raise InvalidParameterError(f"{self.bname}: pulse width {self.pulse_width_s} s >= period")

    @property
    def ra_deg(self) -> float:
        """Right ascension J2000 [deg]."""
        return _hms_to_deg(self.raj)

    @property
    def dec_deg(self) -> float:
        """Declination J2000 [deg]."""
        return _dms_to_deg(self.decj)

    @property
    def direction(self) -> np.ndarray:
        """Unit vector from the Solar system towards the pulsar, ICRF, shape (3,)."""
        return radec_to_unit(self.ra_deg, self.dec_deg)

    @property
    def wavelength_km(self) -> float:
        """``lambda = c P`` [km]: the range equivalent of one cycle."""
        return SPEED_OF_LIGHT_KM_S * self.period_s

    @property
    def duty_cycle(self) -> float:
        """``d = W / P``."""
        return self.pulse_width_s / self.period_s


#: The navigation catalogue. Positions and periods: ATNF Pulsar Catalogue (Manchester, Hobbs, Teoh & Hobbs
#: 2005, AJ 129, 1993; psrcat, https://www.atnf.csiro.au/research/pulsar/psrcat/). X-ray flux (2-10 keV),
#: pulsed fraction and pulse width: Sheikh et al. 2006, JGCD 29(1), table 1. See docs/optical_pulsar.md for
#: the cross-check of the positions.
PULSARS: dict[str, Pulsar] = {
    p.bname: p
    for p in (
        # The Crab: brightest, wide pulse; ATNF position (lpg+93 timing) and P0 at PEPOCH MJD 40000.
        Pulsar("B0531+21", "J0534+2200", "05:34:31.973", "+22:00:52.06", 0.0333924123, 1.54e-2, 0.70, 1.7e-3),
        # Millisecond pulsar in M28.
        Pulsar(
            "B1821-24", "J1824-2452A", "18:24:32.008", "-24:52:10.83", 0.00305431531, 1.93e-4, 0.98, 5.5e-5
        ),
        # The first millisecond pulsar.
        Pulsar(
            "B1937+21",
            "J1939+2134",
            "19:39:38.561224",
            "+21:34:59.12570",
            0.0015578064688,
            4.99e-5,
            0.86,
            2.1e-5,
        ),
    )
}
_ALIASES = {p.jname.lower(): p.bname for p in PULSARS.values()} | {"crab": "B0531+21"}


def _normalise_name(name: str) -> str:
    # Accept the typographic minus and a "PSR " prefix: names are often copied from papers.
    t = str(name).strip().replace("\u2212", "-").replace("\u2013", "-")
    return re.sub(r"^psr\s*", "", t, flags=re.IGNORECASE).lower()


def pulsar(name: str | Pulsar) -> Pulsar:
    """Look a pulsar up by B or J name (case-insensitive, "PSR " prefix and Unicode minus accepted).

    Raises :class:`UnknownPulsarError` naming the bad name and the known ones.
    """
    if isinstance(name, Pulsar):
        return name
    key = _normalise_name(name)
    for b in PULSARS:
        if b.lower() == key:
            return PULSARS[b]
    if key in _ALIASES:
        return PULSARS[_ALIASES[key]]
    raise UnknownPulsarError(
        f"unknown pulsar {name!r}; the catalogue has {[f'{p.bname} ({p.jname})' for p in PULSARS.values()]}"
    )


# ---------------------------------------------------------------------------------------------------------
# Detector and TOA noise
# ---------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class XrayDetector:
    """X-ray timing detector, each setting declared with its unit and range (``options.option``)."""

    area_cm2: float = option(
        1.0e4,
        gt=0,
        unit="cm^2",
        doc="effective area A. Default 1 m^2, the detector size assumed in Sheikh et al. (2006) and used by "
        "most XNAV feasibility studies (NICER's is ~0.19 m^2 at 1.5 keV)",
    )
    integration_time_s: float = option(
        1000.0,
        gt=0,
        unit="s",
        kernel="psr_int_s",
        doc="photon integration (folding) time t per TOA, within the 500-3000 s of the XNAV literature; one "
        "TOA per integration window",
    )
    background_ph_cm2_s: float = option(
        0.005,
        ge=0,
        unit="ph/cm^2/s",
        doc="diffuse X-ray background B_x in the field of view, 2-10 keV (Sheikh et al. 2006)",
    )
    sun_avoidance_deg: float = option(
        30.0,
        ge=0,
        lt=180,
        unit="deg",
        doc="least angle between the pulsar and the Sun for a usable observation: an assumed baffle/thermal "
        "constraint (the patent gives none)",
    )

    def __post_init__(self) -> None:
        check_options(self, "detector.", coerce=True)


DEFAULT_DETECTOR = XrayDetector()


def toa_sigma_s(
    flux_ph_cm2_s: np.ndarray | float,
    pulsed_fraction: np.ndarray | float,
    pulse_width_s: np.ndarray | float,
    period_s: np.ndarray | float,
    background_ph_cm2_s: np.ndarray | float,
    area_cm2: np.ndarray | float,
    integration_time_s: np.ndarray | float,
) -> np.ndarray:
    """1-sigma TOA error [s] of Sheikh et al. (2006): ``W / (2 SNR)`` (module docstring). Broadcasts.

    Raises :class:`InvalidParameterError` for a non-positive area, integration time, flux, width or period,
    a pulsed fraction outside (0, 1] or a negative background.
    """
    f = np.asarray(flux_ph_cm2_s, float)
    pf = np.asarray(pulsed_fraction, float)
    w = np.asarray(pulse_width_s, float)
    p = np.asarray(period_s, float)
    b = np.asarray(background_ph_cm2_s, float)
    a = np.asarray(area_cm2, float)
    t = np.asarray(integration_time_s, float)
    for name, v in (
        ("area_cm2", a),
        ("integration_time_s", t),
        ("flux", f),
        ("pulse_width_s", w),
        ("period_s", p),
    ):
        if not np.all(np.isfinite(v)) or np.any(v <= 0.0):
            raise InvalidParameterError(f"{name} must be positive and finite, got {v}")
    if np.any(~np.isfinite(pf) | (pf <= 0.0) | (pf > 1.0)):
        raise InvalidParameterError(f"pulsed_fraction must be in (0, 1], got {pf}")
    if np.any(~np.isfinite(b) | (b < 0.0)):
        raise InvalidParameterError(f"background_ph_cm2_s must be >= 0, got {b}")
    d = w / p
    pulsed = f * pf * a * t
    noise = np.sqrt((b + f * (1.0 - pf)) * a * t * d + pulsed)
    return w / (2.0 * pulsed / noise)


def pulsar_toa_sigma_s(psr: str | Pulsar, detector: XrayDetector = DEFAULT_DETECTOR) -> float:
    """:func:`toa_sigma_s` for a catalogue pulsar and a detector [s]."""
    p = pulsar(psr)
    return float(
        toa_sigma_s(
            p.flux_ph_cm2_s,
            p.pulsed_fraction,
            p.pulse_width_s,
            p.period_s,
            detector.background_ph_cm2_s,
            detector.area_cm2,
            detector.integration_time_s,
        )
    )


def range_sigma_km(psr: str | Pulsar, detector: XrayDetector = DEFAULT_DETECTOR) -> float:
    """1-sigma range error along the line of sight [km]: ``c sigma_TOA``."""
    return SPEED_OF_LIGHT_KM_S * pulsar_toa_sigma_s(psr, detector)


def phase_sigma_cycles(psr: str | Pulsar, detector: XrayDetector = DEFAULT_DETECTOR) -> float:
    """1-sigma phase error [cycles]: ``sigma_TOA / P``."""
    p = pulsar(psr)
    return pulsar_toa_sigma_s(p, detector) / p.period_s


# ---------------------------------------------------------------------------------------------------------
# Barycentric positions
# ---------------------------------------------------------------------------------------------------------


@functools.lru_cache(maxsize=1)
def _de421():
    from planetnav_env.astro.ephemeris import DEEphemeris

    return DEEphemeris()


def sun_ssb_position(t: np.ndarray | float) -> np.ndarray:
    """Position of the Sun's centre relative to the Solar-system barycentre [km], ICRF, from DE421.

    ``t`` [TDB s since J2000], any shape; result ``t.shape + (3,)``. Add it to a heliocentric position
    (:class:`planetnav_env.astro.ephemeris.DEEphemeris`) to get the barycentric one. Its size is ~1e6 km
    (mostly Jupiter's pull), far from negligible in ``n . r``.
    """
    t = require_finite("time t", np.asarray(t, float))
    return _de421().sun_barycentric_position(t)


# ---------------------------------------------------------------------------------------------------------
# Measurement model
# ---------------------------------------------------------------------------------------------------------


def _directions(pulsars: tuple[str | Pulsar, ...] | list[str | Pulsar]) -> tuple[np.ndarray, np.ndarray]:
    ps = [pulsar(p) for p in pulsars]
    if not ps:
        raise InvalidParameterError("at least one pulsar is needed")
    return np.stack([p.direction for p in ps]), np.array([p.wavelength_km for p in ps])


def phase_model(r_ssb: np.ndarray, pulsars: tuple[str | Pulsar, ...] | list[str | Pulsar]) -> np.ndarray:
    """Total phase ``n_i . r / lambda_i`` [cycles] of the spacecraft at ``r_ssb`` (N, 3) [km, relative to the
    SSB, ICRF] for each pulsar: shape (N, M)."""
    n, lam = _directions(pulsars)
    r = require_finite("r_ssb", r_ssb)
    return (r @ n.T) / lam


def phase_jacobian(n_batch: int, pulsars: tuple[str | Pulsar, ...] | list[str | Pulsar]) -> np.ndarray:
    """``d phase / d x`` (N, M, 6) [cycles/km on the position columns, 0 on velocity]: ``n_i^T / lambda_i``.

    The SSB offset of the state's origin (Mars) does not depend on the state, so the Jacobian is constant.
    """
    n, lam = _directions(pulsars)
    h = np.zeros((n_batch, len(lam), 6))
    h[:, :, 0:3] = n / lam[:, None]
    return h


def measure_phase(
    rng: np.random.Generator,
    r_ssb: np.ndarray,
    pulsars: tuple[str | Pulsar, ...] | list[str | Pulsar],
    detector: XrayDetector = DEFAULT_DETECTOR,
    noise: np.ndarray | None = None,
) -> np.ndarray:
    """Measured fractional phases ``delta_phi`` in [0, 1) [cycles], shape (N, M).

    ``frac(n . r / lambda + e)``, ``e ~ N(0, sigma_TOA / P)``. ``noise`` (N, M) standard normal draws may be
    supplied (common random numbers across filters); otherwise one ``rng.standard_normal((N, M))`` is drawn.
    """
    r = require_finite("r_ssb", np.atleast_2d(r_ssb))
    ps = [pulsar(p) for p in pulsars]
    sig = np.array([phase_sigma_cycles(p, detector) for p in ps])
    if noise is None:
        if not isinstance(rng, np.random.Generator):
            raise InvalidParameterError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
        noise = rng.standard_normal((r.shape[0], len(ps)))
    total = phase_model(r, ps) + sig * np.asarray(noise, float)
    return total - np.floor(total)


@row_kernel
def resolve_cycle(phase_frac: float, predicted_phase: float) -> float:  # pragma: no cover - compiled
    """Total phase ``phase_frac + round(predicted - phase_frac)`` [cycles] (half to even) of one scalar
    pair: what the row kernels call (both targets); :func:`resolve_cycle_kernel` is its ufunc."""
    return phase_frac + pm.rint(predicted_phase - phase_frac)


@row_kernel
def ambiguity_resolvable_row(sigma_pred_cycles: float, k_sigma: float) -> bool:  # pragma: no cover
    """``k_sigma * sigma_pred < 1/2`` cycle of one scalar pair: what the row kernels call (both targets);
    :func:`ambiguity_resolvable_kernel` is its ufunc."""
    return k_sigma * sigma_pred_cycles < 0.5


@vectorize(["float64(float64, float64)"], cache=True)
def resolve_cycle_kernel(phase_frac: float, predicted_phase: float) -> float:  # pragma: no cover - compiled
    """:func:`resolve_cycle` as a ufunc (:func:`resolve_cycle_ambiguity` calls it on arrays)."""
    return resolve_cycle(phase_frac, predicted_phase)


@vectorize(["boolean(float64, float64)"], cache=True)
def ambiguity_resolvable_kernel(sigma_pred_cycles: float, k_sigma: float) -> bool:  # pragma: no cover
    """:func:`ambiguity_resolvable_row` as a ufunc (see :func:`ambiguity_resolvable`)."""
    return ambiguity_resolvable_row(sigma_pred_cycles, k_sigma)


def resolve_cycle_ambiguity(phase_frac: np.ndarray, predicted_phase: np.ndarray) -> np.ndarray:
    """Total measured phase ``delta_phi + delta_N`` [cycles] with ``delta_N = round(h_pred - delta_phi)``.

    Equivalent to wrapping the phase innovation to [-1/2, 1/2) cycle around the prediction. Shapes broadcast.
    """
    f = require_finite("phase_frac", phase_frac)
    h = require_finite("predicted_phase", predicted_phase)
    return resolve_cycle_kernel(np.asarray(f, float), np.asarray(h, float))


def ambiguity_resolvable(sigma_pred_cycles: np.ndarray | float, k_sigma: float = 3.0) -> np.ndarray:
    """Whether the rounding of :func:`resolve_cycle_ambiguity` is trustworthy: ``k sigma_pred < 1/2`` cycle.

    ``sigma_pred_cycles``: predicted 1-sigma of the total phase, ``sqrt(H P H^T + R)`` [cycles].
    """
    require_positive("k_sigma", k_sigma)
    return ambiguity_resolvable_kernel(np.asarray(sigma_pred_cycles, float), float(k_sigma))


# ---------------------------------------------------------------------------------------------------------
# Visibility: Sun avoidance and occultation by a body
# ---------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class PulsarVisibility:
    """Per element (N,) and pulsar (M,): ``visible``, ``sun_blocked`` (Sun within the avoidance cone),
    ``occulted`` (the line of sight passes through the occulting body), ``sun_angle_rad``."""

    visible: np.ndarray
    sun_blocked: np.ndarray
    occulted: np.ndarray
    sun_angle_rad: np.ndarray


def pulsar_visibility(
    r_sc_helio: np.ndarray,
    pulsars: tuple[str | Pulsar, ...] | list[str | Pulsar],
    detector: XrayDetector = DEFAULT_DETECTOR,
    occulter_pos_helio: np.ndarray | None = None,
    occulter_radius_km: float | None = None,
) -> PulsarVisibility:
    """Can each pulsar be timed from heliocentric ``r_sc_helio`` (N, 3) [km]?

    * Sun blocking: the angle between the pulsar direction and the direction to the Sun is below
      ``detector.sun_avoidance_deg`` (the Sun's disk itself, 0.27 deg at 1 AU, is inside any such cone).
    * Occultation: the ray from the spacecraft along ``n`` passes within ``occulter_radius_km`` of
      ``occulter_pos_helio`` (N, 3) or (3,) (e.g. Mars on approach), the body being ahead of the spacecraft.
    """
    r = require_finite("r_sc_helio", np.atleast_2d(r_sc_helio))
    n, _ = _directions(pulsars)
    to_sun = -r / np.linalg.norm(r, axis=-1, keepdims=True)
    cosang = np.clip(to_sun @ n.T, -1.0, 1.0)
    ang = np.arccos(cosang)
    sun_blocked = ang < np.deg2rad(detector.sun_avoidance_deg)
    occulted = np.zeros_like(sun_blocked)
    if occulter_pos_helio is not None:
        rad = require_positive("occulter_radius_km", occulter_radius_km)
        d = np.broadcast_to(require_finite("occulter_pos_helio", occulter_pos_helio), r.shape) - r
        along = d @ n.T  # (N, M): distance along each ray to the closest approach to the body's centre
        miss2 = np.sum(d * d, axis=-1, keepdims=True) - along**2
        occulted = (along > 0.0) & (miss2 < rad * rad)
    return PulsarVisibility(~(sun_blocked | occulted), sun_blocked, occulted, ang)


def check_visible(
    r_sc_helio: np.ndarray,
    pulsars: tuple[str | Pulsar, ...] | list[str | Pulsar],
    detector: XrayDetector = DEFAULT_DETECTOR,
    occulter_pos_helio: np.ndarray | None = None,
    occulter_radius_km: float | None = None,
    occulter_name: str = "occulter",
) -> None:
    """Raise :class:`NotVisibleError` naming the pulsar, the reason and the Sun angle if any pulsar cannot be
    timed from any of the positions (see :func:`pulsar_visibility`)."""
    ps = [pulsar(p) for p in pulsars]
    vis = pulsar_visibility(r_sc_helio, ps, detector, occulter_pos_helio, occulter_radius_km)
    for j, p in enumerate(ps):
        if np.any(vis.sun_blocked[:, j]):
            i = int(np.argmax(vis.sun_blocked[:, j]))
            raise NotVisibleError(
                f"pulsar {p.bname} is blocked by the Sun: its direction is "
                f"{np.degrees(vis.sun_angle_rad[i, j]):.2f} deg from the Sun, inside the "
                f"{detector.sun_avoidance_deg:g} deg avoidance cone (element {i})"
            )
        if np.any(vis.occulted[:, j]):
            i = int(np.argmax(vis.occulted[:, j]))
            raise NotVisibleError(f"pulsar {p.bname} is occulted by {occulter_name} (element {i})")


def mars_radius_km() -> float:
    """Mars's equatorial radius [km] (the occulter on approach)."""
    return body("mars").radius


#: 2 GM_sun / c^2 [km]: the Sun's Shapiro delay's scale as a range (2.95 km).
SHAPIRO_SCALE_KM = 2.0 * GM_SUN / (SPEED_OF_LIGHT_KM_S * SPEED_OF_LIGHT_KM_S)


@row_kernel
def shapiro_range_km(r_helio, b_helio, nvec) -> float:  # pragma: no cover - compiled
    """The Sun's Shapiro delay at heliocentric ``r_helio`` [km] relative to the barycentre (heliocentric
    ``b_helio`` [km]), times c, for a pulsar at infinity along the unit ``nvec`` (ICRF) [km]: the delay of a
    ray from a source at distance D to an observer at ``r`` is ``(2 GM / c^3) ln(2 D / (|r| + n . r))``
    (Shapiro 1964, the source going to infinity), so the phase referenced to the barycentre measures the
    range ``n . r_ssb + 2 GM / c^2 ln((|r| + n . r) / (|b| + n . b))`` (Sheikh et al. 2006, eq. 11;
    negative when the ray passes near the Sun, where it is delayed most)."""
    rn = math.sqrt(r_helio[0] ** 2 + r_helio[1] ** 2 + r_helio[2] ** 2)
    bn = math.sqrt(b_helio[0] ** 2 + b_helio[1] ** 2 + b_helio[2] ** 2)
    nr = r_helio[0] * nvec[0] + r_helio[1] * nvec[1] + r_helio[2] * nvec[2]
    nb = b_helio[0] * nvec[0] + b_helio[1] * nvec[1] + b_helio[2] * nvec[2]
    return SHAPIRO_SCALE_KM * math.log((rn + nr) / (bn + nb))


# VisibilityReason codes of the pulsar geometry, as ints for the row kernel (numba folds int globals).
_VISIBLE = int(VisibilityReason.VISIBLE)
_OCCULTED = int(VisibilityReason.OCCULTED)
_SUN_EXCLUSION = int(VisibilityReason.SUN_EXCLUSION)


@row_kernel
def pulsar_visibility_row(
    r_helio, nvec, sun_avoid, central, central_radius, approach
) -> int:  # pragma: no cover
    """VisibilityReason code for timing a pulsar along unit ``nvec`` from heliocentric ``r_helio``: Sun within
    ``sun_avoid`` [rad] of the pulsar, or the central body (``central`` heliocentric, radius [km], on
    approach only) across the line of sight ahead of the spacecraft."""
    rn = math.sqrt(r_helio[0] ** 2 + r_helio[1] ** 2 + r_helio[2] ** 2)
    c = -(r_helio[0] * nvec[0] + r_helio[1] * nvec[1] + r_helio[2] * nvec[2]) / rn
    if math.acos(min(max(c, -1.0), 1.0)) < sun_avoid:
        return _SUN_EXCLUSION
    if approach:
        d0, d1, d2 = central[0] - r_helio[0], central[1] - r_helio[1], central[2] - r_helio[2]
        along = d0 * nvec[0] + d1 * nvec[1] + d2 * nvec[2]
        miss2 = d0 * d0 + d1 * d1 + d2 * d2 - along * along
        if along > 0.0 and miss2 < central_radius * central_radius:
            return _OCCULTED
    return _VISIBLE
