"""An oblate planet's outline against a brute-force rendering of its silhouette."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planetnav_env.astro.bodies import body
from planetnav_env.sensors.figure import equal_area_radius, limb_minor_axis


def rendered_outline(a: float, c: float, beta: float, pixels: int = 2001) -> tuple[float, float, float]:
    """Semi-axes along the image's x (across the pole) and y (along its projection), and the area, of the
    silhouette of the spheroid x^2/a^2 + y^2/a^2 + z^2/c^2 = 1 seen along the direction at latitude
    ``beta``: a pixel is inside when its ray meets the spheroid (the discriminant of the ray's quadratic
    is non-negative). Orthographic projection."""
    half = 1.02 * a
    u = (np.arange(pixels) + 0.5) / pixels * 2.0 * half - half
    px, py = np.meshgrid(u, u, indexing="xy")
    d = np.array([0.0, math.cos(beta), math.sin(beta)])  # ray direction, in the y-z plane
    e_y = np.array([0.0, -math.sin(beta), math.cos(beta)])  # image y: the pole's projection
    origin = px[..., None] * np.array([1.0, 0.0, 0.0]) + py[..., None] * e_y
    w = np.array([1.0 / a**2, 1.0 / a**2, 1.0 / c**2])
    qa = np.sum(w * d * d)
    qb = 2.0 * np.sum(w * d * origin, axis=-1)
    qc = np.sum(w * origin * origin, axis=-1) - 1.0
    inside = qb * qb - 4.0 * qa * qc >= 0.0
    cell = (2.0 * half / pixels) ** 2
    area = inside.sum() * cell
    # Semi-axes from the second moments of a uniform ellipse: <x^2> = A^2 / 4.
    sx = 2.0 * math.sqrt(float((px[inside] ** 2).mean()))
    sy = 2.0 * math.sqrt(float((py[inside] ** 2).mean()))
    return sx, sy, area


@pytest.mark.parametrize("beta_deg", [0.0, 25.0, 60.0, 90.0])
def test_outline_matches_rendering(beta_deg):
    mars = body("mars")
    a, c = mars.radius, mars.polar_radius
    beta = math.radians(beta_deg)
    sx, sy, area = rendered_outline(a, c, beta)
    b = limb_minor_axis(a, c, math.sin(beta))
    assert sx == pytest.approx(a, rel=2e-4)
    assert sy == pytest.approx(b, rel=2e-4)
    los = np.array([0.0, math.cos(beta), math.sin(beta)])
    radius = equal_area_radius(a, c, los, np.array([0.0, 0.0, 1.0]))
    assert math.pi * radius**2 == pytest.approx(area, rel=5e-4)


def test_outline_limits_and_the_flattening_it_shows():
    mars = body("mars")
    a, c = mars.radius, mars.polar_radius
    assert limb_minor_axis(a, c, 0.0) == c  # from the equator: the polar radius
    assert limb_minor_axis(a, c, 1.0) == a  # from over the pole: a circle
    assert limb_minor_axis(a, c, -1.0) == a
    sphere = body("venus")
    assert limb_minor_axis(sphere.radius, sphere.polar_radius, 0.3) == sphere.radius
    # Mars from its equator: the equal-area radius is 0.3 % below the equatorial radius that a spherical
    # model assumes, which is what the range from the angular size is biased by.
    los = np.array([1.0, 0.0, 0.0])
    ratio = equal_area_radius(a, c, los, np.array([0.0, 0.0, 1.0])) / a
    assert ratio == pytest.approx(math.sqrt(c / a), rel=1e-15)
    assert 1.0 - ratio == pytest.approx(0.00295, abs=2e-5)


def test_poles_are_unit_vectors():
    for name in ("sun", "mercury", "venus", "earth", "moon", "mars", "jupiter", "saturn"):
        assert np.linalg.norm(body(name).pole) == pytest.approx(1.0, abs=1e-15)
    assert np.allclose(body("earth").pole, [0.0, 0.0, 1.0], atol=1e-15)
