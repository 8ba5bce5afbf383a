"""Behaviour-cloning warm start of an SB3 on-policy model from a rule-based teacher (before RL training).

``train.py`` config key ``pretrain: {teacher: SPEC, episodes: N, epochs: E}``: the teacher agent (any
agent spec, e.g. ``baseline``) acts for ``N`` episodes on demonstration seeds :data:`DEMO_SEED`..
(70,000..: away from the training seeds 0.., train.py's evaluation seeds 10,000.., the blind search's
40,000.. and the suite's evaluation seeds 50,000..); the policy is then fitted to its actions by
maximising their log-probability under the policy (``policy.evaluate_actions``), ``E`` passes over the
data, before the RL algorithm trains as usual on the environment's reward. Why: in torque mode neither PPO
nor SAC found the first measurement on their own; cloning the
baseline's PD pointing gives the RL stage a policy that measures, which it may then improve.

The demonstrations are recorded in the training MDP: with ``action_repeat`` the teacher's choice at each
decision point is recorded and held for the decision, as the policy's will be (the teacher still sees
every step, so a teacher with its own features or decision clock, e.g. a saved policy, runs as in
evaluation), and with ``relative_actions`` its absolute
target is encoded as "stay" / "move k places" (:func:`planetnav_train.features.absolute_to_relative`).
With the
``gain`` feature, a greedy teacher's decision is the argmax of an input, which a clone can fit; without
it, the clone of a teacher that switches ~10 times a day learns "stay".
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

#: First demonstration seed: above every evaluation seed block, so no clone sees demonstrations of the
#: episodes it is scored on.
DEMO_SEED = 70_000


def demonstrations(
    env_config: Any,
    teacher: str,
    episodes: int,
    features: Sequence[str],
    action_repeat: int = 1,
    relative_actions: bool = False,
    student: Any = None,
    first_seed: int = DEMO_SEED,
) -> tuple[np.ndarray, np.ndarray]:
    """(observations with ``features`` appended, teacher actions as the policy emits them) at each
    decision of ``episodes`` demonstration episodes (seeds ``first_seed`` ..).

    ``student``: an SB3 model whose deterministic decisions drive the episodes instead of the teacher's,
    which only labels the states the student visits (DAgger's data collection, :func:`dagger`). The teacher
    is told the target the student holds (:meth:`planetnav_agents.base.Agent.follow`) before each decision."""
    from planetnav_agents import make_agent
    from planetnav_env.envs.env import PlanetNavEnv
    from planetnav_train.features import (
        FeatureBatch,
        absolute_to_relative,
        check_action_repeat,
        check_relative_config,
        chosen_planet,
        relative_action,
    )

    check_action_repeat(action_repeat)
    env = PlanetNavEnv(env_config)
    if relative_actions:
        check_relative_config(env.config)
    agent = make_agent(teacher, env)
    state = FeatureBatch.for_env(env, features) if features else None
    n_planets = env.config.n_planets

    def observed(obs: Any, info: dict[str, Any]) -> np.ndarray:
        # Every environment step advances the features (since_measured counts steps), held ones too.
        return state.augment_info(obs, info) if state is not None else np.asarray(obs, np.float32)

    obs_out, act_out = [], []
    for ep in range(episodes):
        seed = first_seed + ep
        agent.reset(seed=seed)
        if state is not None:
            state.reset()
        obs, info = env.reset(seed=seed)
        seen = observed(obs, info)
        current, held, k, done = -1, None, 0, False
        while not done:
            decision = k % action_repeat == 0
            if decision and student is not None:
                agent.follow(current)
            # The teacher sees every step (its own features and decision clock advance, as in evaluation);
            # its choice at a decision point is recorded and, without a student, held for the decision.
            action = agent.act(obs, info)
            if decision:
                obs_out.append(seen)
                if relative_actions:
                    encoded, target = absolute_to_relative(action, current, n_planets)
                    act_out.append(np.asarray(encoded))
                else:
                    target = chosen_planet(action, n_planets)
                    act_out.append(np.asarray(action))
                if student is None:
                    held, current = action, target
                else:
                    held, _ = student.predict(seen, deterministic=True)
                    if relative_actions:
                        held, current = relative_action(held, current, n_planets)
                    else:
                        current = chosen_planet(held, n_planets)
            obs, _, terminated, truncated, info = env.step(held)
            seen = observed(obs, info)
            k += 1
            done = terminated or truncated
    env.close()
    return np.asarray(obs_out, dtype=np.float32), np.asarray(act_out)


def clone(
    model: Any,
    obs: np.ndarray,
    actions: np.ndarray,
    epochs: int,
    lr: float = 1e-3,
    batch: int = 256,
    keep_std: bool = False,
    balance: bool = False,
) -> float:
    """Fits ``model.policy`` to (obs, actions) by maximum likelihood; returns the last epoch's mean
    negative log-likelihood.

    ``keep_std``: a Gaussian policy's state-independent ``log_std`` is put back to its value before the
    fit. Maximum likelihood on a deterministic teacher shrinks it towards zero (NLL ~ -6), and PPO then
    has no exploration left to improve on the clone; with ``keep_std`` only the mean is the clone's.

    ``balance`` (discrete actions): each sample's log-likelihood is weighted by ``N / (C n_c)`` (``n_c`` the
    samples of its action, ``C`` the actions present), so every action weighs the same in the loss. Why: a
    teacher that images at ~3 % of the decisions (``optimum`` on ThrustArc-TCM-v0) is otherwise fitted as
    "stay" wherever its session timing is not a function of the observation, and the argmax never images
    there."""
    import torch

    policy = model.policy
    log_std = getattr(policy, "log_std", None)
    saved = log_std.detach().clone() if (keep_std and log_std is not None) else None
    opt = torch.optim.Adam(policy.parameters(), lr=lr)
    o = torch.as_tensor(obs)
    a = torch.as_tensor(actions)
    if balance:
        if a.ndim != 1:
            raise ValueError(f"clone: balance needs discrete actions (one integer per sample), got {a.shape}")
        values, inverse, counts = np.unique(actions, return_inverse=True, return_counts=True)
        w = torch.as_tensor(len(actions) / (len(values) * counts[inverse]), dtype=torch.float32)
    else:
        w = torch.ones(len(o))
    gen = torch.Generator().manual_seed(0)
    nll = float("nan")
    policy.set_training_mode(True)
    for _ in range(epochs):
        perm = torch.randperm(len(o), generator=gen)
        losses = []
        for i in range(0, len(o), batch):
            idx = perm[i : i + batch]
            _, log_prob, _ = policy.evaluate_actions(o[idx], a[idx])
            loss = -(w[idx] * log_prob).sum() / w[idx].sum()
            opt.zero_grad()
            loss.backward()
            opt.step()
            losses.append(float(loss.detach()))
        nll = float(np.mean(losses))
    if saved is not None:
        with torch.no_grad():
            log_std.copy_(saved)
    policy.set_training_mode(False)
    return nll


def dagger(
    model: Any,
    env_config: Any,
    teacher: str,
    rounds: int,
    episodes: int,
    epochs: int,
    features: Sequence[str],
    data: tuple[np.ndarray, np.ndarray],
    action_repeat: int = 1,
    relative_actions: bool = False,
    keep_std: bool = False,
    balance: bool = False,
) -> tuple[np.ndarray, np.ndarray, float]:
    """DAgger (Ross, Gordon & Bagnell 2011) after a first :func:`clone` on ``data``: ``rounds`` times, the
    clone drives ``episodes`` new demonstration episodes, the teacher labels every decision it visits, and
    the policy is refitted on all labels so far. Returns (observations, labels, the last fit's NLL).

    Why: a clone fitted on the teacher's own states only drifts off them in closed loop, and there it has
    no labels (distilling the target-mode policy into the target+torque Box policy, a plain clone picks
    other planets than its teacher and loses accuracy)."""
    obs, actions = data
    nll = float("nan")
    for r in range(rounds):
        new_obs, new_actions = demonstrations(
            env_config, teacher, episodes, features, action_repeat=action_repeat,
            relative_actions=relative_actions, student=model, first_seed=DEMO_SEED + (r + 1) * episodes,
        )  # fmt: skip
        obs = np.concatenate([obs, new_obs])
        actions = np.concatenate([actions, new_actions])
        nll = clone(model, obs, actions, epochs, keep_std=keep_std, balance=balance)
    return obs, actions, nll


def agreement(
    student_path: str, env_config: Any, teacher: str, episodes: int, first_seed: int
) -> dict[str, float]:
    """How closely a trained student follows a teacher on the student's own states: the student (a saved
    SB3 run) drives ``episodes`` episodes from ``first_seed``; at each of its decisions the teacher labels
    the state (as in :func:`dagger`). Returns the number of decisions, the fraction where the student
    picks another planet than the teacher, and (``target+torque``) the mean |residual torque| the student
    commands, as a fraction of its action range."""
    from planetnav_env.envs.env import PlanetNavEnv
    from planetnav_train.sb3 import SB3Agent

    if env_config.action_mode == "torque":
        raise ValueError("agreement compares planet choices: action_mode 'target' or 'target+torque' only")
    loaded = SB3Agent(student_path, PlanetNavEnv(env_config))
    features = list(loaded.features.features) if loaded.features is not None else []
    obs, labels = demonstrations(
        env_config, teacher, episodes, features, action_repeat=loaded.action_repeat,
        relative_actions=loaded.relative, student=loaded.model, first_seed=first_seed,
    )  # fmt: skip
    actions, _ = loaded.model.predict(obs, deterministic=True)
    n_planets = env_config.n_planets
    if np.ndim(labels) == 1:
        differ = np.asarray(actions).reshape(-1) != labels
        residual = float("nan")
    else:
        differ = np.argmax(actions[:, :n_planets], axis=1) != np.argmax(labels[:, :n_planets], axis=1)
        residual = float(np.mean(np.abs(actions[:, n_planets:]))) if actions.shape[1] > n_planets else np.nan
    return {"decisions": len(obs), "different": float(np.mean(differ)), "mean_abs_residual": residual}
