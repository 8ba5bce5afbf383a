"""TorchRL on planetnav, as a new user would run it (optional: skipped without torchrl).

* ``GymEnv(id)`` on every id: TorchRL passes ``frameskip`` and retries without it only on Python's
  "unexpected keyword argument" ``TypeError``, which planetnav's unknown-option error is.
* ``GymWrapper(gym.make_vec(id, num_envs=4, autoreset_mode="disabled"))``: the native vector env under
  TorchRL, which refuses Gymnasium's default ``next_step`` autoreset and resets finished rows itself
  through ``reset_mask``; a short rollout with a small torch policy runs through two episode ends.
* ``autoreset_mode="same_step"``, the other mode TorchRL accepts, with ``info_keys="numeric"`` (TorchRL 0.14
  stacks every info value into a tensor; the default keys hold names and the filter's ``{"x", "P"}``):
  the docs' snippet run verbatim, and a rollout whose rows end apart and together compared step for step
  with the vector env replayed (final observations and infos in ``next``, reset ones at the next root).

CI installs torchrl in the Ray environment (Makefile).
"""

from __future__ import annotations

import textwrap
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("torchrl", reason="torchrl is not installed (the [clients] extra)")

import torch
from tensordict import TensorDict
from tensordict.nn import TensorDictModule
from torchrl.envs import GymEnv, GymWrapper
from torchrl.envs.utils import check_env_specs

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_env.envs.registration import ENV_IDS, id_options

needs_disabled = pytest.mark.skipif(
    not hasattr(gym.vector.AutoresetMode, "DISABLED"),
    reason="autoreset_mode='disabled' needs Gymnasium >= 1.1",
)


@pytest.mark.parametrize("env_id", sorted(ENV_IDS))
def test_gym_env_builds_and_rolls_out_every_id(env_id: str) -> None:
    hold = id_options(env_id).get("decision_steps", 1)  # a v1 id's decisions hold several steps
    env = GymEnv(env_id, episode_steps=8 * hold)  # 8 decisions
    check_env_specs(env)  # TorchRL's own conformance check (a short rollout against the specs)
    td = env.rollout(10, break_when_any_done=False)
    obs_dim = gym.make(env_id).observation_space.shape[0]
    assert td["next", "observation"].shape == (10, obs_dim)
    assert torch.isfinite(td["next", "observation"]).all() and torch.isfinite(td["next", "reward"]).all()
    assert td["next", "truncated"].squeeze(-1).tolist() == [False] * 7 + [True] + [False] * 2


def _argmax_policy(obs_dim: int, n_actions: int) -> TensorDictModule:
    """A small torch network whose best action is written one-hot (TorchRL's Discrete encoding)."""
    torch.manual_seed(0)
    net = torch.nn.Sequential(torch.nn.Linear(obs_dim, 32), torch.nn.Tanh(), torch.nn.Linear(32, n_actions))

    def act(observation: torch.Tensor) -> torch.Tensor:
        return torch.nn.functional.one_hot(net(observation).argmax(-1), n_actions)

    return TensorDictModule(act, in_keys=["observation"], out_keys=["action"])


@needs_disabled
def test_gym_wrapper_over_the_native_vector_env_rolls_out() -> None:
    """The docs/environment.md example: four rows, a torch policy, episodes of 3 steps reset by TorchRL."""
    venv = gym.make_vec("planetnav/Cruise-Target-v0", num_envs=4, autoreset_mode="disabled", episode_steps=3)
    env = GymWrapper(venv)
    assert env.batch_size == torch.Size([4])
    check_env_specs(env)
    env.set_seed(0)
    td = env.rollout(8, _argmax_policy(47, 3), break_when_any_done=False)
    assert td.batch_size == torch.Size([4, 8])
    assert td["next", "observation"].shape == (4, 8, 47)
    assert torch.isfinite(td["next", "observation"]).all() and torch.isfinite(td["next", "reward"]).all()
    # Every row ends at its 3rd and 6th step; TorchRL's resets (reset_mask) start the next episodes.
    done = td["next", "done"].squeeze(-1)
    assert done.any(0).tolist() == [False, False, True, False, False, True, False, False]
    assert done.all(0).tolist() == done.any(0).tolist()
    assert (td["action"].sum(-1) == 1).all()  # one-hot actions reached the env


def _docs_example(marker: str) -> str:
    """The python block of docs/environment.md's Clients section that contains ``marker`` (run as is)."""
    text = (Path(__file__).parents[2] / "docs" / "environment.md").read_text()
    section = text.split("## Clients", 1)[1].split("\n## ", 1)[0]
    blocks = [textwrap.dedent(b.split("```", 1)[0]) for b in section.split("```python\n")[1:]]
    found = [b for b in blocks if marker in b]
    assert len(found) == 1, f"expected one example with {marker!r} in docs/environment.md, got {len(found)}"
    return found[0]


def _run_docs_example(marker: str) -> Any:
    """Run docs/environment.md's snippet containing ``marker`` verbatim; its rollout of 100 steps of 4 rows
    must be finite."""
    scope: dict = {}
    exec(_docs_example(marker), scope)
    td = scope["td"]
    assert td.batch_size == torch.Size([4, 100])
    assert torch.isfinite(td["next", "observation"]).all() and torch.isfinite(td["next", "reward"]).all()
    return td


@needs_disabled
def test_docs_disabled_example_runs() -> None:
    """docs/environment.md's ``disabled`` snippet, run verbatim."""
    _run_docs_example('autoreset_mode="disabled"')


def test_docs_same_step_example_runs() -> None:
    """docs/environment.md's ``same_step`` snippet, run verbatim: 100 steps of 4 rows with numeric info."""
    td = _run_docs_example('autoreset_mode="same_step"')
    assert torch.isfinite(td["next", "pos_sigma_km"]).all() and td["next", "filter_P"].shape == (4, 100, 6, 6)
    assert not td["next", "done"].any()  # episodes are 1,440 steps


def test_gym_wrapper_same_step_equals_the_env_step_for_step() -> None:
    """``autoreset_mode="same_step"`` with ``info_keys="numeric"``: TorchRL's tensordict holds exactly what
    planetnav returned, replayed on a second vector env with the same seed and actions. A row that ends puts
    its last observation and info (``final_obs``, ``final_info``) in ``next`` and the same step's reset
    observation and info at the root of the following step; when every row ends at once TorchRL calls
    ``reset()`` itself. ``divergence_km`` = 1,500 km ends some rows at their first steps (the initial error
    is drawn with 1,000 km per axis), so rows end at different steps as well as together."""
    kwargs = dict(
        num_envs=4, autoreset_mode="same_step", info_keys="numeric", episode_steps=3, divergence_km=1500.0
    )
    steps, seed = 12, 3
    env = GymWrapper(gym.make_vec("planetnav/Cruise-Target-v0", **kwargs))
    env.set_seed(seed)  # TorchRL: reset(seed=3); the rollout then calls reset()
    td = env.rollout(steps, _argmax_policy(47, 3), break_when_any_done=False)
    assert td.batch_size == torch.Size([4, steps])
    assert torch.isfinite(td["next", "observation"]).all() and torch.isfinite(td["next", "reward"]).all()

    ref = gym.make_vec("planetnav/Cruise-Target-v0", **kwargs)
    ref.reset(seed=seed)
    obs, info = ref.reset()
    keys = [k for k in info if not k.startswith("_")]
    assert "filter_P" in keys and "target" not in keys
    actions = td["action"].argmax(-1).numpy()
    partial = together = 0
    since_reset = np.zeros(4, dtype=int)
    for t in range(steps):
        assert np.array_equal(td["observation"][:, t].numpy(), obs)
        for k in keys:
            assert np.array_equal(td[k][:, t].numpy(), info[k]), (k, t)
        obs, reward, terminated, truncated, info = ref.step(actions[:, t])
        done = terminated | truncated
        # What the step ended on: the final observation and info of the rows that ended.
        last_obs, last_info = obs.copy(), {k: info[k].copy() for k in keys}
        for r in np.flatnonzero(done):
            last_obs[r] = info["final_obs"][r]
            for k in keys:
                last_info[k][r] = info["final_info"][r][k]
        assert np.array_equal(td["next", "observation"][:, t].numpy(), last_obs), t
        for k in keys:
            assert np.array_equal(td["next", k][:, t].numpy(), last_info[k]), (k, t)
        assert np.array_equal(td["next", "reward"][:, t, 0].numpy(), reward.astype(np.float32))
        assert np.array_equal(td["next", "terminated"][:, t, 0].numpy(), terminated)
        assert np.array_equal(td["next", "truncated"][:, t, 0].numpy(), truncated)
        since_reset += 1
        assert (since_reset[truncated] == 3).all() and (since_reset <= 3).all()  # 3-step episodes
        since_reset[done] = 0
        if done.all():
            together += 1
            obs, info = ref.reset()  # TorchRL's own reset when every row has ended
        elif done.any():
            partial += 1
    assert partial >= 2 and together >= 1, (partial, together)
    check_env_specs(env)  # TorchRL's conformance check, after the rollout (see the docs' caveat on reset)


def test_same_step_full_reset_right_after_rows_end_apart() -> None:
    """The docs' TorchRL 0.14 caveat: after a step on which some but not all rows ended, a plain
    ``env.reset()`` (the vector env is reset for real) returns the observations that
    ``VecGymEnvTransform`` saved at that step, not the rows' new ones; a reset with an all-True ``_reset``
    returns the new ones. If TorchRL fixes its transform the first assertion fails: drop the caveat."""
    kwargs = dict(
        num_envs=4, autoreset_mode="same_step", info_keys="numeric", episode_steps=3, divergence_km=1500.0
    )
    env = GymWrapper(gym.make_vec("planetnav/Cruise-Target-v0", **kwargs))
    venv = env.base_env._env.unwrapped
    env.set_seed(3)
    policy = _argmax_policy(47, 3)
    root = env.reset()
    for _ in range(30):
        out, root = env.step_and_maybe_reset(policy(root))
        ended = int(out["next", "done"].sum())
        if 0 < ended < 4:
            break
    assert 0 < ended < 4, "no step ended some but not all rows"
    stale = env.reset()
    assert not np.array_equal(stale["observation"].numpy(), venv.observations())
    fresh = env.reset(TensorDict({"_reset": torch.ones(4, 1, dtype=torch.bool)}, batch_size=[4]))
    assert np.array_equal(fresh["observation"].numpy(), venv.observations())


def test_gym_wrapper_same_step_needs_numeric_info() -> None:
    """With the default keys (names, the nested filter) TorchRL 0.14's same_step reader cannot build its
    tensors: the reason ``info_keys="numeric"`` exists. If this starts to pass, TorchRL accepts the
    default keys and the docs can drop the option from the example."""
    venv = gym.make_vec("planetnav/Cruise-Target-v0", num_envs=4, autoreset_mode="same_step", episode_steps=3)
    with pytest.raises(IndexError):  # its reader on the all-None `target` names at reset
        GymWrapper(venv).rollout(7, break_when_any_done=False)
