"""MaskablePPO's mask of unobservable targets (planetnav_train.masking) at the env's own observation
layout, on a target-choice cruise, the Mars approach (planet + pulsars) and the thrust arc (operations
block, and the last action "stay" that is never masked): in the rollouts MaskablePPO collects, and in the
``predict`` of a saved and reloaded model."""

from __future__ import annotations

import numpy as np
import pytest

from planetnav_env.core.layout import TF_OBSERVABLE
from planetnav_env.envs.env import PlanetNavEnv
from planetnav_train.masking import layout_of, observable_mask

IDS = ("planetnav/Cruise-Target-v0", "planetnav/MarsApproach-Tasking-v0", "planetnav/ThrustArc-TCM-v0")


def decoded_observable(env: PlanetNavEnv, obs: np.ndarray) -> np.ndarray:
    """The ``observable`` column of each target (planets, then pulsars) by the env's own decoder."""
    parsed = env.decode_observation(obs)
    return np.concatenate([parsed["planets"][:, TF_OBSERVABLE], parsed["pulsars"][:, TF_OBSERVABLE]]) > 0.5


@pytest.mark.parametrize("env_id", IDS)
def test_mask_reads_each_targets_observable_column(env_id: str) -> None:
    env = PlanetNavEnv(env_id, episode_steps=8)
    obs, _ = env.reset(seed=3)
    layout = layout_of(env)
    n_act, n_tgt = int(env.action_space.n), layout.n_targets
    idle = n_act - n_tgt  # ThrustArc: 1 ("stay"); the target-choice tasks: 0
    assert idle == (1 if "ThrustArc" in env_id else 0)
    np.testing.assert_array_equal(observable_mask(obs, layout, n_act)[:n_tgt], decoded_observable(env, obs))
    # Hide one target at a time (through the layout's named blocks, not the mask's own offsets).
    for i in range(n_tgt):
        hidden = obs.copy()
        blocks = layout.to_dict(hidden)  # views into ``hidden``
        kind, j = ("planets", i) if i < layout.n_planets else ("pulsars", i - layout.n_planets)
        for k in range(n_tgt):  # every other target observable
            kk, jj = ("planets", k) if k < layout.n_planets else ("pulsars", k - layout.n_planets)
            blocks[kk][jj, TF_OBSERVABLE] = 1.0
        blocks[kind][j, TF_OBSERVABLE] = 0.0
        mask = observable_mask(hidden, layout, n_act)
        assert mask.tolist() == [k != i for k in range(n_tgt)] + [True] * idle
    # Nothing observable: only the idle action when there is one, else every action (no empty mask).
    none = obs.copy()
    for name in ("planets", "pulsars"):
        if name in layout.to_dict(none):
            layout.to_dict(none)[name][:, TF_OBSERVABLE] = 0.0
    expected = [False] * n_tgt + [True] if idle else [True] * n_act
    assert observable_mask(none, layout, n_act).tolist() == expected
    # Not this env's observation (features appended): a clear error, not a silently shifted column.
    with pytest.raises(ValueError, match=f"{obs.size + 2} values is not one of this layout"):
        observable_mask(np.concatenate([obs, [0.0, 0.0]]), layout, n_act)


def test_thrust_arc_layout_is_not_guessable_from_the_size() -> None:
    # 3 planets + the operations block (3 deadlines + 2) on ThrustArc; the observation size alone would
    # read as another target count, which is why the layout comes from the env.
    layout = layout_of(PlanetNavEnv("planetnav/ThrustArc-TCM-v0", episode_steps=4))
    assert (layout.n_planets, layout.n_pulsars, layout.n_deadlines) == (3, 0, 3)
    assert layout.operations_start < layout.size


@pytest.mark.parametrize("env_id", IDS)
def test_maskable_ppo_rollout_masks_and_saved_predict(env_id: str, tmp_path) -> None:
    pytest.importorskip("sb3_contrib", reason="sb3-contrib is not installed (the [bench] extra)")
    from sb3_contrib.common.maskable.utils import get_action_masks

    from planetnav_train.sb3 import algorithm_class, load_model
    from planetnav_train.sb3_vec import PlanetNavSB3VecEnv

    vec = PlanetNavSB3VecEnv(4, env_id, seed=1, episode_steps=16)
    cls = algorithm_class("maskable_ppo")
    model = cls("MlpPolicy", vec, n_steps=8, batch_size=16, n_epochs=1, seed=0, device="cpu")
    single = PlanetNavEnv(env_id)  # its decoder reads any row of the same configuration
    obs = model.env.reset()
    n_act = int(vec.action_space.n)
    hidden_seen = 0
    for _ in range(12):  # the masks MaskablePPO collects with equal the env's decoded observable columns
        masks = get_action_masks(model.env)
        for r in range(vec.num_envs):
            want = decoded_observable(single, obs[r])
            n = want.size
            if want.any() or n_act > n:
                np.testing.assert_array_equal(masks[r, :n], want)
            assert masks[r, n:].all()  # the idle "stay" action, never masked
            hidden_seen += int((~want).sum())
        actions, _ = model.predict(obs, action_masks=masks)
        assert all(masks[r, a] for r, a in enumerate(actions))
        obs, *_ = model.env.step(actions)
    if "ThrustArc" in env_id:
        assert hidden_seen > 0, "seed 1 of the thrust arc hides a planet, or the mask tests nothing there"
    model.learn(32)
    path = tmp_path / "model.zip"
    model.save(path)
    loaded = load_model(path, algo="maskable_ppo")  # no env: the mask comes from the recorded layout
    assert loaded.observation_layout == model.observation_layout
    obs = vec.reset()
    expected = observable_mask(obs, layout_of(vec), n_act)
    for _ in range(5):
        actions, _ = loaded.predict(obs, deterministic=True)
        assert all(expected[r, a] for r, a in enumerate(actions)), (expected, actions)
        obs, *_ = vec.step(actions)
        expected = observable_mask(obs, layout_of(vec), n_act)


def test_config_check_reads_maskable_ppo_hyperparameters_through_its_subclass() -> None:
    """The masked subclass's ``__init__`` passes ``*args, **kwargs`` through: the config check takes
    MaskablePPO's own keywords from the base class (the suite's raw-track cells set n_steps, batch_size
    and n_epochs), and still names a key no class in the chain takes."""
    from planetnav_train.config import ConfigError, parse_config

    hp = {"n_steps": 64, "batch_size": 32, "n_epochs": 2}
    assert parse_config({"algo": "maskable_ppo", "hyperparams": hp}).hyperparams == hp
    with pytest.raises(ConfigError, match=r"unknown key\(s\) \['n_stepz'\].*'n_steps'"):
        parse_config({"algo": "maskable_ppo", "hyperparams": {"n_stepz": 64}})
