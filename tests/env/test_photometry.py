"""The Lambertian centre of brightness against a brute-force rendering of the lit sphere."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from planetnav_env.sensors.photometry import COB_LAMBERT_QUADRATURE, lambert_cob_offset


def rendered_cob(phase: float, pixels: int = 1601) -> float:
    """Centroid [disk radii] of an image of a unit Lambertian sphere at phase angle ``phase`` [rad], by
    rendering: each pixel centre inside the disk is a ray along -z that meets the sphere at
    ``n = (x, y, sqrt(1 - x^2 - y^2))``; its radiance is ``max(n . s, 0)`` with the Sun at
    ``s = (sin phase, 0, cos phase)``. Orthographic projection (a planet far from the camera)."""
    u = (np.arange(pixels) + 0.5) / pixels * 2.0 - 1.0
    x, y = np.meshgrid(u, u, indexing="xy")
    inside = x * x + y * y < 1.0
    nz = np.sqrt(np.where(inside, 1.0 - x * x - y * y, 0.0))
    radiance = np.where(inside, np.maximum(x * math.sin(phase) + nz * math.cos(phase), 0.0), 0.0)
    return float((radiance * x).sum() / radiance.sum())


@pytest.mark.parametrize("phase_deg", [5.0, 20.0, 45.0, 79.0, 90.0, 93.0, 120.0, 150.0, 170.0])
def test_lambert_cob_matches_rendering(phase_deg):
    phase = math.radians(phase_deg)
    expected = rendered_cob(phase)
    # The rendering itself is good to ~1e-4 at 1601 pixels across.
    assert lambert_cob_offset(math.cos(phase)) == pytest.approx(expected, rel=1e-3)


def test_lambert_cob_limits():
    assert lambert_cob_offset(1.0) == 0.0  # full phase: the disk is lit evenly about its centre
    assert lambert_cob_offset(0.0) == pytest.approx(COB_LAMBERT_QUADRATURE, rel=1e-15)
    eps = 1e-3  # a thin crescent: the offset tends to 9 pi / 32 of the radius
    assert lambert_cob_offset(math.cos(math.pi - eps)) == pytest.approx(9.0 * math.pi / 32.0, rel=1e-4)
    assert lambert_cob_offset(-1.0) == 0.0  # nothing lit
    assert lambert_cob_offset(1.5) == 0.0  # clipped to full phase


def test_lambert_cob_grows_with_phase():
    offsets = [lambert_cob_offset(math.cos(math.radians(a))) for a in range(0, 180, 5)]
    assert all(b > a for a, b in itertools.pairwise(offsets))
