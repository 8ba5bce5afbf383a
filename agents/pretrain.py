"""Behaviour-cloning warm start of an SB3 on-policy model from a rule-based teacher (before RL training).

``train.py`` config key ``pretrain: {teacher: SPEC, episodes: N, epochs: E}``: the teacher agent (any
agent spec, e.g. ``baseline``) acts for ``N`` episodes on demonstration seeds 50000.. (away from the
training seeds 0.. and the evaluation seeds 10000..); the policy is then fitted to its actions by
maximising their log-probability under the policy (``policy.evaluate_actions``), ``E`` passes over the
data, before the RL algorithm trains as usual on the environment's reward. Why: in torque mode neither PPO
nor SAC found the first measurement on their own (``docs/training.md``, T1-T4); cloning the baseline's PD
pointing gives the RL stage a policy that measures, which it may then improve.

The demonstrations are recorded in the training MDP: with ``action_repeat`` the teacher decides once per
held decision (its choice held, as the policy's will be), and with ``relative_actions`` its absolute
target is encoded as "stay" / "move k places" (:func:`agents.features.absolute_to_relative`). With the
``gain`` feature, a greedy teacher's decision is the argmax of an input, which a clone can fit; without
it, the clone of a teacher that switches ~10 times a day learns "stay" (``docs/training.md``, R2).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

DEMO_SEED = 50_000


def demonstrations(
    env_config: Any,
    teacher: str,
    episodes: int,
    features: Sequence[str],
    action_repeat: int = 1,
    relative_actions: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """(observations with ``features`` appended, teacher actions as the policy emits them) at each
    decision of ``episodes`` demonstration episodes (seeds :data:`DEMO_SEED` ..)."""
    from agents import make_agent
    from agents.features import FeatureState, absolute_to_relative, check_relative_config
    from planetnav_env.env import PlanetNavEnv

    if isinstance(action_repeat, bool) or not isinstance(action_repeat, int) or action_repeat < 1:
        raise ValueError(f"action_repeat must be an integer >= 1, got {action_repeat!r}")
    env = PlanetNavEnv(env_config)
    if relative_actions:
        check_relative_config(env.config)
    agent = make_agent(teacher, env)
    state = FeatureState(env, features) if features else None
    n_planets = env.config.n_planets

    def observed(obs: Any, info: dict[str, Any]) -> np.ndarray:
        # Every environment step advances the features (since_measured counts steps), held ones too.
        return state.augment(obs, info) if state is not None else np.asarray(obs, np.float32)

    obs_out, act_out = [], []
    for ep in range(episodes):
        seed = DEMO_SEED + ep
        agent.reset(seed=seed)
        if state is not None:
            state.reset()
        obs, info = env.reset(seed=seed)
        seen = observed(obs, info)
        current, done = -1, False
        while not done:
            action = agent.act(obs, info)
            obs_out.append(seen)
            if relative_actions:
                encoded, current = absolute_to_relative(action, current, n_planets)
                act_out.append(np.asarray(encoded))
            else:
                act_out.append(np.asarray(action))
            for _ in range(action_repeat):
                obs, _, terminated, truncated, info = env.step(action)
                seen = observed(obs, info)
                done = terminated or truncated
                if done:
                    break
    env.close()
    return np.asarray(obs_out, dtype=np.float32), np.asarray(act_out)


def clone(
    model: Any, obs: np.ndarray, actions: np.ndarray, epochs: int, lr: float = 1e-3, batch: int = 256
) -> float:
    """Fits ``model.policy`` to (obs, actions) by maximum likelihood; returns the last epoch's mean
    negative log-likelihood."""
    import torch

    policy = model.policy
    opt = torch.optim.Adam(policy.parameters(), lr=lr)
    o = torch.as_tensor(obs)
    a = torch.as_tensor(actions)
    gen = torch.Generator().manual_seed(0)
    nll = float("nan")
    policy.set_training_mode(True)
    for _ in range(epochs):
        perm = torch.randperm(len(o), generator=gen)
        losses = []
        for i in range(0, len(o), batch):
            idx = perm[i : i + batch]
            _, log_prob, _ = policy.evaluate_actions(o[idx], a[idx])
            loss = -log_prob.mean()
            opt.zero_grad()
            loss.backward()
            opt.step()
            losses.append(float(loss.detach()))
        nll = float(np.mean(losses))
    policy.set_training_mode(False)
    return nll
