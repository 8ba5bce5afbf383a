"""Non-myopic reference: a rollout planner over greedy, on deep copies of the environment.

Every ``replan`` steps the agent deep-copies the environment it acts in and, for each planet the camera
could see if pointed at it (the observation's flag), simulates ``horizon`` steps: that planet for the
first ``replan`` steps, then the greedy agent (re-deciding every ``replan`` steps) for the rest. Each
candidate is scored by the mean of the filter's position 1-sigma, ``info["pos_sigma_km"]`` =
sqrt(trace P_rr), over the simulated steps (the covariance reward); the planner picks the lowest and
holds it for ``replan`` steps. This is Bertsekas' rollout: its first decision is one-step-lookahead over a
base policy (greedy), which it improves on the objective it simulates whenever the simulation is faithful.

What the copies carry, and what the planner uses
------------------------------------------------
A copy of the environment is the environment's own simulator: the filter update, the slews (PD law and
wheel limits), visibility and the measurement model are exactly the environment's (no re-implementation
here). The copy also carries the *true* state and the environment's random generator. The planner:

* scores candidates only by the filter's covariance (``pos_sigma_km``), never by ``pos_err_km``;
* replaces the copy's random generator by its own before each rollout (seeded by :meth:`reset`, the same
  stream for every candidate of one decision: common random numbers), so the rollouts do not replay the
  measurement noise the real environment is about to draw.

The truth still enters through the simulated measurements (visibility, and the noisy measurement around
the true line of sight moves the estimate at which the filter linearises), so the planner is a
*reference with a model of the world*, not an on-board algorithm: it is the bar the learners are measured
against, as the issue asks. Its covariance objective is what the spacecraft itself could predict.

Cost: ``n_candidates x horizon`` environment steps plus ``n_candidates x horizon / replan`` greedy
decisions per decision, one decision every ``replan`` steps. ``docs/agents.md`` gives the measured time
per episode.

The agent must be built on the environment it acts in (``make_agent("planner", env)`` then
``env.step(agent.act(obs, info))``, as ``train.py`` does): it copies that environment's current state.
"""

from __future__ import annotations

import copy
from typing import Any

import gymnasium as gym
import numpy as np

from planetnav_agents.base import ParsedObservation, TargetAgent, parse_observation
from planetnav_agents.greedy import GreedyAgent


class PlannerAgent(TargetAgent):
    """Rollout over greedy on environment copies, scored by the mean predicted position 1-sigma."""

    name = "planner"
    requires_idle_action = False

    def __init__(
        self, env: gym.Env, horizon: int = 60, replan: int = 10, greedy_horizon: int = 3, seed: int = 0
    ) -> None:
        super().__init__(env)
        for key, value in (("horizon", horizon), ("replan", replan), ("greedy_horizon", greedy_horizon)):
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
                raise ValueError(f"planner: {key} must be an integer number of steps >= 1, got {value!r}")
        if replan > horizon:
            raise ValueError(f"planner: replan ({replan}) must not exceed horizon ({horizon})")
        self.horizon, self.replan = int(horizon), int(replan)
        self.base = GreedyAgent(env, horizon=int(greedy_horizon))
        if (self.horizon, self.replan, int(greedy_horizon)) != (60, 10, 3):
            self.name = f"planner:horizon={self.horizon},replan={self.replan},greedy_horizon={greedy_horizon}"
        self._seed = int(seed)
        self._rng = np.random.default_rng(self._seed)
        self._k = 0
        self._choice = 0
        self._raw_obs: Any = None
        self.last_scores: dict[int, float] = {}
        self.rollout_steps = 0  # simulated environment steps since reset (cost bookkeeping)

    def act(self, observation: Any, info: dict[str, Any]) -> Any:
        self._raw_obs = observation  # the rollouts start from the observation the agent was given
        return super().act(observation, info)

    def reset(self, seed: int | None = None) -> None:
        self._rng = np.random.default_rng(self._seed if seed is None else seed)
        self._k = 0
        self.rollout_steps = 0

    def _rollout(self, sim: Any, first: int, obs: Any, info: dict[str, Any]) -> float:
        """Mean ``pos_sigma_km`` over ``horizon`` simulated steps: ``first`` for ``replan`` steps, then
        greedy (held ``replan`` steps per decision). ``sim`` is a private copy, consumed."""
        sigmas = []
        idx = first
        for t in range(self.horizon):
            parsed = parse_observation(obs, self.env)
            if t and t % self.replan == 0:
                idx = int(self.base.choose_target(parsed, info))
            obs, _, terminated, truncated, info = sim.step(self.encode(parsed, info, idx))
            sigmas.append(info["pos_sigma_km"])
            if terminated or truncated:
                break
        self.rollout_steps += len(sigmas)
        return float(np.mean(sigmas))

    def choose_target(self, obs: ParsedObservation, info: dict[str, Any]) -> int:
        k = self._k
        self._k += 1
        if k % self.replan:
            return self._choice
        candidates = np.flatnonzero(obs.planet_observable)
        if candidates.size == 0:
            self._choice = obs.target if 0 <= obs.target < self.n_planets else 0
            return self._choice
        if candidates.size == 1:
            self._choice = int(candidates[0])
            return self._choice
        base = copy.deepcopy(self.env.unwrapped)
        raw_obs = self._raw_obs
        noise_seed = int(self._rng.integers(2**63))
        scores: dict[int, float] = {}
        for c in candidates:
            sim = copy.deepcopy(base)
            # Own noise stream, identical for all candidates: no replay of the real environment's noise.
            sim.reseed_noise(noise_seed)
            scores[int(c)] = self._rollout(sim, int(c), raw_obs, info)
        self.last_scores = scores
        best = min(scores.values())
        # Ties (within 0.1 %) go to the current target: a slew costs measurements the score may not see.
        if obs.target in scores and scores[obs.target] <= best * 1.001:
            self._choice = obs.target
        else:
            self._choice = min(scores, key=scores.__getitem__)
        return self._choice
