"""Camera errors from the image: the centroid and apparent-diameter sigmas of one planet image, from the
disk's size in pixels and the image's signal-to-noise ratio (the flight world's ``world.image_errors``).

The model, per image (D the disk's diameter [px], w the optics' Gaussian PSF sigma [px], SNR the image's):

* **Signal.** A Lambertian planet of geometric albedo p, radius R, at ``r`` from the Sun and ``L`` from
  the camera, at phase angle alpha, sends the camera ``S_raw = E_sun A t p Phi(alpha) (R / L)^2
  (1 AU / r)^2`` photo-electrons (:func:`planet_electrons`: ``E_sun`` the Sun's photo-electron rate per
  m^2 at 1 AU, ``A`` the aperture's area, ``t`` the exposure, ``Phi`` the Lambert phase function of
  :mod:`planetnav_env.sensors.photometry`). The image covers ``n = pi D^2 / 4 + 4 pi w^2`` pixels; the
  camera shortens its exposure so that their mean stays below a pixel's full well, ``S = min(S_raw,
  FW n)``, and ``SNR = S / sqrt(S + n sigma_read^2)`` (:func:`image_snr`).
* **Photon term.** The image is the uniform disk convolved with the PSF; a centroid of ``N = SNR^2``
  photo-electrons drawn from it scatters per axis by its rms width over ``sqrt(N)``: ``sqrt(w^2 + D^2 /
  16) / SNR``. The diameter, from the PSF-corrected second moment of the radius, ``D_hat = 2 sqrt(2
  (<rho^2> - 2 w^2))``, scatters by ``(4 / D) sqrt(Var rho^2) / SNR``, ``Var rho^2 = D^4 / 192 + w^2 D^2 /
  2 + 4 w^4`` (the disk's ``R^4 / 12``, the cross term ``2 w^2 R^2`` and the PSF's ``4 w^4``): a sub-pixel
  disk's diameter is poorly measured, a resolved one's well.
* **Floor** ``f`` [px]: a bright point image's centroid (pixel response, PSF-model and distortion
  residuals), ``2 f`` for the diameter (two edges).
* **Limb term** ``k D``: a resolved disk's limb is not the model's (relief, haze, the terminator's
  shading), a scatter of a fixed fraction ``k`` of the diameter per image in the centroid, ``2 k D`` in
  the diameter.

The three add in quadrature (:func:`centroid_sigma_px`, :func:`diameter_sigma_px`): the sigma grows with
the disk's size and falls with its SNR. ``tests/env/test_image_noise.py`` holds the photon terms to Monte
Carlo draws of their definition (photo-electrons drawn from the PSF-blurred disk). The magnitudes and their
sources are in ``docs/flight_world.md``.
"""

from __future__ import annotations

import math

from planetnav_env.astro.bodies import AU_KM
from planetnav_env.numerics.jit import row_kernel
from planetnav_env.sensors.photometry import lambert_phase_function

#: The Sun's V magnitude at 1 AU: Willmer (2018), "The absolute magnitude of the Sun in several filters",
#: ApJS 236:47, table 3 (-26.76).
V_SUN = -26.76
#: Photo-electrons per second and m^2 of aperture from a V = 0 source: the V-band zero point of ~1,000
#: photons cm^-2 s^-1 A^-1 (Bessell, Castelli & Plez 1998, A&A 333:231) over an 880 A band is 8.8e9
#: photons s^-1 m^-2; a broadband CMOS sensor collects about twice the band at a quantum efficiency of
#: about 0.6, so ~1e10 (a round stated assumption).
V0_ELECTRONS_M2_S = 1.0e10
#: Photo-electrons per second and m^2 of aperture from the Sun at 1 AU.
SUN_ELECTRONS_M2_S = V0_ELECTRONS_M2_S * 10.0 ** (-0.4 * V_SUN)


@row_kernel
def planet_electrons(
    albedo, radius_km, sun_km, range_km, cos_phase, collect_m2_s
) -> float:  # pragma: no cover
    """Photo-electrons [e-] a camera of aperture area times exposure ``collect_m2_s`` [m^2 s] collects from a
    Lambertian planet of geometric ``albedo`` and radius ``radius_km`` [km], ``sun_km`` [km] from the Sun
    and ``range_km`` [km] from the camera, at phase angle ``acos(cos_phase)`` (the module's ``S_raw``)."""
    rr = radius_km / range_km
    rs = AU_KM / sun_km
    return SUN_ELECTRONS_M2_S * collect_m2_s * albedo * lambert_phase_function(cos_phase) * rr * rr * rs * rs


@row_kernel
def image_snr(electrons, d_px, psf_px, full_well_e, read_noise_e) -> float:  # pragma: no cover - compiled
    """The image's SNR: ``S = min(electrons, full_well_e * n)`` over ``sqrt(S + n read_noise_e^2)``, with
    ``n = pi d_px^2 / 4 + 4 pi psf_px^2`` the pixels it covers (the exposure shortened to stay below the
    full well [e-]); 0 without signal."""
    n = math.pi * (0.25 * d_px * d_px + 4.0 * psf_px * psf_px)
    s = min(electrons, full_well_e * n)
    if s <= 0.0:
        return 0.0
    return s / math.sqrt(s + n * read_noise_e * read_noise_e)


@row_kernel
def photon_centroid_px(d_px, snr, psf_px) -> float:  # pragma: no cover - compiled
    """The photon term of the centroid's sigma per axis [px]: ``sqrt(psf^2 + d^2 / 16) / snr``."""
    return math.sqrt(psf_px * psf_px + d_px * d_px / 16.0) / max(snr, 1e-9)


@row_kernel
def photon_diameter_px(d_px, snr, psf_px) -> float:  # pragma: no cover - compiled
    """The photon term of the diameter's sigma [px]: ``(4 / d) sqrt(d^4 / 192 + psf^2 d^2 / 2 + 4 psf^4) /
    snr`` (``d`` kept above 1e-6 px)."""
    d = max(d_px, 1e-6)
    w2 = psf_px * psf_px
    var_rho2 = d * d * d * d / 192.0 + 0.5 * w2 * d * d + 4.0 * w2 * w2
    return 4.0 / d * math.sqrt(var_rho2) / max(snr, 1e-9)


@row_kernel
def centroid_sigma_px(d_px, snr, psf_px, floor_px, limb) -> float:  # pragma: no cover - compiled
    """The centroid's sigma per image axis [px] of a disk of ``d_px`` [px] at ``snr``: floor, photon and
    limb terms in quadrature (module docstring)."""
    ph = photon_centroid_px(d_px, snr, psf_px)
    lb = limb * d_px
    return math.sqrt(floor_px * floor_px + ph * ph + lb * lb)


@row_kernel
def diameter_sigma_px(d_px, snr, psf_px, floor_px, limb) -> float:  # pragma: no cover - compiled
    """The diameter's sigma [px] of a disk of ``d_px`` [px] at ``snr``: ``2 floor``, photon and ``2 limb
    d`` terms in quadrature (module docstring)."""
    ph = photon_diameter_px(d_px, snr, psf_px)
    lb = 2.0 * limb * d_px
    fl = 2.0 * floor_px
    return math.sqrt(fl * fl + ph * ph + lb * lb)
