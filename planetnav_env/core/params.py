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
    central body; none otherwise, so the matched world's table is unchanged). With ``truth_apart`` (the
    truth follows an ephemeris of its own, ``world.truth_ephemeris``) the truth's central body, planets
    and barycentre offset follow in channels of their own (``tcentral``, ``tplanet0``, ``tssb``), fitted
    from that ephemeris as the truth's perturbers are; without, those indices are the onboard ones."""

    central_body: str
    planets: tuple[str, ...]
    perturbers: tuple[str, ...]
    with_ssb: bool
    truth_perturbers: tuple[str, ...] = ()
    truth_apart: bool = False

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
    def _apart0(self) -> int:
        """The first of the truth's own body channels (``truth_apart``)."""
        return self.truth0 + len(self.truth_perturbers)

    @property
    def tcentral(self) -> int:
        """The truth's central body (heliocentric; -1 for the Sun)."""
        if not self.truth_apart or self.central_body == "sun":
            return self.central
        return self._apart0

    @property
    def tplanet0(self) -> int:
        """The truth's first planet (heliocentric)."""
        if not self.truth_apart:
            return self.planet0
        return self._apart0 + (0 if self.central_body == "sun" else 1)

    @property
    def tssb(self) -> int:
        """The truth's central body relative to the barycentre (-1 without pulsars)."""
        if not self.truth_apart or not self.with_ssb:
            return self.ssb
        return self.tplanet0 + len(self.planets)

    @property
    def n_channels(self) -> int:
        if not self.truth_apart:
            return self._apart0
        return self.tplanet0 + len(self.planets) + (1 if self.with_ssb else 0)

    def positions(self, ephemeris, times: np.ndarray, truth_ephemeris=None) -> np.ndarray:
        """(T, C, 3) [km] of every channel at ``times`` [TDB s] (what the table is fitted to): the onboard
        model's from ``ephemeris``, the truth's from ``truth_ephemeris`` (``ephemeris`` if None)."""
        truth = ephemeris if truth_ephemeris is None else truth_ephemeris

        def columns(eph, with_central: bool) -> tuple[list[np.ndarray], np.ndarray]:
            central = (
                eph.position(self.central_body, times)
                if self.central_body != "sun"
                else np.zeros((times.size, 3))
            )
            return ([central] if with_central and self.central >= 0 else []), central

        cols, central = columns(ephemeris, True)
        cols += [ephemeris.position(p, times) for p in self.planets]
        cols += [ephemeris.position(b, times) - central for b in self.perturbers]
        if self.with_ssb:
            cols.append(central + ephemeris.sun_barycentric_position(times))
        truth_cols, t_central = columns(truth, self.truth_apart)
        cols += [truth.position(b, times) - t_central for b in self.truth_perturbers]
        if self.truth_apart:
            cols += truth_cols
            cols += [truth.position(p, times) for p in self.planets]
            if self.with_ssb:
                cols.append(t_central + truth_barycentre_offset(ephemeris, truth, times))
        return np.stack(cols, axis=1)


def truth_barycentre_offset(onboard, truth, times: np.ndarray) -> np.ndarray:
    """(T, 3) [km] the Sun relative to the barycentre in truth at ``times`` [TDB s], as the pulsars'
    timing models see it: the truth ephemeris' offset less its constant difference from the onboard
    one's at ``times[0]`` (the episode's start). Two DE fits put the barycentre ~116 km apart almost
    constantly (DE440 counts the Kuiper belt's mass, DE421 does not: docs/flight_world.md); a timing
    model fitted with the onboard ephemeris holds that constant in its phase, so what is left for the
    filter is the offset's change over the episode and the heliocentric positions' difference."""
    t0 = times[:1]
    frame = truth.sun_barycentric_position(t0) - onboard.sun_barycentric_position(t0)
    return truth.sun_barycentric_position(times) - frame


def bias_quaternion(bias_arcsec: tuple[float, float, float]) -> np.ndarray:
    """Unit quaternion of the rotation vector ``bias_arcsec`` (body axes) [arcsec]."""
    v = np.asarray(bias_arcsec, dtype=float) * ARCSEC
    angle = float(norm3(v))
    if angle == 0.0:
        return np.array([1.0, 0.0, 0.0, 0.0])
    return np.concatenate([[math.cos(0.5 * angle)], math.sin(0.5 * angle) * v / angle])
