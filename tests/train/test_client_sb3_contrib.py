"""sb3-contrib on planetnav, as a new user would run it (optional: skipped without sb3-contrib).

MaskablePPO learns with an action mask of the beacons that cannot be observed now (the observation's
``observable`` column of each target block: Sun exclusion, occultation, too small), and RecurrentPPO learns
on the SB3 adapter built from an env id. CI installs sb3-contrib in the Ray environment (Makefile).
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("sb3_contrib", reason="sb3-contrib is not installed (the [clients] extra)")

from sb3_contrib import MaskablePPO, RecurrentPPO
from sb3_contrib.common.wrappers import ActionMasker

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_env.core.layout import TF_OBSERVABLE
from planetnav_train.sb3_vec import PlanetNavSB3VecEnv

#: Seed 0 of the random cruise draws a geometry where Venus (action 0) cannot be observed.
MASK_ID, MASK_SEED = "planetnav/RandomCruise-Target-v0", 0


def observable_targets(env: gym.Env) -> np.ndarray:
    """Which target actions can give a measurement now (planets, then pulsars), from the observation.

    Every action stays allowed when none can (MaskablePPO needs one valid action; the PD law still slews).
    """
    base = env.unwrapped
    parsed = base.decode_observation(base.current_observation())
    mask = np.concatenate([parsed["planets"][:, TF_OBSERVABLE], parsed["pulsars"][:, TF_OBSERVABLE]]) > 0.5
    return mask if mask.any() else np.ones_like(mask)


def test_maskable_ppo_learns_with_a_mask_of_unobservable_beacons() -> None:
    env = ActionMasker(gym.make(MASK_ID, episode_steps=64), observable_targets)
    env.reset(seed=MASK_SEED)
    first_mask = env.action_masks()
    assert first_mask.dtype == bool and first_mask.shape == (3,)
    assert not first_mask.all(), "the chosen seed must hide a beacon, or the mask tests nothing"
    model = MaskablePPO("MlpPolicy", env, n_steps=64, batch_size=64, n_epochs=2, seed=0, device="cpu")
    model.learn(256)
    assert model.num_timesteps >= 256
    obs, _ = env.reset(seed=MASK_SEED)
    for _ in range(20):  # the trained policy never picks a masked beacon
        mask = env.action_masks()
        action, _ = model.predict(obs, action_masks=mask, deterministic=True)
        assert mask[int(action)], (mask, action)
        obs, reward, *_ = env.step(int(action))
        assert np.isfinite(reward)


def test_recurrent_ppo_learns_on_the_sb3_adapter_from_an_env_id() -> None:
    vec = PlanetNavSB3VecEnv(4, "planetnav/MarsApproach-Tasking-v0", seed=0, episode_steps=24)
    model = RecurrentPPO(
        "MlpLstmPolicy", vec, n_steps=32, batch_size=64, n_epochs=1, seed=0, device="cpu",
        policy_kwargs={"lstm_hidden_size": 16, "net_arch": [32]},
    )  # fmt: skip
    model.learn(256)
    assert model.num_timesteps >= 256
    obs = vec.reset()
    actions, state = model.predict(obs, state=None, episode_start=np.ones(4, dtype=bool))
    assert actions.shape == (4,) and np.all((actions >= 0) & (actions < 3))
    assert state[0].shape == (1, 4, 16) and np.all(np.isfinite(state[0]))
