"""Solar radiation pressure on a spacecraft: the cannonball model.

Sunlight carries momentum: at distance ``r`` from the Sun its pressure on a surface that absorbs it is
``P(r) = (S / c) (1 AU / r)^2`` with the solar constant ``S`` = 1361 W/m^2 (the total solar irradiance at
1 AU, Kopp & Lean 2011) and ``c`` the speed of light: 4.54e-6 N/m^2 at 1 AU. A spacecraft of
cross-section ``A`` [m^2], mass ``m`` [kg] and reflectivity coefficient ``C_R`` (1 absorbs all, 2 mirrors
all back) is pushed away from the Sun with ``a = C_R (A / m) P(r)``.

Being radial and falling as ``1 / r^2``, that acceleration is the Sun's gravity reduced: a cannonball
spacecraft moves in the Sun's field with ``GM_eff = GM_sun - k`` where ``k = C_R (A / m) P(1 AU) AU^2``
(:func:`srp_gm` [km^3/s^2]; 1.3e6 km^3/s^2, a 1e-5 part of GM_sun, for A/m = 0.01 m^2/kg and C_R = 1.3).
Units: km, s and kg as the project's, with the inputs a spacecraft's designer quotes (m^2/kg, N/m^2).
"""

from __future__ import annotations

from planetnav_env.astro.apparent import SPEED_OF_LIGHT_KM_S
from planetnav_env.astro.bodies import AU_KM
from planetnav_env.numerics.jit import row_kernel

#: Total solar irradiance at 1 AU [W/m^2] (Kopp & Lean 2011, Geophys. Res. Lett. 38:L01706).
SOLAR_CONSTANT_W_M2 = 1361.0
#: Radiation pressure of sunlight on an absorbing surface at 1 AU [N/m^2].
P_1AU_N_M2 = SOLAR_CONSTANT_W_M2 / (SPEED_OF_LIGHT_KM_S * 1e3)


@row_kernel
def solar_pressure(r_km: float) -> float:  # pragma: no cover - compiled
    """Radiation pressure of sunlight [N/m^2] on an absorbing surface at ``r_km`` [km] from the Sun."""
    x = AU_KM / r_km
    return P_1AU_N_M2 * x * x


@row_kernel
def srp_gm(area_to_mass_m2_kg: float, reflectivity: float) -> float:  # pragma: no cover - compiled
    """The cannonball SRP as a reduction ``k`` [km^3/s^2] of the Sun's GM: the acceleration is
    ``+k r / |r|^3`` (heliocentric ``r`` [km]) for a spacecraft of ``area_to_mass_m2_kg`` [m^2/kg] and
    reflectivity coefficient ``reflectivity`` [1, 2]. (N/m^2 * m^2/kg = m/s^2; * 1e-3 -> km/s^2.)"""
    return reflectivity * area_to_mass_m2_kg * P_1AU_N_M2 * 1e-3 * AU_KM * AU_KM
