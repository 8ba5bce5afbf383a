"""Mars approach of the hybrid optical + X-ray pulsar navigation (patent 003): scenario and truth.

Trajectory and epoch (documented in ``docs/optical_pulsar.md``)
----------------------------------------------------------------
* Central body Mars; Sun, Earth and Jupiter as point-mass perturbers (direct minus indirect terms,
  :class:`planetnav_env.dynamics.orbit.GravityModel`), their positions from DE421 (Jupiter: its system
  barycentre). State ``x = [r, v]`` relative to Mars's centre, ICRF axes, km and km/s; time TDB s since J2000.
* Closest approach (periapsis) at ``closest_approach_tdb``, default 2021-02-10 12:00 TDB (the week Tianwen-1
  arrived; the trajectory is an idealised one, not Tianwen-1's).
* Arrival geometry of a Hohmann-like transfer: the spacecraft reaches Mars near the aphelion of its transfer
  orbit, moving slower than Mars, so its incoming hyperbolic excess velocity points against Mars's
  heliocentric velocity: ``v_inf = -v_inf_km_s * unit(v_mars)``, default 2.65 km/s (the Hohmann value
  for 1 -> 1.524 AU). The hyperbola's plane contains ``v_inf`` and is as close to the ecliptic as possible
  (its normal is the ecliptic pole's component orthogonal to ``v_inf``), periapsis altitude 400 km.
* The two-body periapsis state of that hyperbola at ``closest_approach_tdb`` defines the trajectory: it is
  integrated *backwards* with the full force model by compiled RK4 (steps <= 10 s) to ``duration_h`` before
  closest approach (default 96 h); its states on the filter's time grid are the truth. Because the
  state at ``closest_approach_tdb`` has ``r . v = 0`` exactly, it is the truth's closest approach.

The patent's navigation methods on this approach (optical, pulsar, both) are run by
:mod:`planetnav_validation.approach_methods`.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from planetnav_env.astro.bodies import ECLIPTIC_TO_EQUATORIAL, body
from planetnav_env.astro.ephemeris import DEEphemeris
from planetnav_env.astro.timescale import tdb_seconds
from planetnav_env.dynamics.orbit import GravityModel, rk4_step
from planetnav_env.errors import InvalidParameterError, require_finite, require_positive
from planetnav_env.estimation.ekf_kernels import rk4_path_kernel
from planetnav_env.numerics.portable_math import cross3, dot3, matvec3, norm3, unit3
from planetnav_env.sensors import pulsar as psr

__all__ = ["PERTURBERS", "ApproachConfig", "MarsApproach", "hyperbolic_periapsis_state"]

PERTURBERS = ("sun", "earth", "jupiter")
DEFAULT_CLOSEST_APPROACH_TDB = tdb_seconds(2021, 2, 10, 12.0)
_ECLIPTIC_POLE = matvec3(ECLIPTIC_TO_EQUATORIAL, np.array([0.0, 0.0, 1.0]))
#: RK4 steps of the truth integration [s]: at most 2 s within 12 h of closest approach (1/500 of the
#: dynamical time at the 400-km periapsis, ~1100 s: a velocity error there grows into a position error over
#: the days before), at most 20 s before. The truth is then within a millimetre of DOP853 (rtol = atol =
#: 1e-12; tests/env/test_approach.py).
TRUTH_STEP_NEAR_S = 2.0
TRUTH_STEP_FAR_S = 20.0
TRUTH_NEAR_CA_S = 12 * 3600.0


def hyperbolic_periapsis_state(
    v_inf_vec: np.ndarray, periapsis_radius_km: float, mu: float, plane_normal_hint: np.ndarray
) -> np.ndarray:
    """Periapsis state (6,) [km, km/s] of the two-body hyperbola with incoming excess velocity ``v_inf_vec``.

    ``e = 1 + r_p v_inf^2 / mu``; with ``s`` the unit incoming asymptote (velocity direction at infinity),
    ``h`` the unit orbit normal (``plane_normal_hint`` made orthogonal to ``s``), ``w = h x s`` and
    ``k = sqrt(e^2 - 1)``: periapsis direction ``p = (s - k w) / e``, velocity direction ``q = h x p``,
    speed ``sqrt(v_inf^2 + 2 mu / r_p)``. (From the perifocal velocity at true anomaly ``-acos(-1/e)``,
    which points along ``(p + k q) / e``.)
    """
    v_inf_vec = require_finite("v_inf_vec", v_inf_vec)
    rp = require_positive("periapsis_radius_km", periapsis_radius_km)
    vinf = float(norm3(v_inf_vec))
    require_positive("|v_inf|", vinf)
    s = v_inf_vec / vinf
    hint = np.asarray(plane_normal_hint, float)
    h = hint - dot3(hint, s) * s
    if norm3(h) < 1e-9:
        raise InvalidParameterError("plane_normal_hint is parallel to v_inf: the orbit plane is undefined")
    h = unit3(h)
    e = 1.0 + rp * vinf**2 / mu
    k = np.sqrt(e * e - 1.0)
    p = (s - k * cross3(h, s)) / e
    q = cross3(h, p)
    vp = np.sqrt(vinf**2 + 2.0 * mu / rp)
    return np.concatenate([rp * p, vp * q])


@dataclass(frozen=True)
class ApproachConfig:
    """The approach trajectory and the time grid.

    closest_approach_tdb [TDB s since J2000]; v_inf_km_s [km/s]; periapsis_altitude_km [km above Mars's
    equatorial radius]; duration_h: start of the simulation before closest approach [h]; end_before_ca_h: end
    of the simulation before closest approach [h] (0 = at closest approach); dt_s: filter and truth grid
    step [s].
    """

    closest_approach_tdb: float = DEFAULT_CLOSEST_APPROACH_TDB
    v_inf_km_s: float = 2.65
    periapsis_altitude_km: float = 400.0
    duration_h: float = 96.0
    end_before_ca_h: float = 0.0
    dt_s: float = 60.0

    def __post_init__(self) -> None:
        for name in ("v_inf_km_s", "periapsis_altitude_km", "duration_h", "dt_s"):
            require_positive(f"ApproachConfig.{name}", getattr(self, name))
        if not np.isfinite(self.closest_approach_tdb):
            raise InvalidParameterError(
                f"closest_approach_tdb must be finite, got {self.closest_approach_tdb!r}"
            )
        if not 0.0 <= self.end_before_ca_h < self.duration_h:
            raise InvalidParameterError(
                f"end_before_ca_h must be in [0, duration_h={self.duration_h}), got {self.end_before_ca_h!r}"
            )
        span = (self.duration_h - self.end_before_ca_h) * 3600.0
        n = span / self.dt_s
        if abs(n - round(n)) > 1e-9 * max(1.0, n):
            raise InvalidParameterError(f"the span {span} s is not a whole number of steps dt_s={self.dt_s}")


class MarsApproach:
    """Truth trajectory, ephemeris tables and the force model of one approach (see the module docstring).

    Attributes: ``t`` (K+1,) grid [TDB s]; ``x_true`` (K+1, 6) [km, km/s, Mars-centred ICRF];
    ``mars_helio`` (K+1, 3) and ``mars_ssb`` (K+1, 3) [km]; ``model`` the GravityModel.
    """

    def __init__(self, config: ApproachConfig | None = None, ephemeris: DEEphemeris | None = None) -> None:
        self.config = cfg = config or ApproachConfig()
        self.eph = ephemeris or DEEphemeris()
        self.model = GravityModel(central="mars", perturbers=PERTURBERS)
        self.t0 = cfg.closest_approach_tdb - cfg.duration_h * 3600.0
        self.t_end = cfg.closest_approach_tdb - cfg.end_before_ca_h * 3600.0
        self.dt = cfg.dt_s
        self.n_steps = round((self.t_end - self.t0) / self.dt)
        self.t = self.t0 + self.dt * np.arange(self.n_steps + 1)
        # Perturber positions on the RK4 half-step grid: the filter's RK4 asks for exactly these times.
        self._half = 0.5 * self.dt
        t_half = self.t0 + self._half * np.arange(2 * self.n_steps + 1)
        self._pert_table = self.perturber_positions(t_half)
        self.mars_helio = self.eph.position("mars", self.t)
        self.mars_ssb = self.mars_helio + psr.sun_ssb_position(self.t)
        self.x_ca = self.periapsis_state()
        self.x_true = self._integrate_truth()

    # --- ephemeris ------------------------------------------------------------------------------------
    def perturber_positions(self, t: np.ndarray | float) -> np.ndarray:
        """Sun, Earth, Jupiter relative to Mars [km], shape ``t.shape + (3, 3)`` (body axis second last)."""
        t = np.asarray(t, float)
        mars = self.eph.position("mars", t)
        out = [(-mars if b == "sun" else self.eph.position(b, t) - mars) for b in PERTURBERS]
        return np.stack(out, axis=-2)

    def perturbers(self, t: float) -> np.ndarray:
        """``PerturberFn`` for the RK4 filter: tabulated on the half-step grid, exact elsewhere."""
        j = (t - self.t0) / self._half
        i = round(j)
        if abs(j - i) < 1e-6 and 0 <= i < self._pert_table.shape[0]:
            return self._pert_table[i]
        return self.perturber_positions(t)

    def periapsis_state(self) -> np.ndarray:
        """Two-body periapsis state at closest approach (6,) (see :func:`hyperbolic_periapsis_state`)."""
        cfg = self.config
        _, v_mars = self.eph.state("mars", cfg.closest_approach_tdb)
        v_inf = -cfg.v_inf_km_s * unit3(v_mars)
        rp = body("mars").radius + cfg.periapsis_altitude_km
        return hyperbolic_periapsis_state(v_inf, rp, self.model.mu_central, _ECLIPTIC_POLE)

    def _truth_steps(self) -> tuple[np.ndarray, np.ndarray]:
        """The truth's RK4 step ends, from closest approach back to the grid's start (decreasing times), and
        the index among them of each grid time, from the last grid time to the first."""
        t_ca = self.config.closest_approach_tdb
        near = t_ca - TRUTH_NEAR_CA_S
        marks = [t_ca, *(self.t[::-1] if self.t[-1] < t_ca else self.t[-2::-1])]
        times, keep = [np.array([t_ca])], [0] if self.t[-1] == t_ca else []
        n = 1
        for a, b in itertools.pairwise(marks):
            ends = [b] if a <= near or b >= near else [near, b]  # a piece lies in one zone
            for e in ends:
                step = TRUTH_STEP_NEAR_S if e >= near else TRUTH_STEP_FAR_S
                m = max(1, math.ceil((a - e) / step))
                times.append(a + (e - a) * (np.arange(1, m + 1) / m))
                times[-1][-1] = e
                n += m
                a = e
            keep.append(n - 1)
        return np.concatenate(times), np.asarray(keep, dtype=np.int64)

    def _integrate_truth(self) -> np.ndarray:
        """The truth on the grid (K + 1, 6): compiled RK4 backwards from the periapsis state, with a fixed
        order of arithmetic (the same bits on every CPU); see :data:`TRUTH_STEP_NEAR_S`."""
        times, keep = self._truth_steps()
        mid = times[:-1] + 0.5 * (times[1:] - times[:-1])
        pert_t = np.empty(2 * times.size - 1)
        pert_t[0::2], pert_t[1::2] = times, mid
        out = np.empty((keep.size, 6))
        rk4_path_kernel(
            np.asarray(self.x_ca, dtype=float), times, float(self.model.mu_central),
            np.ascontiguousarray(self.perturber_positions(pert_t)),
            np.asarray(self.model.mu_perturbers, dtype=float), keep, out,
        )  # fmt: skip
        return out[::-1].copy()

    def rk4_trajectory(self) -> np.ndarray:
        """The filter's fixed-step RK4 from the true initial state over the grid, (K+1, 6)."""
        out = np.empty((self.n_steps + 1, 6))
        x = self.x_true[:1].copy()
        out[0] = x[0]
        for k in range(self.n_steps):
            x = rk4_step(self.model, x, self.t[k], self.dt, self.perturbers)
            out[k + 1] = x[0]
        return out

    # --- geometry ---------------------------------------------------------------------------------------
    @property
    def hours(self) -> np.ndarray:
        """Grid times since the start [h]."""
        return (self.t - self.t0) / 3600.0

    def range_km(self) -> np.ndarray:
        """Distance from Mars's centre along the truth (K+1,) [km]."""
        return np.linalg.norm(self.x_true[:, :3], axis=-1)
