"""The greedy information score of each planet, for rows of observations: one compiled formula.

The score of planet ``p`` is the reduction of the filter's ``trace(P_rr)`` [km^2] per step that looking
at it for ``horizon`` steps would bring, after the steps lost slewing there (``docs/agents.md``):

* the planet's position in the filter's frame: ``x_est + distance * line of sight``, both from the
  observation (the body-axes direction rotated by the star-tracker quaternion; ``10^(log10 AU)``);
* the slew angle between the boresight (body +x) and that direction gives a rest-to-rest bang-bang time
  (:func:`bang_bang_time`) stretched by the PD law's slowdown; the steps lost are ``ceil(t / step) - 1``;
* ``n = horizon - lost`` images of a nearly static state equal one with ``R / n``: one Kalman update by
  the environment core's own model and update (:func:`planetnav_env.core.what_if.predicted_planet_trace`).

:class:`planetnav_agents.greedy.GreedyAgent` picks the largest score, the ``gain`` observation feature
(:class:`planetnav_train.features.FeatureBatch`) is the score relative to the best planet's. All of
them call :func:`planet_scores`, which loops over rows in compiled code, so a row's score does not depend
on the batch it is computed in (a single env, N = 1, and the vector training env's rows agree bit for
bit).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit, vectorize

from planetnav_env.astro.bodies import AU_KM
from planetnav_env.attitude.plant import dcm_body_to_inertial_kernel
from planetnav_env.config import EnvConfig
from planetnav_env.core import layout as L
from planetnav_env.core.what_if import coasted_position_trace, predicted_planet_trace

#: Greedy's horizon [steps]: over it, the value of a new line of sight outweighs the slew
# (``planetnav_agents.greedy``).
DEFAULT_HORIZON = 3
#: Ratio of the PD law's slew time to the bang-bang minimum, calibrated on the environment
#: (``planetnav_agents.greedy`` docstring, ``docs/agents.md``).
PD_SLOWDOWN = 1.6


#: Index of the star-tracker quaternion in the box observation.
_ATTITUDE = L.ObservationLayout(0, 0).blocks[[b[0] for b in L.SPACECRAFT_BLOCK].index("attitude")][1]


class SlewModel(NamedTuple):
    """What a slew costs: rest-to-rest accel [rad/s^2] and rate cap [rad/s] at the mean moment of
    inertia, the PD law's slowdown against bang-bang, and the environment step [s]."""

    accel: float
    rate_max: float
    pd_slowdown: float
    step_s: float

    @classmethod
    def from_config(cls, cfg: EnvConfig, pd_slowdown: float = PD_SLOWDOWN) -> SlewModel:
        j_mean = float(np.mean(cfg.attitude.inertia))
        return cls(
            cfg.attitude.wheel_torque_limit / j_mean,
            cfg.attitude.wheel_momentum_capacity / j_mean,
            float(pd_slowdown),
            float(cfg.step_s),
        )


@vectorize(["float64(float64, float64, float64)"], cache=True)
def bang_bang_time(angle_rad: float, accel: float, rate_max: float) -> float:  # pragma: no cover - compiled
    """Minimum rest-to-rest slew time [s] through ``angle_rad`` with a bounded accel and rate (trapezoid)."""
    angle = abs(angle_rad)
    # Triangle profile while the peak rate sqrt(angle * accel) stays under the cap, trapezoid beyond.
    if angle * accel <= rate_max * rate_max:
        return 2.0 * math.sqrt(angle / accel)
    return angle / rate_max + rate_max / accel


@vectorize(["float64(float64, float64, float64, float64, float64)"], cache=True)
def lost_steps(  # pragma: no cover - compiled
    angle_rad: float, accel: float, rate_max: float, pd_slowdown: float, step_s: float
) -> float:
    """Steps without a measurement while the PD law slews through ``angle_rad``: ``ceil(t / step) - 1``
    (the image is taken at the end of a step, so a slew shorter than one step loses nothing)."""
    t = pd_slowdown * bang_bang_time(angle_rad, accel, rate_max)
    return max(math.ceil(t / step_s) - 1.0, 0.0)


@njit(cache=True)
def planet_scores(prm, slew, horizon, q, planets, x, p, out, lookahead_s=0.0) -> None:  # pragma: no cover
    """Scores [km^2 per step] into ``out`` (N, P); ``-inf`` for a planet not observable if pointed at.

    prm: the environment's ``CoreParams``; slew: :class:`SlewModel`; horizon: steps (>= 1); q (N, 4):
    star-tracker quaternions from the observation (normalised here); planets (N, P, 7): the
    observation's planet blocks (body-axes direction, log10 distance / AU, size, observable flag, ...);
    x (N, 6), p (N, 6, 6): the filter's estimate [km, km/s] and covariance. lookahead_s [s]: score the
    position covariance coasted that far ahead (``core.what_if.coasted_position_trace``; 0: as it is).
    """
    n_rows, n_planets = out.shape
    d = L.TF_DIR  # the body-axes direction's 3 columns
    dcm = np.empty((3, 3))
    planet = np.empty(3)
    for r in range(n_rows):
        norm = math.sqrt(q[r, 0] ** 2 + q[r, 1] ** 2 + q[r, 2] ** 2 + q[r, 3] ** 2)
        dcm_body_to_inertial_kernel(q[r, 0] / norm, q[r, 1] / norm, q[r, 2] / norm, q[r, 3] / norm, dcm)
        trace0 = coasted_position_trace(p[r], lookahead_s)
        for i in range(n_planets):
            if planets[r, i, L.TF_OBSERVABLE] <= 0.5:
                out[r, i] = -np.inf
                continue
            dist = AU_KM * 10.0 ** planets[r, i, L.TF_LOG_DISTANCE]
            cos_angle = 0.0
            for a in range(3):
                u = (
                    dcm[a, 0] * planets[r, i, d]
                    + dcm[a, 1] * planets[r, i, d + 1]
                    + dcm[a, 2] * planets[r, i, d + 2]
                )
                planet[a] = x[r, a] + u * dist
                cos_angle += u * dcm[a, 0]  # boresight = body +x in inertial axes: column 0 of R
            angle = math.acos(min(1.0, max(-1.0, cos_angle)))
            n = horizon - lost_steps(angle, slew.accel, slew.rate_max, slew.pd_slowdown, slew.step_s)
            after = trace0 if n <= 0 else predicted_planet_trace(prm, x[r], p[r], planet, i, n, lookahead_s)
            out[r, i] = (trace0 - after) / horizon


def planet_gains(
    prm, slew: SlewModel, horizon: int, observations: np.ndarray, x: np.ndarray, p: np.ndarray, n_planets: int
) -> np.ndarray:
    """The ``gain`` feature (N, P) float32 of box observations (N, D): each planet's score relative to the
    best observable planet's (1 for greedy's choice, 0 .. 1 for the others), -1 where not observable,
    0 where no planet would reduce the covariance. x (N, 6), p (N, 6, 6): the filter's state at the
    observations.

    Why relative to the best: the scores themselves are ~1e-3 of trace(P_rr) per step and differ between
    planets in the fourth decimal, which a policy network does not resolve; the
    ratio puts greedy's ranking, and how far the current target is behind the best, on a unit scale."""
    obs = np.asarray(observations, dtype=np.float64)
    a = _ATTITUDE
    start = L.ObservationLayout(n_planets, 0).planets_start
    q = np.ascontiguousarray(obs[:, a : a + 4])
    blocks = np.ascontiguousarray(obs[:, start : start + n_planets * L.TARGET_FEATURES]).reshape(
        obs.shape[0], n_planets, L.TARGET_FEATURES
    )
    x = np.ascontiguousarray(x, dtype=np.float64)
    p = np.ascontiguousarray(p, dtype=np.float64)
    scores = np.empty((obs.shape[0], n_planets))
    planet_scores(prm, slew, int(horizon), q, blocks, x, p, scores)
    finite = np.isfinite(scores)
    best = np.max(np.where(finite, scores, 0.0), axis=1, keepdims=True)
    ratio = np.divide(scores, best, out=np.zeros_like(scores), where=finite & (best > 0.0))
    return np.where(finite, ratio, -1.0).astype(np.float32)
