"""External torques on the spacecraft body and what the reaction wheels lose to friction.

Each function is a compiled row kernel over scalars and caller-allocated 3-vectors, body frame, SI units
(N m, m, kg, rad/s), as the attitude plant (:mod:`planetnav_env.attitude.plant`) takes them:

* :func:`srp_torque`: solar radiation pressure on a flat-faced cross-section ``A`` whose centre of pressure
  sits ``r_cp`` from the centre of mass: the force ``C_R A P(r)`` acts away from the Sun
  (:func:`~planetnav_env.dynamics.srp.solar_pressure`), the torque is ``r_cp x F``.
* :func:`gravity_gradient_torque`: a central body of GM ``mu`` at distance ``r`` along the body-frame unit
  vector ``u`` (spacecraft to body) pulls the near side harder: ``3 mu / r^3 (u x J u)`` (Hughes,
  *Spacecraft Attitude Dynamics*, 1986, eq. 4.3.19).
* :func:`thrust_torque`: a thruster of force ``F`` along the body-frame unit ``d`` acting at ``r_t`` from the
  centre of mass: ``r_t x F d`` (a misaligned or offset ion engine).
* :func:`wheel_friction`: the bearing's torque on a wheel spinning with momentum ``h`` about its axis,
  ``-sign(h) tau_c - c_v h / J_w`` (Coulomb plus viscous), which the body receives back (internal: total
  momentum is conserved).
* :func:`dump_delta_v`: thrusters of lever arm ``l`` that unload ``dh`` of wheel momentum push the centre of
  mass by ``dh / (l m)``.
"""

from __future__ import annotations

import math

from planetnav_env.dynamics.srp import solar_pressure
from planetnav_env.numerics.jit import row_kernel


@row_kernel
def srp_torque(sun_dir, r_sun_km, area_m2, reflectivity, r_cp, out) -> None:  # pragma: no cover - compiled
    """Torque [N m, body] of solar radiation pressure: ``sun_dir`` the unit direction to the Sun (body),
    ``r_sun_km`` [km] the distance, ``area_m2`` the sunlit cross-section, ``reflectivity`` C_R,
    ``r_cp`` [m, body] the centre of pressure from the centre of mass."""
    f = -reflectivity * area_m2 * solar_pressure(r_sun_km)  # along sun_dir: the push is away from the Sun
    fx, fy, fz = f * sun_dir[0], f * sun_dir[1], f * sun_dir[2]
    out[0] = r_cp[1] * fz - r_cp[2] * fy
    out[1] = r_cp[2] * fx - r_cp[0] * fz
    out[2] = r_cp[0] * fy - r_cp[1] * fx


@row_kernel
def gravity_gradient_torque(u, r_km, mu_km3_s2, jm, out) -> None:  # pragma: no cover - compiled
    """Gravity-gradient torque [N m, body] from a body of GM ``mu_km3_s2`` at ``r_km`` [km] along the unit
    body-frame vector ``u``; ``jm`` (3, 3) the inertia [kg m^2]. (km^3/s^2 / km^3 = 1/s^2.)"""
    k = 3.0 * mu_km3_s2 / (r_km * r_km * r_km)
    ju0 = jm[0, 0] * u[0] + jm[0, 1] * u[1] + jm[0, 2] * u[2]
    ju1 = jm[1, 0] * u[0] + jm[1, 1] * u[1] + jm[1, 2] * u[2]
    ju2 = jm[2, 0] * u[0] + jm[2, 1] * u[1] + jm[2, 2] * u[2]
    out[0] = k * (u[1] * ju2 - u[2] * ju1)
    out[1] = k * (u[2] * ju0 - u[0] * ju2)
    out[2] = k * (u[0] * ju1 - u[1] * ju0)


@row_kernel
def thrust_torque(force_n, direction, r_t, out) -> None:  # pragma: no cover - compiled
    """Torque [N m, body] of a thrust of ``force_n`` [N] along the unit ``direction`` (body) applied at
    ``r_t`` [m, body] from the centre of mass."""
    fx, fy, fz = force_n * direction[0], force_n * direction[1], force_n * direction[2]
    out[0] = r_t[1] * fz - r_t[2] * fy
    out[1] = r_t[2] * fx - r_t[0] * fz
    out[2] = r_t[0] * fy - r_t[1] * fx


@row_kernel
def wheel_friction(h, wheel_inertia, coulomb_n_m, viscous_n_m_s) -> float:  # pragma: no cover - compiled
    """Bearing torque [N m] on a wheel of axial momentum ``h`` [N m s] and inertia ``wheel_inertia``
    [kg m^2]: Coulomb ``coulomb_n_m`` against the spin plus viscous ``viscous_n_m_s`` [N m s] times the
    wheel speed ``h / J_w``. Zero at rest (no stiction)."""
    if h == 0.0:
        return 0.0
    return -math.copysign(coulomb_n_m, h) - viscous_n_m_s * h / wheel_inertia


@row_kernel
def dump_delta_v(dh_n_m_s, lever_arm_m, mass_kg) -> float:  # pragma: no cover - compiled
    """Velocity change [km/s] of the centre of mass when thrusters of lever arm ``lever_arm_m`` [m]
    unload ``dh_n_m_s`` [N m s] of wheel momentum from a spacecraft of ``mass_kg`` [kg]: the impulse is
    ``dh / l`` [N s] (one-sided thrusters, no couple)."""
    return dh_n_m_s / (lever_arm_m * mass_kg) * 1e-3
