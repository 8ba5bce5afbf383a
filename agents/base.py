"""The one agent interface, observation parsing and the pointing helpers the rule-based agents share.

Every agent (rule-based or learned) is an :class:`Agent`: ``reset(seed)`` at the start of an episode, then
``act(observation, info) -> action`` once per step, with the observation and ``info`` the environment just
returned. Agents read only what the spacecraft knows: the observation, ``info["filter"]`` (estimate and
covariance), ``info["time_s"]``, the environment's public ``config``/``planets`` and the ephemeris. They
never read ``env.truth`` or the true errors in ``info``.

Rule-based agents that decide *which planet to look at* derive from :class:`TargetAgent`; it turns the
chosen planet index into an action for any ``action_mode``:

* ``target``: the index itself (the environment's PD law slews);
* ``target+torque``: +1 on the chosen planet, -1 elsewhere, zero residual torque;
* ``hybrid``: the PD-law option of the chosen planet (+1 on it, -1 on the other options, zero torque);
* ``torque``: the PD command toward the planet's estimated direction, computed here from the observation
  (star-tracker quaternion, reported rates, wheel momentum), as a fraction of the wheel torque limit.
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np

from planetnav_env.astro.bodies import body
from planetnav_env.attitude.plant import AttitudeConfig, raise_state_error
from planetnav_env.attitude.pointing import frame_batch, pd_torque_batch
from planetnav_env.config import EnvConfig
from planetnav_env.envs.parsed_observation import ParsedObservation
from planetnav_env.errors import InvalidParameterError, require_finite

_DEG = math.pi / 180.0


def parse_observation(observation: Any, env: gym.Env) -> ParsedObservation:
    """Split a ``box`` or ``dict`` observation of ``env`` (a planetnav environment, wrapped or not) into the
    environment's public record (:class:`planetnav_env.envs.parsed_observation.ParsedObservation`)."""
    return ParsedObservation.from_observation(observation, env)


def with_planet_choice(actions: np.ndarray, choice: np.ndarray, n_planets: int) -> np.ndarray:
    """Copies (float32) of ``target+torque`` Box actions (N, P + 3) whose planet entries pick ``choice``
    (N,): +1 on it, -1 on the other planets; the residual torque is kept."""
    out = np.array(actions, dtype=np.float32, copy=True)
    out[:, :n_planets] = -1.0
    out[np.arange(out.shape[0]), np.asarray(choice, dtype=np.int64)] = 1.0
    return out


def target_torque_action(idx: int, n_planets: int) -> np.ndarray:
    """The ``target+torque`` action (P + 3,) that picks planet ``idx`` with no residual torque."""
    return with_planet_choice(np.zeros((1, n_planets + 3)), np.array([idx]), n_planets)[0]


def hybrid_action(option: int, n_planets: int, torque: np.ndarray | None = None) -> np.ndarray:
    """The ``hybrid`` action (P + 1 + 3,) float32 (:func:`planetnav_env.envs.spaces.decode_hybrid`): option
    ``k < P`` slews to planet k by the PD law; ``k = P`` commands ``torque`` (3,) [fraction of
    ``torque_action_scale`` x the wheel limit, body axes] directly. Raises ``ValueError`` naming a bad
    option or torque."""
    if not 0 <= int(option) <= n_planets:
        raise ValueError(f"hybrid option must be in [0, {n_planets}] (P = direct torque), got {option!r}")
    out = np.full(n_planets + 4, -1.0, dtype=np.float32)
    out[int(option)] = 1.0
    out[n_planets + 1 :] = 0.0
    if torque is not None:
        t = np.asarray(torque, dtype=float)
        if t.shape != (3,) or not np.all(np.isfinite(t)):
            raise ValueError(f"hybrid torque must be 3 finite numbers, got {torque!r}")
        out[n_planets + 1 :] = np.clip(t, -1.0, 1.0)
    return out


class NotApplicableError(ValueError):
    """The agent cannot act in this environment (e.g. a model trained for another action space); the
    evaluation harness skips it with the message as a note instead of stopping."""


class Agent:
    """The interface every agent implements.

    ``name`` labels results; ``requires_idle_action`` says the environment must be built with
    ``idle_action=True`` (the evaluation harness does so for such agents only).
    """

    name: str = "agent"
    requires_idle_action: bool = False

    def reset(self, seed: int | None = None) -> None:
        """Start of an episode; ``seed`` seeds any randomness the agent has."""

    def act(self, observation: Any, info: dict[str, Any]) -> Any:
        """The action for this step, from the latest observation and ``info``."""
        raise NotImplementedError

    def follow(self, target: int) -> None:
        """Another actor holds planet ``target`` (an index, -1 for none) in this episode: the agent labels
        states it does not drive (DAgger, ``planetnav_train.pretrain``). Agents whose actions are
        relative to their
        own last choice resynchronise; the others ignore it."""


def unwrapped_config(env: gym.Env) -> EnvConfig:
    """The :class:`EnvConfig` of a (possibly wrapped) planetnav environment."""
    cfg = getattr(env.unwrapped, "config", None)
    if not isinstance(cfg, EnvConfig):
        raise TypeError(f"expected a planetnav environment, got {env!r}")
    return cfg


class PointingLaw:
    """The agent-side PD law of a configuration over N rows: the wheel torque that points the camera
    toward given directions, as a torque action.

    Gains for a zero-order hold of ``step_s``: the env applies the agent's torque unchanged for the whole
    step, so the 1-s-substep gains of the env's own PD law (k_a=0.02, k_w=1) would overshoot wildly. For
    a double integrator J theta'' = u held over T, u = -J (theta / T^2 + 1.5 omega / T) is deadbeat (both
    closed-loop poles at 0). With S ~ 2 theta this is k_a = J / (2 T^2), k_w = 1.5 J / T, taken at the
    mean moment (the per-axis ratio 0.8-1.25 keeps the poles inside the unit circle).

    When the step is no longer than the env's attitude sub-step (``step_s <= attitude_substep_s``, e.g.
    ``Cruise-TorqueControl-v0``'s 1 s) the agent's hold is the env's own, and the configuration's gains
    (``attitude.k_a``, ``attitude.k_w``) are used: the law is then the env's PD law, run on the
    star-tracker attitude and the reported rates. (The deadbeat gains at T = 1 s, k_a = 5 N m, would
    ask 500 times the wheel limit and bang the wheels.)

    What :meth:`TargetAgent.torque_toward` commands in torque mode and what the ``pd_torque`` feature
    (:class:`planetnav_train.features.FeatureBatch`) gives per planet: one formula.
    """

    def __init__(self, cfg: EnvConfig) -> None:
        att = cfg.attitude
        self._att_config = AttitudeConfig(inertia=att.inertia)
        t = cfg.step_s
        j_mean = float(np.mean(att.inertia))
        if t <= cfg.attitude_substep_s:
            self.k_a, self.k_w = float(att.k_a), float(att.k_w)  # the env's own law and hold
        else:
            self.k_a = j_mean / (2.0 * t * t)  # [N m]
            self.k_w = 1.5 * j_mean / t  # [N m s]
        self._tau_max = att.wheel_torque_limit
        self._torque_scale = cfg.torque_action_scale
        self._h_max = att.wheel_momentum_capacity

    def torque_actions(
        self,
        q: np.ndarray,
        rates_rad_s: np.ndarray,
        wheel_fraction: np.ndarray,
        directions: np.ndarray,
        roll_ref: np.ndarray,
    ) -> np.ndarray:
        """(N, K, 3) float32 torque actions in [-1, 1] toward K directions per row: the PD torque divided
        by ``wheel_torque_limit * torque_action_scale``, clipped.

        q (N, 4): star-tracker attitude (unit, body->inertial, scalar first); rates_rad_s (N, 3): reported
        body rates [rad/s]; wheel_fraction (N, 3): wheel momentum / capacity; directions (N, K, 3):
        inertial directions to point the boresight at (any length > 0); roll_ref (N, 3): the vector that
        fixes the roll (the estimated position [km])."""
        n, k = directions.shape[:2]
        # One row per (row, direction): the kernels below loop over rows.
        named = {
            "q": q, "rates_rad_s": rates_rad_s, "wheel_fraction": wheel_fraction * self._h_max,
            "roll_ref": roll_ref,
        }  # fmt: skip
        for name, v in named.items():
            named[name] = np.ascontiguousarray(np.repeat(require_finite(name, v), k, axis=0))
        q_, w_, h_, x_ = named.values()
        p_ = np.ascontiguousarray(require_finite("directions", directions).reshape(n * k, 3))
        # The compiled kernels of attitude.pointing.pd_torque, called directly: its validation and
        # broadcasting cost ~0.5 ms a call, more than a training step of 8 rows; the inputs are checked here.
        frame = np.empty((n * k, 3, 3))
        bad = frame_batch(p_, x_, frame)
        if bad:
            r, i = divmod(bad - 1, k)
            raise InvalidParameterError(f"direction {i} of row {r} has zero length: {p_[bad - 1].tolist()}")
        u = np.empty((n * k, 3))
        status = pd_torque_batch(q_, w_, h_, frame, self._att_config.inertia_matrix, self.k_a, self.k_w, u)
        raise_state_error(status, [("q", q_)])
        u = u.reshape(n, k, 3)
        return np.clip(u / (self._tau_max * self._torque_scale), -1.0, 1.0).astype(np.float32)


class TargetAgent(Agent):
    """An agent that chooses a planet each step; :meth:`act` encodes it for the environment's action mode.

    Subclasses implement :meth:`choose_target`. ``torque`` mode uses the thesis's PD law on the agent side
    with gains re-tuned for a torque held over a whole environment step (:class:`PointingLaw`).
    """

    def __init__(self, env: gym.Env) -> None:
        cfg = unwrapped_config(env)
        self.env = env
        self.config = cfg
        self.n_planets = cfg.n_planets
        self.n_targets = cfg.n_targets
        self.radii = np.array([body(p).radius for p in cfg.planets])
        self.pointing = PointingLaw(cfg)

    def choose_target(self, obs: ParsedObservation, info: dict[str, Any]) -> int:
        """Index of the target: a planet (order of ``config.planets``), then the pulsars."""
        raise NotImplementedError

    def act(self, observation: Any, info: dict[str, Any]) -> Any:
        obs = parse_observation(observation, self.env)
        return self.encode(obs, info, int(self.choose_target(obs, info)))

    def encode(self, obs: ParsedObservation, info: dict[str, Any], idx: int) -> Any:
        """The action that points at target ``idx`` in this environment's action mode (class docstring)."""
        mode = self.config.action_mode
        if mode == "target":
            return idx
        if mode == "target+torque":
            return target_torque_action(idx, self.n_planets)
        if mode == "hybrid":
            return hybrid_action(idx, self.n_planets)
        return self.torque_toward(obs, info, idx)

    def estimate(self, obs: ParsedObservation, info: dict[str, Any]) -> np.ndarray:
        """The filter's state estimate (6,) [km, km/s]: ``info["filter"]["x"]`` or, failing that, the obs."""
        filt = info.get("filter") if info else None
        if filt is not None and "x" in filt:
            return np.asarray(filt["x"], dtype=float)
        return np.concatenate([obs.position_km, obs.velocity_km_s])

    def torque_toward(self, obs: ParsedObservation, info: dict[str, Any], idx: int) -> np.ndarray:
        """Torque action (3,) in [-1, 1] of the PD law toward planet ``idx``'s estimated direction: the
        wheel torque as a fraction of the limit, divided by ``config.torque_action_scale``, clipped."""
        x_est = self.estimate(obs, info)
        direction = obs.planet_los_inertial[idx]
        one_row = (obs.q[None], obs.rates_rad_s[None], obs.wheel_fraction[None], direction[None, None])
        return self.pointing.torque_actions(*one_row, x_est[None, :3])[0, 0]
