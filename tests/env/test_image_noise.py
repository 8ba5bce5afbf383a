"""The flight world's image-driven camera errors: the photon terms of the centroid and diameter sigmas
against Monte Carlo draws of their stated definition (photo-electrons drawn from the PSF-blurred uniform
disk), the planets' brightness against their published absolute magnitudes, and the env's wiring of the
model into the truth's image."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from planetnav_env.astro.bodies import AU_KM, body
from planetnav_env.batch import BatchCore
from planetnav_env.config import EnvConfig
from planetnav_env.core import sensing
from planetnav_env.core.records import make_scratch
from planetnav_env.envs.registration import ENV_IDS
from planetnav_env.sensors.image_noise import (
    V_SUN,
    centroid_sigma_px,
    diameter_sigma_px,
    image_snr,
    photon_centroid_px,
    photon_diameter_px,
    planet_electrons,
)
from planetnav_env.sensors.photometry import GEOMETRIC_ALBEDO, lambert_phase_function


def _photon_estimates(d_px: float, psf: float, n: int, trials: int, seed: int) -> tuple[np.ndarray, ...]:
    """Per trial: the centroid's x and the PSF-corrected second-moment diameter 2 sqrt(2 (<rho^2> - 2
    psf^2)) of ``n`` photo-electrons drawn uniformly on a disk of diameter ``d_px`` and blurred by a
    Gaussian PSF of sigma ``psf`` [px] (the model's definition of its photon terms)."""
    rng = np.random.default_rng(seed)
    cx = np.empty(trials)
    dd = np.empty(trials)
    r_disk = 0.5 * d_px
    for k in range(trials):
        rad = r_disk * np.sqrt(rng.random(n))
        ang = 2.0 * math.pi * rng.random(n)
        x = rad * np.cos(ang) + psf * rng.standard_normal(n)
        y = rad * np.sin(ang) + psf * rng.standard_normal(n)
        cx[k] = x.mean()
        m = float(np.mean(x * x + y * y))
        dd[k] = 2.0 * math.sqrt(2.0 * max(m - 2.0 * psf * psf, 0.0))
    return cx, dd


@pytest.mark.parametrize(
    "d_px,n", [(0.0, 2_500), (1.0, 40_000), (4.0, 10_000), (20.0, 2_500), (60.0, 900)]
)  # fmt: skip
def test_photon_terms_match_monte_carlo_of_their_definition(d_px, n):
    psf, trials = 0.7, 1500
    cx, dd = _photon_estimates(d_px, psf, n, trials, seed=int(10 * d_px) + n)
    snr = math.sqrt(n)  # photon-limited: N photo-electrons give SNR sqrt(N)
    tol = 5.0 / math.sqrt(2.0 * trials)  # five standard errors of a sample standard deviation
    assert np.std(cx) == pytest.approx(photon_centroid_px(d_px, snr, psf), rel=tol)
    if d_px > 0.0:
        assert np.mean(dd) == pytest.approx(d_px, rel=0.02)  # the estimator is the diameter
        assert np.std(dd) == pytest.approx(photon_diameter_px(d_px, snr, psf), rel=tol)


def test_sigmas_grow_with_the_disk_and_fall_with_the_snr():
    psf, floor, limb = 0.7, 0.05, 1e-3
    sizes = [0.1, 1.0, 10.0, 100.0, 1000.0]
    for snr in (30.0, 300.0):
        c = [centroid_sigma_px(d, snr, psf, floor, limb) for d in sizes]
        assert all(b > a for a, b in itertools.pairwise(c))
    for d in sizes:
        c = [centroid_sigma_px(d, s, psf, floor, limb) for s in (5.0, 50.0, 500.0)]
        dm = [diameter_sigma_px(d, s, psf, floor, limb) for s in (5.0, 50.0, 500.0)]
        assert all(b < a for a, b in itertools.pairwise(c))
        assert all(b < a for a, b in itertools.pairwise(dm))
    # The terms add in quadrature; the floor alone at infinite SNR on a point image.
    assert centroid_sigma_px(0.0, 1e12, psf, floor, limb) == pytest.approx(floor, rel=1e-9)
    assert diameter_sigma_px(50.0, 1e12, psf, floor, limb) == pytest.approx(
        math.hypot(2 * floor, 0.1), rel=1e-9
    )


def test_snr_caps_at_the_full_well_and_adds_read_noise():
    d, psf, fw = 3.0, 0.7, 2e4
    n_pix = math.pi * (d * d / 4.0 + 4.0 * psf * psf)
    assert image_snr(1e4, d, psf, fw, 0.0) == pytest.approx(100.0, rel=1e-12)  # photon-limited
    assert image_snr(1e12, d, psf, fw, 0.0) == pytest.approx(math.sqrt(fw * n_pix), rel=1e-12)
    assert image_snr(1e4, d, psf, fw, 10.0) == pytest.approx(1e4 / math.sqrt(1e4 + 100.0 * n_pix), rel=1e-12)


#: Absolute magnitudes V(1, 0) at zero phase: Mallama & Hilton (2018), "Computing apparent planetary
#: magnitudes for The Astronomical Almanac", Astronomy and Computing 25:10 (Jupiter's and Mars's at their
#: mean figure).
H_V = {"mercury": -0.613, "venus": -4.384, "earth": -3.99, "mars": -1.601, "jupiter": -9.395}


@pytest.mark.parametrize("name", sorted(H_V))
def test_planet_brightness_matches_the_published_magnitudes(name):
    """The electrons of a planet at 1 AU from both the Sun and the camera at full phase, as a V
    magnitude (the Sun's through the same constant), against its published absolute magnitude."""
    b = body(name)
    collect = 1.0
    sun = planet_electrons(1.0, AU_KM, AU_KM, AU_KM, 1.0, collect)  # p = 1, R / L = 1: the Sun's rate
    e = planet_electrons(GEOMETRIC_ALBEDO[name], b.radius, AU_KM, AU_KM, 1.0, collect)
    v = V_SUN - 2.5 * math.log10(e / sun)
    assert v == pytest.approx(H_V[name], abs=0.1)
    # The phase law: the Lambert phase function, 1/pi of full phase at quadrature.
    q = planet_electrons(GEOMETRIC_ALBEDO[name], b.radius, AU_KM, AU_KM, 0.0, collect)
    assert q / e == pytest.approx(1.0 / math.pi, rel=1e-12)
    assert lambert_phase_function(-1.0) == 0.0


def test_the_truth_image_reads_the_model_at_the_row_geometry():
    """sensing._image_sigmas on a hand-made geometry equals the model evaluated here from the world's
    options (aperture [mm] -> area [m^2], pixels from the camera's focal length)."""
    world = {"image_errors": True, "aperture_mm": 25.0, "exposure_s": 0.01, "read_noise_e": 30.0}
    cfg = EnvConfig.from_dict({**ENV_IDS["planetnav/Cruise-Target-v2"], "episode_steps": 4, "world": world})
    core = BatchCore(cfg, 1)
    prm = core.params
    sc = make_scratch(prm)
    idx = cfg.planets.index("mars")
    planet = np.array([1.2 * AU_KM, 0.8 * AU_KM, 0.1 * AU_KM])
    sc.tplanets[idx] = planet  # the truth's planet: the image's own geometry
    sun_dir = -planet / np.linalg.norm(planet)
    side = np.cross(sun_dir, [0.0, 0.0, 1.0])
    side /= np.linalg.norm(side)
    w = cfg.world
    f_px = cfg.camera.f_px
    r_km = body("mars").radius
    for phase_deg, dist in ((30.0, 2e6), (100.0, 3e7), (150.0, 4e8)):
        ph = math.radians(phase_deg)
        u = math.cos(ph) * sun_dir + math.sin(ph) * side  # planet -> camera
        sc.r1[0] = planet + dist * u
        sc.t1[0] = planet
        s_dir, s_alpha = sensing._image_sigmas(prm, sc, idx, r_km)
        d_px = 2.0 * math.asin(r_km / dist) * f_px
        collect = math.pi * (0.5e-3 * w.aperture_mm) ** 2 * w.exposure_s
        e = planet_electrons(
            GEOMETRIC_ALBEDO["mars"], r_km, np.linalg.norm(planet), dist, math.cos(ph), collect
        )
        snr = image_snr(e, d_px, w.psf_sigma_px, w.full_well_e, w.read_noise_e)
        args = (d_px, snr, w.psf_sigma_px, w.centroid_floor_px, w.limb_scatter)
        assert s_dir == pytest.approx(centroid_sigma_px(*args) / f_px, rel=1e-9)
        assert s_alpha == pytest.approx(diameter_sigma_px(*args) / f_px, rel=1e-9)
