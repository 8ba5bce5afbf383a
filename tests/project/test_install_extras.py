"""The environment without the ``[train]`` extra: no torch, no Stable-Baselines3.

A user who only wants the environment installs ``planetnav`` without extras. This test runs, in a fresh
interpreter where importing torch, Stable-Baselines3 and the other training-only packages fails as it does
when they are not installed, everything that user does: ``import planetnav_env``, ``gym.make`` and
stepping every id, ``gym.make_vec``, ``import planetnav_agents`` and the rule agents acting. The training
packages are blocked by a meta-path finder that raises ``ModuleNotFoundError``: putting ``None`` in
``sys.modules`` would not look like a missing package (SciPy's array-API helpers, imported by the
environment, test ``"torch" in sys.modules`` and then read ``torch.Tensor``, which fails on ``None``).
"""

from __future__ import annotations

import subprocess
import sys
import textwrap

SCRIPT = textwrap.dedent(
    """
    import importlib.abc
    import sys

    BLOCKED = ("torch", "stable_baselines3", "sb3_contrib", "tensorboard", "tqdm", "rich", "torchrl", "ray")


    class Missing(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path=None, target=None):
            if name.partition(".")[0] in BLOCKED:
                raise ModuleNotFoundError(f"No module named {name!r}", name=name)
            return None


    sys.meta_path.insert(0, Missing())
    for name in list(sys.modules):
        if name.partition(".")[0] in BLOCKED:
            del sys.modules[name]

    import gymnasium as gym
    import numpy as np

    import planetnav_agents
    import planetnav_env
    from planetnav_agents import make_agent

    steps = 0
    for env_id in planetnav_env.ENV_IDS:
        hold = planetnav_env.ENV_IDS[env_id].get("decision_steps", 1)
        env = gym.make(env_id, episode_steps=4 * hold)
        # Rule agents act at the physics step (a v1 id's references run on its v0 interface).
        agents = ["greedy", "baseline", "planner:horizon=3,replan=2", "random"]
        # The default cycle names three planets; the Mars approach has one (and two pulsars).
        agents.append("periodic:cycle=0" if "MarsApproach" in env_id else "periodic")
        agents = agents if env_id.endswith("-v0") else ["random"]
        for name in agents:
            agent = make_agent(name, env)
            obs, info = env.reset(seed=1)
            agent.reset(seed=1)
            for _ in range(3):
                obs, reward, terminated, truncated, info = env.step(agent.act(obs, info))
                assert np.isfinite(reward) and np.all(np.isfinite(obs)), (env_id, name)
                steps += 1
        venv = gym.make_vec(env_id, num_envs=3, episode_steps=4 * hold)
        obs, info = venv.reset(seed=2)
        for _ in range(5):  # through one next-step autoreset
            obs, reward, terminated, truncated, info = venv.step(venv.action_space.sample())
            assert obs.shape[0] == 3 and np.all(np.isfinite(reward))
        assert info["target"].shape == (3,)
    # the rule agents are the agents package's own: nothing of the training packages was imported
    training = sorted(m for m in sys.modules if m.partition(".")[0] in ("planetnav_train", "planetnav_rl"))
    assert not training, training
    try:
        make_agent("no/such/model", gym.make("planetnav/Cruise-Target-v0"))
    except ValueError as exc:
        assert "planetnav_train" in str(exc), exc
    else:
        raise AssertionError("make_agent of a missing model path built an agent")
    try:
        import planetnav_train.sb3_vec  # noqa: F401
    except ImportError as exc:
        assert "planetnav[train]" in str(exc), exc
    else:
        raise AssertionError("planetnav_train.sb3_vec imported without Stable-Baselines3")
    loaded = sorted(m for m in sys.modules if m.partition(".")[0] in BLOCKED)
    assert not loaded, loaded
    print("OK", steps, planetnav_agents.__name__)
    """
)


def test_environment_and_rule_agents_run_without_torch_or_sb3() -> None:
    """``import planetnav_env``, ``gym.make``, stepping, ``gym.make_vec``, ``import planetnav_agents`` and
    the rule agents (greedy, baseline, periodic, planner, random) on every v0 id and random on every v1 id,
    with torch and SB3 absent;
    the SB3 adapter then fails with an error that names the extra to install."""
    proc = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    ids = __import__("planetnav_env").ENV_IDS
    v0 = sum(i.endswith("-v0") for i in ids)  # five agents on each v0 id, random alone on each v1 id
    assert proc.stdout.split()[:2] == ["OK", str((v0 * 5 + (len(ids) - v0)) * 3)], proc.stdout
