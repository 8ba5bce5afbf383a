"""GNSS-visibility antenna direction and the dipole field (Belokonov & Kramlikh 2007, functional (5)).

Geometry of the paper
---------------------
* Orbital frame O x2 y2 z2 (the paper's OSK): ``z2`` along the radius vector, ``y2`` along the orbital
  angular momentum ``r x v``, ``x2 = y2 x z2`` (along the velocity on a circular orbit).
  :func:`orbital_frame` returns the matrix ``C`` with ``v_orb = C @ v_eci``.
* The receiver antenna sits on the body x axis with a 180 deg beam (a hemisphere).
* Each satellite of the constellation is in one of three classes (the paper's "visible", "invisible
  because of the spacecraft structure", "invisible because the Earth blocks it"):

  - ``+1`` visible: the Earth does not block the line of sight *and* it lies in the antenna hemisphere,
    ``cos(antenna, los) >= 0`` (relation (4), first line);
  - ``-1`` not visible, shadowed by the structure: line of sight clear of the Earth but behind the
    antenna, ``cos < 0`` (relation (4), second line);
  - ``0`` Earth-shadowed: excluded from functional (5), as the paper says.

Functional (5) is ``Phi(u) = sum_visible (g_i.u - 1)^2 + sum_invisible (g_j.u + 1)^2`` =
``|G u - y|^2`` with the unit lines of sight ``g`` (orbital frame) stacked in ``G`` and targets
``y = +-1``. Two minimisers are provided (ERRATA 002 item 7):

* :func:`antenna_unconstrained`: the least-squares solution ``(G^T G)^-1 G^T y``, normalised afterwards;
* :func:`antenna_constrained`: the exact minimiser on the sphere ``|u| = 1`` (a trust-region-type
  subproblem): with ``A = G^T G = E diag(mu) E^T`` and ``c = G^T y``, the Lagrange condition is
  ``(A + alpha I) u = c`` with ``alpha >= -mu_min`` (second-order condition of the global minimum);
  ``alpha`` is the unique root of ``|u(alpha)| = 1`` on that interval, found by Newton's method on
  ``1/|u(alpha)| - 1`` (Reinsch / More-Sorensen: concave and increasing, so Newton from the left
  converges monotonically without safeguards). The "hard case" (``c`` orthogonal to the eigenvector
  of ``mu_min``) is handled explicitly.

Everything is batched over leading axes; frames and units are stated per function (km, rad, nT).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from planetnav_env.astro.bodies import BODIES
from planetnav_env.errors import DegenerateGeometryError, InvalidParameterError, require_finite

#: Earth's equatorial radius [km] (from ``bodies.py``); the Earth is a sphere of this radius for shadowing.
R_EARTH_KM = BODIES["earth"].radius
#: Equatorial surface field of the centred dipole [nT] (IGRF-era g10 ~ -29 400 nT; rounded). Only the
#: direction enters the attitude problem, so its exact value does not matter.
DIPOLE_B0_NT = 30_000.0

#: Relative threshold of ``det(G^T G) / (tr/3)^3`` under which the usable lines of sight are treated as
#: coplanar (functional (5) then does not fix the antenna direction).
COPLANAR_TOL = 1e-10


@dataclass(frozen=True)
class WalkerShell:
    """One Walker-delta shell ``T/P/F``: ``n_planes`` planes of ``per_plane`` satellites.

    Attributes: ``a_km`` semi-major axis [km], ``inc_deg`` inclination [deg], ``phasing`` the Walker F
    (inter-plane phase step ``F * 360 / T`` deg), ``name`` a label.
    """

    name: str
    n_planes: int
    per_plane: int
    inc_deg: float
    a_km: float
    phasing: int

    @property
    def size(self) -> int:
        return self.n_planes * self.per_plane

    def slots(self) -> tuple[np.ndarray, np.ndarray]:
        """Nominal RAAN and argument of latitude [rad] of every slot at phase 0, shapes (T,)."""
        p, j = np.divmod(np.arange(self.size), self.per_plane)
        raan = 2.0 * np.pi * p / self.n_planes
        u = 2.0 * np.pi * (j / self.per_plane + p * self.phasing / self.size)
        return raan, u


#: GPS idealised as Walker 24/6/2: six planes 60 deg apart at 55 deg, four equally spaced slots each,
#: a = 26 560 km. (The real slots are unevenly spaced; the paper gives no geometry.)
GPS = WalkerShell("GPS", n_planes=6, per_plane=4, inc_deg=55.0, a_km=26_560.0, phasing=2)
#: GLONASS nominal: Walker 24/3/1, three planes 120 deg apart at 64.8 deg, eight slots 45 deg apart,
#: 15 deg inter-plane phase step, a = 25 510 km.
GLONASS = WalkerShell("GLONASS", n_planes=3, per_plane=8, inc_deg=64.8, a_km=25_510.0, phasing=1)
#: The paper's 48 navigation satellites.
CONSTELLATION: tuple[WalkerShell, ...] = (GPS, GLONASS)


def _orbit_positions(a_km: np.ndarray, inc: np.ndarray, raan: np.ndarray, u: np.ndarray) -> np.ndarray:
    """ECI positions [km] on circular orbits (broadcast over all arguments), shape (..., 3)."""
    cu, su = np.cos(u), np.sin(u)
    co, so = np.cos(raan), np.sin(raan)
    ci, si = np.cos(inc), np.sin(inc)
    return a_km[..., None] * np.stack([co * cu - so * su * ci, so * cu + co * su * ci, su * si], axis=-1)


@functools.lru_cache(maxsize=4)
def _shell_basis(shells: tuple[WalkerShell, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Nominal positions X0 (K, 3) [km] and X0 advanced by 90 deg along track, Y0, at phase 0."""
    x0, y0 = [], []
    for shell in shells:
        raan, u = shell.slots()
        a = np.full(raan.shape, shell.a_km)
        inc = np.full(raan.shape, np.radians(shell.inc_deg))
        x0.append(_orbit_positions(a, inc, raan, u))
        y0.append(_orbit_positions(a, inc, raan, u + 0.5 * np.pi))
    return np.concatenate(x0), np.concatenate(y0)


def constellation_positions(
    raan_offset: np.ndarray, phase_offset: np.ndarray, shells: tuple[WalkerShell, ...] = CONSTELLATION
) -> np.ndarray:
    """Frozen constellation positions [km, ECI], shape (N, sum of shell sizes, 3).

    ``raan_offset`` and ``phase_offset`` [rad], shape (N, len(shells)): each shell is advanced along its
    orbits by ``phase_offset`` and turned rigidly about the Earth's axis by ``raan_offset``, which keeps
    its nominal slot pattern (a "frozen" constellation at a random epoch, as in the paper's stage 1).
    """
    raan_offset = np.atleast_2d(np.asarray(raan_offset, dtype=float))
    phase_offset = np.atleast_2d(np.asarray(phase_offset, dtype=float))
    x0, y0 = _shell_basis(tuple(shells))
    sizes = [s.size for s in shells]
    # Advancing every satellite of a circular shell by the same angle f is x0 cos f + y0 sin f: no per-
    # satellite trigonometry, which dominated the run time.
    cf = np.repeat(np.cos(phase_offset), sizes, axis=1)[..., None]
    sf = np.repeat(np.sin(phase_offset), sizes, axis=1)[..., None]
    p = cf * x0 + sf * y0
    cw = np.repeat(np.cos(raan_offset), sizes, axis=1)
    sw = np.repeat(np.sin(raan_offset), sizes, axis=1)
    out = np.empty_like(p)
    out[..., 0] = cw * p[..., 0] - sw * p[..., 1]
    out[..., 1] = sw * p[..., 0] + cw * p[..., 1]
    out[..., 2] = p[..., 2]
    return out


def circular_orbit(
    radius_km: float, inc: np.ndarray, raan: np.ndarray, u: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Position [km] and unit velocity direction (ECI) on a circular orbit, shapes (..., 3)."""
    inc, raan, u = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (inc, raan, u)))
    a = np.full(u.shape, float(radius_km))
    r = _orbit_positions(a, inc, raan, u)
    v = _orbit_positions(np.ones(u.shape), inc, raan, u + 0.5 * np.pi)  # d/du of the unit position
    return r, v


def orbital_frame(r: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Matrix ``C`` (..., 3, 3) with ``v_orb = C @ v_eci``; rows x2, y2, z2 (z2 radial, y2 along r x v)."""
    r = np.asarray(r, dtype=float)
    z = r / np.linalg.norm(r, axis=-1, keepdims=True)
    y = np.cross(r, v)
    y = y / np.linalg.norm(y, axis=-1, keepdims=True)
    x = np.cross(y, z)
    return np.stack([x, y, z], axis=-2)


def earth_blocks(r_rx: np.ndarray, r_tx: np.ndarray, radius_km: float = R_EARTH_KM) -> np.ndarray:
    """True where the segment receiver -> transmitter passes through the sphere of ``radius_km``.

    ``r_rx`` (..., 3) and ``r_tx`` (..., K, 3) [km, ECI], result (..., K) bool. Both ends must lie outside
    the sphere (checked by the callers through the altitude).
    """
    r_rx = np.asarray(r_rx, dtype=float)
    d = np.asarray(r_tx, dtype=float) - r_rx[..., None, :]
    dd = np.einsum("...ki,...ki->...k", d, d)
    rd = np.einsum("...ki,...i->...k", d, r_rx)
    t = -rd / dd  # parameter of the closest approach of the line to the centre
    closest2 = np.einsum("...i,...i->...", r_rx, r_rx)[..., None] - rd * rd / dd
    return (t > 0.0) & (t < 1.0) & (closest2 < radius_km * radius_km)


def dipole_field(
    r_eci: np.ndarray, b0_nt: float = DIPOLE_B0_NT, axis: np.ndarray | None = None
) -> np.ndarray:
    """Centred dipole field [nT, ECI] at ``r_eci`` (..., 3) [km].

    ``B = b0 (R_E/r)^3 (3 (m.r_hat) r_hat - m)`` with unit dipole axis ``m``; the default ``m = -z`` is the
    paper's "direct" (axial) dipole, whose field at the equator points north (+z). For an axial dipole
    the field in the orbital frame depends only on the argument of latitude and the inclination.
    """
    r = np.asarray(r_eci, dtype=float)
    m = np.array([0.0, 0.0, -1.0]) if axis is None else np.asarray(axis, dtype=float)
    m = m / np.linalg.norm(m)
    rn = np.linalg.norm(r, axis=-1, keepdims=True)
    rh = r / rn
    return b0_nt * (R_EARTH_KM / rn) ** 3 * (3.0 * np.sum(rh * m, axis=-1, keepdims=True) * rh - m)


def classify_satellites(los_orb: np.ndarray, antenna_orb: np.ndarray, blocked: np.ndarray) -> np.ndarray:
    """The paper's classes: +1 visible, -1 behind the antenna (structure), 0 Earth-shadowed; (..., K) int8.

    ``los_orb`` (..., K, 3) unit lines of sight, ``antenna_orb`` (..., 3) unit antenna axis, both in the
    orbital frame; ``blocked`` (..., K) from :func:`earth_blocks`. Relation (4): visible iff cos >= 0.
    """
    cos = np.einsum("...ki,...i->...k", los_orb, antenna_orb)
    cls = np.where(cos >= 0.0, 1, -1).astype(np.int8)
    return np.where(blocked, np.int8(0), cls)


def antenna_functional(u: np.ndarray, los: np.ndarray, cls: np.ndarray) -> np.ndarray:
    """Functional (5) at ``u`` (..., 3): ``sum_{cls=+1} (g.u - 1)^2 + sum_{cls=-1} (g.u + 1)^2``, (...)."""
    res = np.einsum("...ki,...i->...k", los, u) - cls
    return np.sum(np.where(cls != 0, res * res, 0.0), axis=-1)


def normal_equations(los: np.ndarray, cls: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``A = G^T G`` (..., 3, 3) and ``c = G^T y`` (..., 3) of functional (5), non-excluded satellites only.

    ``Phi(u) = u^T A u - 2 c^T u + n_used``. Raises :class:`DegenerateGeometryError` when the usable lines
    of sight do not span space (fewer than three, or coplanar): then (5) does not fix the direction.
    """
    los = require_finite("lines of sight", los)
    cls = np.asarray(cls)
    if los.shape[-1] != 3 or los.shape[:-1] != cls.shape:
        raise InvalidParameterError(f"los must be (..., K, 3) and cls (..., K); got {los.shape}, {cls.shape}")
    if not np.all((cls == 1) | (cls == 0) | (cls == -1)):
        raise InvalidParameterError(
            "satellite classes must be +1 (visible), -1 (not visible) or 0 (excluded)"
        )
    used = (cls != 0).astype(float)
    gm = los * used[..., None]
    a = np.swapaxes(gm, -1, -2) @ los
    c = np.einsum("...ki,...k->...i", los, cls.astype(float))
    tr = np.trace(a, axis1=-2, axis2=-1)
    det = np.linalg.det(a)
    bad = ~(det > COPLANAR_TOL * (tr / 3.0) ** 3)
    if np.any(bad):
        idx = np.argwhere(bad)[:4].tolist() if bad.ndim else []
        n_used = used.sum(axis=-1)
        raise DegenerateGeometryError(
            "functional (5) does not fix the antenna direction: fewer than three non-coplanar satellites "
            f"outside the Earth's shadow at batch index {idx} (usable satellites there: "
            f"{np.atleast_1d(n_used[bad])[:4].astype(int).tolist()})"
        )
    return a, c


def antenna_unconstrained(los: np.ndarray, cls: np.ndarray) -> np.ndarray:
    """Least-squares minimiser of (5) without the constraint, then normalised: unit (..., 3), orbital frame.

    Raises :class:`DegenerateGeometryError` if the usable lines of sight are coplanar (or fewer than 3) or
    the least-squares solution is the zero vector.
    """
    return unconstrained_from_normal(*normal_equations(los, cls))


def unconstrained_from_normal(a: np.ndarray, c: np.ndarray) -> np.ndarray:
    """:func:`antenna_unconstrained` from validated normal equations (see :func:`normal_equations`)."""
    u = np.linalg.solve(a, c[..., None])[..., 0]
    n = np.linalg.norm(u, axis=-1, keepdims=True)
    if np.any(n == 0.0):
        raise DegenerateGeometryError(
            "least-squares antenna direction is the zero vector (visible and "
            "invisible satellites balance exactly)"
        )
    return u / n


def antenna_constrained(los: np.ndarray, cls: np.ndarray, iterations: int = 60) -> np.ndarray:
    """Exact minimiser of (5) on the unit sphere (see the module docstring): unit (..., 3), orbital frame.

    Newton's iteration runs on the whole batch (vectorised) until every member has converged (quadratic
    convergence: typically under 10 steps) or ``iterations`` steps; the result is checked to
    ``| |u| - 1 | < 1e-9``.
    """
    return constrained_from_normal(*normal_equations(los, cls), iterations=iterations)


def constrained_from_normal(a: np.ndarray, c: np.ndarray, iterations: int = 60) -> np.ndarray:
    """:func:`antenna_constrained` from validated normal equations (see :func:`normal_equations`)."""
    mu, e = np.linalg.eigh(a)
    d = np.einsum("...ji,...j->...i", e, c)  # c in the eigenbasis
    gap = mu - mu[..., :1]  # >= 0, exactly 0 for the smallest
    scale = np.maximum(np.linalg.norm(c, axis=-1), 1e-300)
    # delta = alpha + mu_min > 0 is the distance from the pole. At delta0 = |d_0| the first term alone
    # gives |u| >= 1, so delta0 lies left of the root, where Newton on the concave 1/|u| is monotone.
    delta = np.maximum(np.abs(d[..., 0]), 1e-14 * scale)
    d2 = d * d
    for _ in range(iterations):
        inv = 1.0 / (gap + delta[..., None])
        t2 = d2 * inv * inv
        n2 = np.sum(t2, axis=-1)
        n1 = np.sqrt(n2)
        step = (1.0 - 1.0 / n1) * (n1 * n2) / np.sum(t2 * inv, axis=-1)
        delta = delta + step
        # Monotone convergence from the left: stop once every member has stopped moving.
        if np.all(step <= 1e-15 * delta):
            break
    den = gap + delta[..., None]
    coef = d / den
    # Hard case: c (almost) orthogonal to the smallest eigenvector and the other terms alone shorter
    # than 1: the minimum sits at alpha = -mu_min and u gets the missing length along e_0.
    rest = np.where(gap > 0.0, d / np.where(gap > 0.0, gap, 1.0), 0.0)
    rest[..., 0] = 0.0
    rest_n2 = np.sum(rest * rest, axis=-1)
    hard = (np.abs(d[..., 0]) <= 1e-12 * scale) & (rest_n2 <= 1.0)
    if np.any(hard):
        rest[..., 0] = np.sqrt(np.maximum(1.0 - rest_n2, 0.0))
        coef = np.where(hard[..., None], rest, coef)
    u = np.einsum("...ij,...j->...i", e, coef)
    norm = np.linalg.norm(u, axis=-1)
    if not np.all(np.abs(norm - 1.0) < 1e-9):
        worst = float(np.max(np.abs(norm - 1.0)))
        raise DegenerateGeometryError(
            f"sphere-constrained minimiser of (5) did not converge (| |u|-1 | = {worst})"
        )
    return u / norm[..., None]


def validate_altitude(altitude_km: float) -> float:
    """Return the altitude [km] or raise :class:`InvalidParameterError` if it is not a LEO-to-MEO receiver.

    Valid: ``0 < h < a_min - R_E`` with ``a_min`` the lowest navigation-satellite orbit (GLONASS,
    19 132 km altitude): above it the receiver would be among or above the transmitters, which the
    paper's geometry (antenna hemisphere, Earth shadowing) does not describe.
    """
    h = float(altitude_km)
    h_max = min(s.a_km for s in CONSTELLATION) - R_EARTH_KM
    if not np.isfinite(h) or h <= 0.0 or h >= h_max:
        raise InvalidParameterError(
            f"altitude must be in (0, {h_max:.0f}) km (above the Earth's surface, below the GNSS orbits); "
            f"got {altitude_km!r}"
        )
    return h
