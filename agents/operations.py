"""Deadline- and cost-aware session rule of ``greedy:threshold=θ`` on the operations scenarios
(docs/agents.md).

Units: times [s], covariances [km^2, km^2/s, km^2/s^2], σ [km], Δv [m/s], the cost weight ``w`` [km per
m/s], ``threshold`` θ dimensionless.

At each decision (not inside a session) the rule predicts, for every deadline k still ahead, the knowledge
σ_k [km] the environment will report (``deadline_sigma_km``: ``sqrt(coasted_position_trace(P(t_k), t_go))``,
``t_go = E - t_k``, ``t_k`` the first step end at or after the deadline's epoch):

* coasting is linear in ``P``, so ``σ_k^2 = coasted(P_now, E - t) + coasted(Q(t_k - t), t_go)``, with
  ``Q`` the thrust execution noise accumulated from now to ``t_k`` with the engine on throughout
  (``core.operations.add_thrust_q``, the env's own Q) and free flight over the gravity gradient
  (``core.what_if.coasted_position_trace``);
* after one session of ``session`` steps on planet i, ``coasted(P_now, E - t)`` becomes
  ``predicted_planet_trace(..., n_meas=session, lookahead_s=E - t)`` (the core's update with R / n).

A planet's score [km] is ``Σ_k (σ_k without - σ_k with the session)`` over the deadlines reached after
the session ends. The rule starts a session on the best visible planet when its score exceeds
``θ × w × Δv_session``, ``Δv_session = a × session × step_s`` [m/s] (the two slews not counted), images that
planet for the whole session (the next visible planet if it leaves the field), and otherwise stays at the
mission attitude (the last action). The noise the session saves by not thrusting is left out of the score.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np

from planetnav_agents.base import ParsedObservation, unwrapped_config
from planetnav_env.core.operations import add_thrust_q
from planetnav_env.core.what_if import coasted_position_trace, predicted_planet_trace

#: Default session [s]: 2 h of images.
DEFAULT_SESSION_S = 7200.0


class DeadlineSessionRule:
    """Scores and the session state of ``greedy:threshold=θ`` (module docstring)."""

    def __init__(self, env: gym.Env, threshold: float, session: int | None = None) -> None:
        cfg = unwrapped_config(env)
        ops = cfg.operations
        if ops is None:
            raise ValueError(
                f"greedy: threshold={threshold!r} needs an operations scenario (config.operations), "
                "e.g. planetnav/ThrustArc-TCM-v0"
            )
        if isinstance(threshold, bool) or not (
            isinstance(threshold, int | float) and math.isfinite(threshold) and threshold >= 0
        ):
            raise ValueError(f"greedy: threshold must be a finite number >= 0, got {threshold!r}")
        step_s = float(cfg.step_s)
        if session is None:
            session = max(1, round(DEFAULT_SESSION_S / step_s))
        if isinstance(session, bool) or not isinstance(session, int | np.integer) or session < 1:
            raise ValueError(f"greedy: session must be an integer number of steps >= 1, got {session!r}")
        self.threshold = float(threshold)
        self.session = int(session)
        self.step_s = step_s
        self.params = env.unwrapped.core_params
        self.n_planets = cfg.n_planets
        self.stay = cfg.n_targets  # the last action: stay at the mission attitude
        self.encounter_s = float(ops.encounter_s)
        # The env reaches a deadline at the first step end at or after its epoch.
        self.deadline_s = np.array([math.ceil(d / step_s - 1e-9) * step_s for d in ops.deadlines_s])
        self.q_par, self.q_perp = ops.psd_km2_s3
        self.dv_session_m_s = ops.thrust_accel_km_s2 * 1e3 * self.session * step_s
        self.cost_km = self.threshold * ops.cost_weight * self.dv_session_m_s
        self.reset()

    def reset(self) -> None:
        """A new episode: step count 0, no session under way."""
        self.k = 0  # steps since reset
        self.left = 0  # steps left in the session under way
        self.planet = -1
        self.last_scores = np.full(self.n_planets, -np.inf)

    def thrust_terms(self, t: float, x: np.ndarray) -> np.ndarray:
        """(D,) ``coasted(Q(t_k - t), E - t_k)`` [km^2] of each deadline ahead of ``t`` [s] (NaN if
        reached): the thrust noise from now to the deadline with the engine on, mapped to the encounter."""
        v = np.asarray(x[3:6], float)
        u = v / max(float(np.linalg.norm(v)), 1e-300)
        out = np.full(self.deadline_s.size, np.nan)
        for j, tk in enumerate(self.deadline_s):
            if tk > t:
                q = np.zeros((6, 6))
                add_thrust_q(q, tk - t, 1.0, self.q_par, self.q_perp, u)
                out[j] = coasted_position_trace(q, self.encounter_s - tk)
        return out

    def predicted_sigma(
        self, t: float, x: np.ndarray, p: np.ndarray, planet: np.ndarray | None = None, idx: int = -1
    ) -> np.ndarray:
        """(D,) predicted σ_k [km] at each deadline ahead of ``t`` [s] (NaN if reached): with no image, or
        after one session on planet ``idx`` (at ``planet``, km) now."""
        x = np.ascontiguousarray(x, dtype=float)
        p = np.ascontiguousarray(p, dtype=float)
        look = self.encounter_s - t
        if idx < 0:
            base = float(coasted_position_trace(p, look))
        else:
            pl = np.asarray(planet, float)
            base = float(predicted_planet_trace(self.params, x, p, pl, int(idx), float(self.session), look))
        return np.sqrt(base + self.thrust_terms(t, x))

    def scores(self, t: float, x: np.ndarray, p: np.ndarray, obs: ParsedObservation) -> np.ndarray:
        """(P,) predicted Σ_k σ_k reduction [km] of one session on each visible planet (-inf if not
        visible), over the deadlines reached after the session ends."""
        out = np.full(self.n_planets, -np.inf)
        after = self.deadline_s >= t + self.session * self.step_s
        visible = np.flatnonzero(obs.planet_observable[: self.n_planets])
        if not np.any(after):
            out[visible] = 0.0  # no deadline left to serve
            return out
        s0 = self.predicted_sigma(t, x, p)
        planets = obs.planet_positions(x)
        for i in visible:
            s1 = self.predicted_sigma(t, x, p, planets[i], int(i))
            out[i] = float(np.sum((s0 - s1)[after]))
        return out

    def choose(self, obs: ParsedObservation, x: np.ndarray, p: np.ndarray) -> int:
        """The action: the session's planet, a new session's, or stay."""
        t = self.k * self.step_s
        self.k += 1
        visible = obs.planet_observable[: self.n_planets]
        if self.left > 0:
            self.left -= 1
            if not visible[self.planet] and np.any(visible):
                self.planet = int(np.flatnonzero(visible)[0])
            return self.planet
        sc = self.scores(t, x, p, obs)
        self.last_scores = sc
        best = int(np.argmax(sc))
        # theta = 0 images whenever a planet is visible (a score of exactly 0 included).
        if np.isfinite(sc[best]) and (sc[best] > self.cost_km or self.cost_km == 0.0):
            self.planet = best
            self.left = self.session - 1
            return best
        return self.stay
