"""A CleanRL-style PPO loop over ``gym.make_vec`` (optional: skipped without torch).

CleanRL writes its algorithms as one plain file: a torch network, a rollout buffer of arrays, GAE and the
clipped PPO loss, over a Gymnasium vector env. This is that loop, short, on planetnav's native vector env
with Gymnasium's default ``next_step`` autoreset: the step after a row ends only resets it (its action is
ignored, its reward is 0), so those transitions are masked out of the loss, as CleanRL does for
Gymnasium 1.x.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import planetnav_env  # noqa: F401  (registers the ids)

torch = pytest.importorskip("torch", reason="torch is not installed (the [train] extra)")

NUM_ENVS, NUM_STEPS, ITERATIONS, EPOCHS, MINIBATCHES = 4, 32, 3, 2, 4
GAMMA, LAMBDA, CLIP, ENT_COEF, VF_COEF, LR = 0.99, 0.95, 0.2, 0.01, 0.5, 3e-4


class Agent(torch.nn.Module):
    """Separate actor (logits over the discrete targets) and critic MLPs, as CleanRL's ppo.py."""

    def __init__(self, obs_dim: int, n_actions: int) -> None:
        super().__init__()
        self.critic = torch.nn.Sequential(
            torch.nn.Linear(obs_dim, 64), torch.nn.Tanh(), torch.nn.Linear(64, 1)
        )
        self.actor = torch.nn.Sequential(
            torch.nn.Linear(obs_dim, 64), torch.nn.Tanh(), torch.nn.Linear(64, n_actions)
        )

    def value(self, obs: torch.Tensor) -> torch.Tensor:
        return self.critic(obs).squeeze(-1)

    def act(self, obs: torch.Tensor, action: torch.Tensor | None = None):
        """(action, log-prob, entropy, value); samples an action when none is given."""
        dist = torch.distributions.Categorical(logits=self.actor(obs))
        if action is None:
            action = dist.sample()
        return action, dist.log_prob(action), dist.entropy(), self.value(obs)


def run_ppo(env_id: str) -> dict[str, list[float]]:
    """A few PPO iterations; returns the per-iteration losses and the finished episodes' returns."""
    envs = gym.make_vec(env_id, num_envs=NUM_ENVS, episode_steps=12)
    assert isinstance(envs.single_action_space, gym.spaces.Discrete)
    obs_dim = envs.single_observation_space.shape[0]
    torch.manual_seed(0)
    agent = Agent(obs_dim, int(envs.single_action_space.n))
    optimizer = torch.optim.Adam(agent.parameters(), lr=LR, eps=1e-5)
    shape = (NUM_STEPS, NUM_ENVS)
    obs_buf = torch.zeros((*shape, obs_dim))
    actions, logprobs, rewards, values = (torch.zeros(shape) for _ in range(4))
    dones, valid = torch.zeros(shape), torch.zeros(shape)

    next_obs = torch.as_tensor(envs.reset(seed=1)[0])
    next_done = torch.zeros(NUM_ENVS)
    autoresetting = np.zeros(NUM_ENVS, dtype=bool)  # rows whose next step only resets them
    ep_return, returns, losses = np.zeros(NUM_ENVS), [], []
    for _ in range(ITERATIONS):
        for step in range(NUM_STEPS):
            obs_buf[step], dones[step] = next_obs, next_done
            valid[step] = torch.as_tensor(~autoresetting, dtype=torch.float32)
            with torch.no_grad():
                action, logprob, _, value = agent.act(next_obs)
            actions[step], logprobs[step], values[step] = action.float(), logprob, value
            obs, reward, terminated, truncated, info = envs.step(action.numpy())
            assert obs.shape == (NUM_ENVS, obs_dim) and reward.shape == (NUM_ENVS,)
            assert np.isfinite(obs).all() and np.isfinite(reward).all()
            assert info["pos_err_km"].shape == (NUM_ENVS,)
            assert np.all(reward[autoresetting] == 0.0)  # the reset step: reward 0, action ignored
            rewards[step] = torch.as_tensor(reward, dtype=torch.float32)
            ep_return += reward
            done = terminated | truncated
            returns += ep_return[done].tolist()
            ep_return[done] = 0.0
            autoresetting = done
            next_obs = torch.as_tensor(obs)
            next_done = torch.as_tensor(done, dtype=torch.float32)

        with torch.no_grad():  # GAE (truncations bootstrap as terminations here, as CleanRL's ppo.py)
            next_value = agent.value(next_obs)
            advantages = torch.zeros(shape)
            last = torch.zeros(NUM_ENVS)
            for t in reversed(range(NUM_STEPS)):
                nonterminal = 1.0 - (next_done if t == NUM_STEPS - 1 else dones[t + 1])
                following = next_value if t == NUM_STEPS - 1 else values[t + 1]
                delta = rewards[t] + GAMMA * following * nonterminal - values[t]
                last = delta + GAMMA * LAMBDA * nonterminal * last
                advantages[t] = last
            targets = advantages + values
        assert torch.isfinite(advantages).all()

        keep = valid.reshape(-1) > 0  # drop the autoreset transitions
        b_obs, b_act = obs_buf.reshape(-1, obs_dim)[keep], actions.reshape(-1)[keep]
        b_logp, b_adv = logprobs.reshape(-1)[keep], advantages.reshape(-1)[keep]
        b_ret = targets.reshape(-1)[keep]
        n = len(b_obs)
        assert masked_count_is_plausible(n)
        for _ in range(EPOCHS):
            for idx in torch.randperm(n).chunk(MINIBATCHES):
                _, newlogp, entropy, newvalue = agent.act(b_obs[idx], b_act[idx].long())
                ratio = (newlogp - b_logp[idx]).exp()
                adv = (b_adv[idx] - b_adv[idx].mean()) / (b_adv[idx].std() + 1e-8)
                pg_loss = torch.max(-adv * ratio, -adv * ratio.clamp(1 - CLIP, 1 + CLIP)).mean()
                v_loss = 0.5 * ((newvalue - b_ret[idx]) ** 2).mean()
                loss = pg_loss - ENT_COEF * entropy.mean() + VF_COEF * v_loss
                optimizer.zero_grad()
                loss.backward()
                torch.nn.utils.clip_grad_norm_(agent.parameters(), 0.5)
                optimizer.step()
        losses.append(float(loss))
    envs.close()
    return {"losses": losses, "returns": returns}


def masked_count_is_plausible(n: int) -> bool:
    """Episodes of 12 steps: per row, one reset step in each 13 is masked out, never more."""
    total = NUM_STEPS * NUM_ENVS
    return total - NUM_ENVS * (NUM_STEPS // 13 + 1) <= n < total


@pytest.mark.parametrize("env_id", ["planetnav/Cruise-Target-v0", "planetnav/MarsApproach-Tasking-v0"])
def test_cleanrl_style_ppo_runs_end_to_end(env_id: str) -> None:
    out = run_ppo(env_id)
    assert len(out["losses"]) == ITERATIONS and np.all(np.isfinite(out["losses"]))
    # 96 steps per row at 13 steps per episode (12 and the reset step): 7 episodes per row.
    assert len(out["returns"]) == NUM_ENVS * 7
    assert np.all(np.isfinite(out["returns"])) and np.all(np.asarray(out["returns"]) < 0)  # -error / scale
