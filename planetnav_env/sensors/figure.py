"""The outline of an oblate planet in the image: the limb that a camera fits.

Onboard, a planet is a sphere of its equatorial radius ``a``; in truth it is a spheroid of equatorial
radius ``a`` and polar radius ``c`` (Mars: 3396.19 and 3376.20 km, a flattening of 1/170). Seen from far
away (orthographic projection: the planet's angular size is well below a degree wherever the scenarios
fly), a spheroid's outline is an ellipse. Its semi-major axis is ``a``, across the pole's projection, and
its semi-minor axis, along it, is

    b = sqrt(a^2 sin^2(beta) + c^2 cos^2(beta)),

with ``beta`` the sub-camera latitude (the angle between the line of sight and the equator; from over a
pole ``b = a``, from the equator ``b = c``). A limb fit that assumes a circle returns a radius between
``b`` and ``a``; :func:`equal_area_radius` takes the circle of the outline's area, ``sqrt(a b)``.
``tests/env/test_figure.py`` holds both to a brute-force rendering of the spheroid's silhouette.
"""

from __future__ import annotations

import math

from planetnav_env.numerics.jit import row_kernel


@row_kernel
def limb_minor_axis(a: float, c: float, sin_beta: float) -> float:  # pragma: no cover - compiled
    """Semi-minor axis [km] of the outline of a spheroid of equatorial radius ``a`` and polar radius ``c``
    [km] seen along a line of sight at sub-camera latitude ``asin(sin_beta)``."""
    s2 = min(sin_beta * sin_beta, 1.0)
    return math.sqrt(a * a * s2 + c * c * (1.0 - s2))


@row_kernel
def equal_area_radius(a: float, c: float, los, pole) -> float:  # pragma: no cover - compiled
    """Radius [km] of the circle with the area of the spheroid's outline seen along the unit line of
    sight ``los`` (3,), the spheroid's unit polar axis being ``pole`` (3,) in the same frame."""
    sin_beta = los[0] * pole[0] + los[1] * pole[1] + los[2] * pole[2]
    return math.sqrt(a * limb_minor_axis(a, c, sin_beta))
