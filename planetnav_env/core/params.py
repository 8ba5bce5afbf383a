"""What the core's parameter record is built from, besides the configuration.

:class:`ChannelPlan` says which ephemeris channel of a row's table holds which body; the settling
thresholds of a held target and :func:`bias_quaternion` (the star tracker's fixed misalignment) are the
core's own. The record itself, :class:`~planetnav_env.core.records.CoreParams`, is built from a validated
configuration one layer up, by :func:`planetnav_env.kernel_params.build_params` (the core reads no
configuration).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from planetnav_env.numerics.portable_math import norm3

ARCSEC = math.pi / 648_000.0
#: Pointing error [rad] and rate [rad/s] below which a held target's attitude counts as settled (see
#: docs/architecture.md: the coarse sub-steps are tested to stay within 1" of the fine integration).
SETTLE_ANGLE_RAD = 1e-4
SETTLE_RATE_RAD_S = 1e-5


@dataclass(frozen=True)
class ChannelPlan:
    """Ephemeris channels of a row's table: ``central`` (heliocentric; -1 for the Sun, always zero),
    ``planets`` (heliocentric, in config order), ``perturbers`` (the filter's, relative to the central
    body), ``ssb`` (central body relative to the Solar-system barycentre; -1 without pulsars), then
    ``truth_perturbers`` (the truth's third bodies when its force model is its own, relative to the
    central body; none otherwise, so the matched world's table is unchanged)."""

    central_body: str
    planets: tuple[str, ...]
    perturbers: tuple[str, ...]
    with_ssb: bool
    truth_perturbers: tuple[str, ...] = ()

    @property
    def central(self) -> int:
        return -1 if self.central_body == "sun" else 0

    @property
    def planet0(self) -> int:
        return self.central + 1

    @property
    def pert0(self) -> int:
        return self.planet0 + len(self.planets)

    @property
    def ssb(self) -> int:
        return self.pert0 + len(self.perturbers) if self.with_ssb else -1

    @property
    def truth0(self) -> int:
        """The first of the truth's perturber channels (after every channel of the onboard model)."""
        return self.pert0 + len(self.perturbers) + (1 if self.with_ssb else 0)

    @property
    def n_channels(self) -> int:
        return self.truth0 + len(self.truth_perturbers)

    def positions(self, ephemeris, times: np.ndarray) -> np.ndarray:
        """(T, C, 3) [km] of every channel at ``times`` [TDB s] (what the table is fitted to)."""
        cols = []
        central = (
            ephemeris.position(self.central_body, times)
            if self.central_body != "sun"
            else np.zeros((times.size, 3))
        )
        if self.central >= 0:
            cols.append(central)
        cols += [ephemeris.position(p, times) for p in self.planets]
        cols += [ephemeris.position(b, times) - central for b in self.perturbers]
        if self.with_ssb:
            cols.append(central + ephemeris.sun_barycentric_position(times))
        cols += [ephemeris.position(b, times) - central for b in self.truth_perturbers]
        return np.stack(cols, axis=1)


def bias_quaternion(bias_arcsec: tuple[float, float, float]) -> np.ndarray:
    """Unit quaternion of the rotation vector ``bias_arcsec`` (body axes) [arcsec]."""
    v = np.asarray(bias_arcsec, dtype=float) * ARCSEC
    angle = float(norm3(v))
    if angle == 0.0:
        return np.array([1.0, 0.0, 0.0, 0.0])
    return np.concatenate([[math.cos(0.5 * angle)], math.sin(0.5 * angle) * v / angle])
