"""Photometry of a sunlit planet's image: where its centre of brightness lies.

A camera that centroids a planet's image finds the centre of brightness, not the centre of the disk:
at phase angle ``alpha`` (Sun-planet-camera) the lit part of the disk lies toward the Sun, and the
centroid is displaced that way. For a Lambertian sphere (radiance proportional to the cosine of the
incidence angle) the displacement has a closed form. With the camera on the +z axis of the planet's
frame and the Sun in the x-z plane at ``s = (sin alpha, 0, cos alpha)``, a surface point of normal
``n = (cos b sin l, sin b, cos b cos l)`` is seen where ``n_z > 0`` and lit where ``n . s > 0``; its image
brightness per unit solid angle of the sphere is ``(n . s) n_z``, so the flux and its first moment along x
are ``int cos^3 b db int cos l cos(l - alpha) dl`` and ``int cos^4 b db int sin l cos l cos(l - alpha) dl``
over the lune ``l in [alpha - pi/2, pi/2]``. They give

    offset / R = (3 pi / 16) sin(alpha) (1 + cos(alpha)) / (sin(alpha) + (pi - alpha) cos(alpha))

in units of the disk's apparent radius, toward the Sun's direction across the line of sight: 0 at full
phase, 3 pi / 16 = 0.589 at quadrature, and toward 9 pi / 32 = 0.884 as the crescent thins
(``tests/env/test_photometry.py`` holds it to a brute-force rendering of the lit sphere).
"""

from __future__ import annotations

import math

from planetnav_env.numerics.jit import row_kernel

#: The Lambertian sphere's centre-of-brightness offset at quadrature (alpha = 90 deg), in disk radii.
COB_LAMBERT_QUADRATURE = 3.0 * math.pi / 16.0

#: Geometric albedos (V band) of the bodies a camera may target: Mallama, Krobusek & Pavlov (2017),
#: "Comprehensive wide-band magnitudes and albedos for the planets, with applications to exo-planets and
#: Planet Nine", Icarus 282:19, table 12; the Moon's 0.12 is the classical value (Allen's Astrophysical
#: Quantities, 4th ed., sec. 12.3). The image-driven camera errors read them (the planet's brightness).
GEOMETRIC_ALBEDO = {
    "mercury": 0.142,
    "venus": 0.689,
    "earth": 0.434,
    "moon": 0.12,
    "mars": 0.170,
    "jupiter": 0.538,
    "saturn": 0.499,
}


@row_kernel
def lambert_phase_function(cos_phase: float) -> float:  # pragma: no cover - compiled
    """The Lambertian sphere's phase function Phi(alpha) = (sin alpha + (pi - alpha) cos alpha) / pi, its
    flux at phase angle ``acos(cos_phase)`` over its flux at full phase (1 at 0, 1/pi at quadrature, 0 at
    pi): the lune integral of the module docstring, ``cos_phase`` clipped to [-1, 1]."""
    c = min(max(cos_phase, -1.0), 1.0)
    return max(0.0, _lune_flux(c)) / math.pi


@row_kernel
def _lune_flux(c: float) -> float:  # pragma: no cover - compiled
    """sin(alpha) + (pi - alpha) cos(alpha) at cos(alpha) = ``c`` in [-1, 1]."""
    return math.sqrt(max(0.0, 1.0 - c * c)) + (math.pi - math.acos(c)) * c


@row_kernel
def lambert_cob_offset(cos_phase: float) -> float:  # pragma: no cover - compiled
    """Centre-of-brightness offset of a Lambertian sphere at phase angle ``acos(cos_phase)``, in units of
    its apparent radius, toward the Sun across the line of sight (see the module docstring). ``cos_phase``
    is clipped to [-1, 1]; at ``alpha = pi`` (the night side facing the camera) nothing is lit and 0 is
    returned."""
    c = min(max(cos_phase, -1.0), 1.0)
    s = math.sqrt(max(0.0, 1.0 - c * c))
    flux = _lune_flux(c)
    if flux <= 0.0:
        return 0.0
    return COB_LAMBERT_QUADRATURE * s * (1.0 + c) / flux
