"""baselines/ppo_continuous.py: the single-file PPO with a Gaussian head on a Box of actions. It runs end to
end, its log-probabilities and entropies are Stable-Baselines3's for the same weights, its sampled
evaluation draws the suite's evaluator's draws, its whole training loop ends with SB3's weights when given
SB3's random draws, and the wrong action space or agent file is refused by name."""

from __future__ import annotations

import importlib.util
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "baselines" / "ppo_continuous.py"
TASK = "planetnav/Cruise-Torque-v2"
LR = 3e-4


def _module():
    spec = importlib.util.spec_from_file_location("ppo_continuous", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _sb3_ppo(T: int, N: int, seed: int, **hyperparams):
    """Stable-Baselines3's PPO on the suite's training env of the torque task (N rows, 40-decision
    episodes): T decisions a rollout, minibatches of 32, 2 epochs, entropy 0.01 (the script's)."""
    from stable_baselines3 import PPO

    from planetnav_train.config import parse_config
    from planetnav_train.envs import make_training_env

    env = {"episode_steps": 40}
    tc = parse_config({"algo": "ppo", "env_id": TASK, "n_envs": N, "seed": seed, "env": env})
    return PPO("MlpPolicy", make_training_env(tc, None), n_steps=T, batch_size=32, n_epochs=2, ent_coef=0.01,
               learning_rate=LR, seed=seed, device="cpu", **hyperparams)  # fmt: skip


def test_runs_two_updates_saves_a_gaussian_agent_and_prints_a_finite_score(tmp_path: Path) -> None:
    model = tmp_path / "agent.pt"
    proc = subprocess.run(
        [sys.executable, str(SCRIPT), "--num-envs", "8", "--num-steps", "16", "--total-timesteps", "256",
         "--eval-episodes", "3", "--episode-steps", "40", "--seed", "0", "--save-model", str(model)],
        cwd=ROOT, capture_output=True, text=True, timeout=900, check=False,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert re.findall(r"^iter +(\d+)/2 ", proc.stdout, re.M) == ["1", "2"], proc.stdout
    m = re.search(r"^blind-zero score: (\S+) \[(\S+), (\S+)\]", proc.stdout, re.M)
    assert m and all(np.isfinite(float(x)) for x in m.groups()), proc.stdout
    state = torch.load(model)
    assert state["log_std"].shape == (3,) and state["actor.4.weight"].shape[0] == 3
    # The log std is trained (it starts at 0): two updates of Adam move it by ~LR per step.
    assert 0 < float(state["log_std"].abs().max()) < 40 * LR * 3, state["log_std"]
    loaded = _module().load_agent(model).state_dict()
    assert all(torch.equal(loaded[k], state[k]) for k in state)


def test_log_probabilities_and_entropies_are_stable_baselines3s() -> None:
    """SB3's ``evaluate_actions`` is the oracle: the same weights give the same values, log-probabilities
    (summed over the axes) and entropies, on actions inside and outside the Box."""
    mod = _module()
    model = _sb3_ppo(16, 2, seed=1)
    with torch.no_grad():
        model.policy.log_std.copy_(torch.tensor([-0.5, 0.0, 0.7]))
    agent = mod.agent_from_sb3(model.policy.state_dict())
    obs_dim = agent.actor[0].in_features
    obs = torch.as_tensor(np.random.default_rng(0).normal(size=(5, obs_dim)), dtype=torch.float32)
    act = torch.as_tensor(np.random.default_rng(1).uniform(-2, 2, size=(5, 3)), dtype=torch.float32)
    with torch.no_grad():
        v, lp, ent = model.policy.evaluate_actions(obs, act)
        _, ours_lp, ours_ent, ours_v = agent.get_action_and_value(obs, act)
    torch.testing.assert_close(ours_lp, lp, rtol=1e-6, atol=1e-5)
    torch.testing.assert_close(ours_ent, ent, rtol=1e-6, atol=1e-6)
    torch.testing.assert_close(ours_v, v, rtol=1e-6, atol=1e-6)


def test_sampled_evaluation_draws_the_suites_draws(tmp_path: Path) -> None:
    """A Gaussian policy scores here what it scores in the suite: the script's sampled evaluation of an SB3
    policy gives the suite's evaluator's per-episode objective (``PATH@sampled``) to its rounding; another
    ``stream`` gives other draws, hence another J."""
    import yaml

    from planetnav_env.config import EnvConfig
    from planetnav_env.envs.registration import id_options
    from planetnav_train.evaluate import evaluate_agent
    from planetnav_train.suite import OBJECTIVES, get_task

    mod = _module()
    cfg = EnvConfig.from_dict(id_options(TASK), episode_steps=60, noise_streams="per_step")
    model = _sb3_ppo(16, 2, seed=0)  # never trained; the means made to depend on the observation
    with torch.no_grad():
        model.policy.action_net.weight.mul_(100.0)
    run = tmp_path / "run"
    run.mkdir()
    model.save(run / "model.zip")
    (run / "config.yaml").write_text(yaml.safe_dump({"algo": "ppo"}))
    seeds = [50_000, 50_001, 50_002]
    m = evaluate_agent(f"{run}@sampled", cfg, len(seeds), seeds[0], progress=False).metrics
    suite_j = OBJECTIVES[get_task("Cruise-Torque-v2").objective].values(m)
    agent = mod.agent_from_sb3(model.policy.state_dict())
    single = mod.single
    j = single.evaluate(mod.sampled_policy(agent, seeds), cfg, seeds)
    # The draws are the suite's; the means are not bit for bit: a batched forward pass rounds their last
    # bits otherwise than the suite's (planetnav_train.evaluate._sample_rows), and a continuous action
    # carries them. They move J by ~1e-7 of itself; other draws move it by far more.
    np.testing.assert_allclose(j, suite_j, rtol=1e-6)
    other = single.evaluate(mod.sampled_policy(agent, seeds, stream=1), cfg, seeds)
    assert (np.abs(other - j) > 1e-3 * j).all(), (other, j)


def test_training_loop_equals_stable_baselines3s_ppo_on_its_draws(
    monkeypatch: pytest.MonkeyPatch, sb3_learn, sb3_order
) -> None:
    """ppo_single_file's loop with the Gaussian agent against Stable-Baselines3's PPO on the Box: three
    updates of 8 rows x 16 decisions with 40-decision episodes (so time limits are bootstrapped). Given
    SB3's initial weights, torch's generator where SB3's first draw finds it, and SB3's minibatch order,
    ``train()`` ends with SB3's weights, the log std included: the unclipped sample is stored and the
    clipped one stepped, as SB3 does."""
    mod = _module()
    single = mod.single
    torch.set_num_threads(1)
    T, N, updates, seed = 16, 8, 3, 3
    before, after, at_first_draw = sb3_learn(_sb3_ppo(T, N, seed=seed, gamma=0.95), T * N * updates)
    names = {**single.SB3_NAMES, "log_std": "log_std"}

    def sb3_initialized(space, obs_dim):
        agent = mod.box_agent(space, obs_dim)
        agent.load_state_dict({ours: before[theirs] for ours, theirs in names.items()})
        torch.set_rng_state(at_first_draw["torch"])  # the initialization above drew from it
        return agent

    monkeypatch.setattr(single, "shuffler", sb3_order(T, N))
    np.random.set_state(at_first_draw["numpy"])  # noqa: NPY002
    args = single.parse_args(["--env-id", TASK, "--num-envs", str(N), "--num-steps", str(T),
                              "--num-minibatches", "4", "--update-epochs", "2", "--seed", str(seed),
                              "--learning-rate", str(LR), "--episode-steps", "40", "--eval-episodes", "0",
                              "--total-timesteps", str(T * N * updates)])  # fmt: skip
    agent = single.train(args, sb3_initialized)
    for ours, theirs in names.items():
        moved = (after[theirs] - before[theirs]).abs().max().item()
        assert moved > 1e-4, (theirs, moved)
        torch.testing.assert_close(agent.state_dict()[ours], after[theirs], rtol=0, atol=1e-5, msg=ours)


def test_the_wrong_action_space_or_agent_file_is_refused_by_name(tmp_path: Path) -> None:
    import gymnasium as gym

    mod = _module()
    with pytest.raises(ValueError, match=r"takes a 1-D Box of actions, not Discrete\(3\)"):
        mod.box_agent(gym.spaces.Discrete(3), 10)
    with pytest.raises(ValueError, match=r"takes Discrete actions, not Box"):
        mod.single.discrete_agent(gym.spaces.Box(-1, 1, (3,)), 10)
    torch.save(mod.single.Agent(10, 3).state_dict(), tmp_path / "discrete.pt")
    with pytest.raises(ValueError, match="no log_std: not a Gaussian agent"):
        mod.load_agent(tmp_path / "discrete.pt")
