"""The v3 posing options: the reward's time-only baseline (``reward_baseline_km``) and the unit-scaled
observation (``observation_scaling: unit``), against what their definitions say, computed here in numpy
from the same rollout without them; and the v3 ids' declarations."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_env.config import EnvConfig
from planetnav_env.core.layout import ObservationLayout, unit_scaling
from planetnav_env.envs.vector_env import PlanetNavVectorEnv
from planetnav_env.errors import OptionError
from planetnav_env.tasks import VERSIONS, get_version

STEPS = 23  # not a multiple of the bins below: the last bin is shorter


def _rollout(cfg: EnvConfig, actions: np.ndarray, seed: int = 5):
    env = PlanetNavVectorEnv(2, cfg, autoreset_mode="disabled")
    obs, _ = env.reset(seed=seed)
    out_obs, out_r, err = [obs], [], []
    for a in actions:
        r, term, trunc = env.step_rows(a, np.ones(2, bool))
        out_r.append(r)
        out_obs.append(env.observations())
        err.append(env.info_arrays()["pos_err_km"])
        if (term | trunc).all():
            break
    env.close()
    return np.array(out_obs), np.array(out_r), np.array(err)


def _cfg(**over) -> EnvConfig:
    return EnvConfig.from_dict({"episode_steps": STEPS, "reward": "truth", "reward_scale_km": 250.0, **over})


def test_the_baseline_shifts_each_step_by_its_bin_and_leaves_the_episode_otherwise_unchanged():
    base = (100.0, -40.0, 7.5, 3000.0, 0.25)
    rng = np.random.default_rng(0)
    for _policy in range(2):
        actions = rng.integers(0, 3, (STEPS, 2))
        o0, r0, e0 = _rollout(_cfg(), actions)
        o1, r1, e1 = _rollout(_cfg(reward_baseline_km=base), actions)
        np.testing.assert_array_equal(o0, o1)  # the baseline changes the reward only
        np.testing.assert_array_equal(e0, e1)
        k = np.arange(1, STEPS + 1)
        b = np.array(base)[((k - 1) * len(base)) // STEPS]
        np.testing.assert_allclose(r0, -e0 / 250.0, rtol=1e-12)
        np.testing.assert_allclose(r1, -(e0 - b[:, None]) / 250.0, rtol=1e-12, atol=1e-12)
        # The return moves by the same constant whatever the policy: the optimum is the same policy.
        np.testing.assert_allclose(r1.sum(axis=0) - r0.sum(axis=0), sum(b) / 250.0, rtol=1e-12)


def test_unit_scaling_writes_each_column_as_its_declared_affine_of_the_raw_one():
    for over in ({}, {"scenario": "mars-approach", "planets": ("mars",), "pulsars": ("B0531+21",),
                      "step_s": 300.0}):  # fmt: skip
        actions = np.zeros((6, 2), np.int64)
        raw, _, _ = _rollout(_cfg(episode_steps=6, **over), actions)
        unit, _, _ = _rollout(_cfg(episode_steps=6, observation_scaling="unit", **over), actions)
        cfg = _cfg(episode_steps=6, **over)
        aff = unit_scaling(ObservationLayout.for_config(cfg), cfg.scenario)
        # The kernels scale the float64 value, then it is stored as float32.
        np.testing.assert_allclose(unit, (raw.astype(float) - aff[0]) / aff[1], rtol=1e-5, atol=1e-5)
        assert (aff[1] > 0).all() and not np.array_equal(raw, unit)


def test_bad_posing_options_name_the_option_through_make():
    for bad in ({"reward_baseline_km": (1.0, math.nan)}, {"reward_baseline_km": (1.0, math.inf)},
                {"observation_scaling": "standard"}, {"reward_baseline_km": "fast"}):  # fmt: skip
        name = next(iter(bad))
        with pytest.raises(OptionError, match=name):
            gym.make("planetnav/Cruise-Target-v2", **bad)


V3 = sorted(i for i in VERSIONS if i.endswith("-v3"))


def test_the_v3_ids_are_the_five_flight_world_tasks():
    assert [i.split("/")[1] for i in V3] == sorted(
        ["Cruise-Target-v3", "RandomCruise-Target-v3", "MarsApproach-Tasking-v3", "ThrustArc-TCM-v3",
         "Cruise-Torque-v3"]
    )  # fmt: skip


@pytest.mark.parametrize("env_id", V3)
def test_a_v3_id_is_posed_in_the_flight_world_and_its_rules_read_the_raw_observation(env_id):
    v = get_version(env_id)
    cfg = v.config()
    assert cfg.world.preset == "flight" and cfg.reward == "truth"
    assert cfg.observation_scaling == "unit" and cfg.target_actions == "absolute"
    assert EnvConfig.from_dict(v.rule_options()).observation_scaling == "raw"
    assert cfg.at_physics_step().observation_scaling == "raw"
    assert cfg.observe_residual_log
