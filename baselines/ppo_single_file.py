"""Single-file PPO on planetnav's native vector env, scored on the suite's blind-zero scale.

    python baselines/ppo_single_file.py --env-id planetnav/Cruise-Target-v2 --total-timesteps 300000

In the style of CleanRL's ppo.py: read it top to bottom. The arguments, the agent (two 64-64 tanh MLPs),
the rollout / GAE / clipped-update loop on ``gym.make_vec(id, num_envs=N)`` (the batch-first compiled
:class:`~planetnav_env.envs.vector_env.PlanetNavVectorEnv`, not a SyncVectorEnv), then the evaluation.
Box actions (the torque tasks): baselines/ppo_continuous.py, this loop with a Gaussian head.

The defaults are the suite's PPO settings for the target-choice tasks (configs/v2/cruise_target_v2_ppo.yaml;
Stable-Baselines3's PPO defaults otherwise): 64 envs x 64 decisions per update, 4 minibatches of 1,024,
5 epochs, discount 0.95 per decision, GAE lambda 0.95, clip 0.2, entropy 0.01, Adam at 3e-4. A timestep is
one decision of one env (a vector-env step; 300,000 decisions = the suite's budget). A truncated episode
is bootstrapped from the value of its last observation, as Stable-Baselines3 does.

Evaluation, suite v2's protocol: sampled actions on its evaluation seeds (50,000.., one row per seed) with
per-step noise streams, each episode's draws seeded as the suite seeds them (a policy scores here what it
scores in the suite, draw for draw); J is each episode's mean true position error [km]. The blind-zero
score ``(J_blind - J) / (J_blind - J_best)`` and its 95 % paired bootstrap interval come from the suite's
scorer (:func:`planetnav_train.suite.blind.paired_ratio_ci`), against the per-seed values stored in
docs/tasks_v2_blind.json (its 100 seeds' prefix), or evaluated here by the suite's evaluator with
``--episode-steps`` or beyond them. Suite v3 scores a saved agent: ``python -m planetnav_train.suite.v3
agent-rows``. Training results differ across CPUs (torch picks its kernels per CPU); the env does not.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch
from torch import nn
from torch.distributions import Categorical

import planetnav_env  # noqa: F401  (registers the planetnav/* ids)
from planetnav_env.config import EnvConfig
from planetnav_env.envs.registration import id_options
from planetnav_env.envs.vector_env import PlanetNavVectorEnv
from planetnav_train.suite.blind import evaluate_objective, paired_ratio_ci

BLIND_JSON = Path(__file__).resolve().parents[1] / "docs" / "tasks_v2_blind.json"


def make_parser(
    description: str = "Single-file PPO on planetnav's native vector env.",
) -> argparse.ArgumentParser:
    """The arguments (baselines/ppo_device.py adds its own to these)."""
    p = argparse.ArgumentParser(description=description)
    a = p.add_argument
    a("--env-id", default="planetnav/Cruise-Target-v2", help="a target-choice id (Discrete actions)")
    a("--seed", type=int, default=0, help="torch's seed; env row i is reset with seed + i")
    a("--torch-threads", type=int, default=1, help="torch CPU threads (1: the suite's setting)")
    a("--total-timesteps", type=int, default=300_000, help="decisions summed over the envs")
    a("--num-envs", type=int, default=64, help="rows of the native vector env")
    a("--num-steps", type=int, default=64, help="decisions per env per rollout")
    a("--learning-rate", type=float, default=3e-4)
    a("--anneal-lr", action="store_true", help="anneal the learning rate linearly to 0")
    a("--gamma", type=float, default=0.95, help="discount per decision")
    a("--gae-lambda", type=float, default=0.95)
    a("--num-minibatches", type=int, default=4)
    a("--update-epochs", type=int, default=5)
    a("--clip-coef", type=float, default=0.2)
    a("--ent-coef", type=float, default=0.01)
    a("--vf-coef", type=float, default=0.5)
    a("--max-grad-norm", type=float, default=0.5)
    a("--target-kl", type=float, default=None, help="stop an update's epochs past this KL (None: never)")
    a("--episode-steps", type=int, default=None, help="shorter episodes [physics steps], for smoke runs")
    a("--eval-episodes", type=int, default=100, help="evaluation seeds 50,000.. (0: no evaluation)")
    a("--blind-json", default=str(BLIND_JSON), help="the blind search's per-seed reference values")
    a("--save-model", default=None, help="write the agent's state_dict here (torch.save)")
    return p


def finish_args(args: argparse.Namespace) -> argparse.Namespace:
    """The sizes derived from the arguments."""
    args.batch_size = args.num_envs * args.num_steps
    args.minibatch_size = max(1, args.batch_size // args.num_minibatches)
    args.num_iterations = max(1, math.ceil(args.total_timesteps / args.batch_size))
    return args


def parse_args(argv: list[str] | None = None, parser=None) -> argparse.Namespace:
    return finish_args((parser or make_parser()).parse_args(argv))


def layer_init(layer: nn.Linear, std: float = math.sqrt(2), bias_const: float = 0.0) -> nn.Linear:
    nn.init.orthogonal_(layer.weight, std)
    nn.init.constant_(layer.bias, bias_const)
    return layer


class Agent(nn.Module):
    """Separate actor and critic MLPs (64-64, tanh, orthogonal init): Stable-Baselines3's MlpPolicy."""

    action_shape, action_dtype = (), torch.long  # a row's action (the rollout's storage): one index

    def __init__(self, obs_dim: int, n_actions: int) -> None:
        super().__init__()
        self.critic = nn.Sequential(
            layer_init(nn.Linear(obs_dim, 64)), nn.Tanh(),
            layer_init(nn.Linear(64, 64)), nn.Tanh(),
            layer_init(nn.Linear(64, 1), std=1.0),
        )  # fmt: skip
        self.actor = nn.Sequential(
            layer_init(nn.Linear(obs_dim, 64)), nn.Tanh(),
            layer_init(nn.Linear(64, 64)), nn.Tanh(),
            layer_init(nn.Linear(64, n_actions), std=0.01),
        )  # fmt: skip

    def get_value(self, x: torch.Tensor) -> torch.Tensor:
        return self.critic(x)

    def get_action_and_value(self, x: torch.Tensor, action: torch.Tensor | None = None):
        probs = Categorical(logits=self.actor(x))
        action = probs.sample() if action is None else action
        return action, probs.log_prob(action), probs.entropy(), self.critic(x)


#: Each Agent parameter's name in Stable-Baselines3's MlpPolicy (the same layers, same shapes).
SB3_NAMES = {
    f"{ours}.{w}": f"{theirs}.{w}"
    for ours, theirs in {"critic.0": "mlp_extractor.value_net.0", "critic.2": "mlp_extractor.value_net.2",
                         "critic.4": "value_net", "actor.0": "mlp_extractor.policy_net.0",
                         "actor.2": "mlp_extractor.policy_net.2", "actor.4": "action_net"}.items()
    for w in ("weight", "bias")
}  # fmt: skip


def agent_from_sb3(policy_state: dict) -> Agent:
    """An Agent holding the weights of an SB3 ``MlpPolicy``'s ``state_dict()`` (a PPO on Discrete actions)."""
    agent = Agent(policy_state["mlp_extractor.policy_net.0.weight"].shape[1],
                  policy_state["action_net.weight"].shape[0])  # fmt: skip
    agent.load_state_dict({ours: policy_state[theirs] for ours, theirs in SB3_NAMES.items()})
    return agent


def load_agent(path: str | Path) -> Agent:
    """An Agent holding the ``state_dict`` that ``--save-model`` wrote at ``path``."""
    state = torch.load(path, map_location="cpu")
    agent = Agent(state["actor.0.weight"].shape[1], state["actor.4.weight"].shape[0])
    agent.load_state_dict(state)
    return agent


def env_options(args: argparse.Namespace) -> dict:
    """The env options this run overrides on top of the id's."""
    return {"episode_steps": args.episode_steps} if args.episode_steps else {}


def gae(rewards, values, dones, next_value, next_done, gamma: float, lam: float):
    """Generalized advantage estimation over a (T, N) rollout (tensors on any device): ``dones[t]`` marks
    the rows whose episode ended before step ``t``'s observation; returns (advantages, returns)."""
    advantages = torch.zeros_like(rewards)
    lastgaelam = 0
    for t in reversed(range(rewards.shape[0])):
        if t == rewards.shape[0] - 1:
            nextnonterminal, nextvalues = 1.0 - next_done, next_value
        else:
            nextnonterminal, nextvalues = 1.0 - dones[t + 1], values[t + 1]
        delta = rewards[t] + gamma * nextvalues * nextnonterminal - values[t]
        lastgaelam = delta + gamma * lam * nextnonterminal * lastgaelam
        advantages[t] = lastgaelam
    return advantages, advantages + values


def ppo_update(agent, optimizer, args, b_obs, b_actions, b_logprobs, b_advantages, b_returns, permutation):
    """The clipped PPO update over one flattened batch: ``update_epochs`` epochs of minibatches of the
    indices ``permutation()`` returns each epoch. Returns the last minibatch's losses and the mean clip
    fraction as tensors (no host read inside the loop)."""
    clipfracs = []
    for _epoch in range(args.update_epochs):
        b_inds = permutation()
        for lo in range(0, args.batch_size, args.minibatch_size):
            mb = b_inds[lo : lo + args.minibatch_size]
            _, newlogprob, entropy, newvalue = agent.get_action_and_value(b_obs[mb], b_actions[mb])
            logratio = newlogprob - b_logprobs[mb]
            ratio = logratio.exp()
            with torch.no_grad():
                approx_kl = ((ratio - 1) - logratio).mean()
                clipfracs.append(((ratio - 1.0).abs() > args.clip_coef).float().mean())
            mb_adv = b_advantages[mb]
            mb_adv = (mb_adv - mb_adv.mean()) / (mb_adv.std() + 1e-8)
            pg_loss = torch.max(
                -mb_adv * ratio, -mb_adv * torch.clamp(ratio, 1 - args.clip_coef, 1 + args.clip_coef)
            ).mean()
            v_loss = ((newvalue.flatten() - b_returns[mb]) ** 2).mean()  # SB3's MSE (CleanRL halves it)
            entropy_loss = entropy.mean()
            loss = pg_loss - args.ent_coef * entropy_loss + v_loss * args.vf_coef

            optimizer.zero_grad()
            loss.backward()
            nn.utils.clip_grad_norm_(agent.parameters(), args.max_grad_norm)
            optimizer.step()
        if args.target_kl is not None and approx_kl > args.target_kl:
            break
    return {"pg_loss": pg_loss, "v_loss": v_loss, "entropy": entropy_loss, "approx_kl": approx_kl,
            "clipfrac": torch.stack(clipfracs).mean()}  # fmt: skip


def anneal_lr(optimizer, args, iteration: int) -> None:
    """Linear learning-rate decay from ``args.learning_rate`` at iteration 1 toward 0 (CleanRL's)."""
    if args.anneal_lr:
        frac = 1.0 - (iteration - 1.0) / args.num_iterations
        optimizer.param_groups[0]["lr"] = frac * args.learning_rate


def shuffler(rng: np.random.Generator, inds: np.ndarray):
    """A ``permutation()`` for :func:`ppo_update` that shuffles ``inds`` in place with ``rng`` each call."""

    def permutation() -> np.ndarray:
        rng.shuffle(inds)
        return inds

    return permutation


def discrete_agent(space: gym.Space, obs_dim: int) -> Agent:
    """The agent of a Discrete action space (baselines/ppo_continuous.py builds a Box's)."""
    if not isinstance(space, gym.spaces.Discrete):
        raise ValueError(f"this PPO takes Discrete actions, not {space} (a Box: baselines/ppo_continuous.py)")
    return Agent(obs_dim, int(space.n))


def train(args: argparse.Namespace, build=discrete_agent) -> Agent:
    envs = gym.make_vec(args.env_id, num_envs=args.num_envs, autoreset_mode="same_step", **env_options(args))
    assert isinstance(envs, PlanetNavVectorEnv), f"not the native vector env: {type(envs).__name__}"
    obs_dim = int(np.prod(envs.single_observation_space.shape))
    agent = build(envs.single_action_space, obs_dim)
    optimizer = torch.optim.Adam(agent.parameters(), lr=args.learning_rate, eps=1e-5)
    rng = np.random.default_rng(args.seed)  # minibatch shuffling

    T, N = args.num_steps, args.num_envs  # the rollout's storage
    obs = torch.zeros((T, N, obs_dim))
    actions = torch.zeros((T, N, *agent.action_shape), dtype=agent.action_dtype)
    logprobs, rewards, dones, values = (torch.zeros((T, N)) for _ in range(4))

    global_step, start = 0, time.time()
    next_obs = torch.as_tensor(envs.reset(seed=args.seed)[0])
    next_done = torch.zeros(N)
    ep_return, finished = np.zeros(N), []
    for iteration in range(1, args.num_iterations + 1):
        anneal_lr(optimizer, args, iteration)

        for step in range(T):
            global_step += N
            obs[step], dones[step] = next_obs, next_done
            with torch.no_grad():
                action, logprob, _, value = agent.get_action_and_value(next_obs)
            values[step], actions[step], logprobs[step] = value.flatten(), action, logprob

            o, reward, terminated, truncated, info = envs.step(action.numpy())
            ep_return += reward
            reward = reward.copy()
            # same_step autoreset: `o` holds the new episodes' first observations for the rows that ended,
            # their last in info["final_obs"]. A time limit is not a terminal state: bootstrap from it.
            cut = np.flatnonzero(truncated & ~terminated)
            if cut.size:
                last = torch.as_tensor(np.stack(info["final_obs"][cut]))
                with torch.no_grad():
                    reward[cut] += args.gamma * agent.get_value(last).flatten().numpy()
            rewards[step] = torch.as_tensor(reward, dtype=torch.float32)
            done = terminated | truncated
            finished += ep_return[done].tolist()
            ep_return[done] = 0.0
            next_obs, next_done = torch.as_tensor(o), torch.as_tensor(done, dtype=torch.float32)

        with torch.no_grad():
            advantages, returns = gae(rewards, values, dones, agent.get_value(next_obs).reshape(1, -1),
                                      next_done, args.gamma, args.gae_lambda)  # fmt: skip
        b_obs = obs.reshape((-1, obs_dim))
        b_values = values.reshape(-1)
        b_returns = returns.reshape(-1)
        permutation = shuffler(rng, np.arange(args.batch_size))
        st = ppo_update(agent, optimizer, args, b_obs, actions.flatten(0, 1), logprobs.reshape(-1),
                        advantages.reshape(-1), b_returns, permutation)  # fmt: skip
        pg_loss, v_loss, entropy_loss, approx_kl = st["pg_loss"], st["v_loss"], st["entropy"], st["approx_kl"]
        clipfracs = [st["clipfrac"].item()]

        y_pred, y_true = b_values.numpy(), b_returns.numpy()
        var_y = np.var(y_true)
        explained_var = np.nan if var_y == 0 else 1 - np.var(y_true - y_pred) / var_y
        ret = f"{np.mean(finished[-N:]):9.2f}" if finished else "      n/a"
        print(f"iter {iteration:4d}/{args.num_iterations}  decisions {global_step:9d}  episode return {ret}  "
              f"pg {pg_loss.item():+.4f}  v {v_loss.item():.4f}  entropy {entropy_loss.item():.3f}  "
              f"kl {approx_kl.item():.4f}  clipfrac {np.mean(clipfracs):.3f}  expl.var {explained_var:.3f}  "
              f"SPS {int(global_step / (time.time() - start))}", flush=True)  # fmt: skip
    envs.close()
    return agent


def evaluate(act, cfg: EnvConfig, seeds: list[int]) -> np.ndarray:
    """The suite's objective of a policy ``act`` (observations (N, D) -> actions (N,)): one native
    vector-env row per seed, each row's episode's mean true position error [km] over its physics steps.
    Every physics step of a held decision is recorded (``step_rows``' ``on_step``), as the suite's
    batched evaluation (planetnav_train/evaluate.py) records it."""
    venv = PlanetNavVectorEnv(len(seeds), cfg)  # stepped by step_rows: no autoreset
    venv.reset(seed=list(seeds))
    errs: list[np.ndarray] = []  # per physics step, (N,) with NaN for the rows it did not step

    def record(stepped: np.ndarray) -> None:
        e = np.full(len(seeds), np.nan)
        e[stepped] = venv.info_arrays()["pos_err_km"][stepped]
        errs.append(e)

    running = np.ones(len(seeds), dtype=bool)
    while running.any():
        _, terminated, truncated = venv.step_rows(act(venv.observations()), running, on_step=record)
        running &= ~(terminated | truncated)
    venv.close()
    return np.array([np.mean(row[~np.isnan(row)]) for row in np.array(errs).T])


def sampled_policy(agent: Agent, seeds: list[int], stream: int = 0):
    """The agent's sampled actions, row ``r`` drawing from its own generator seeded ``stream + seeds[r]``
    as a one-row ``Categorical.sample`` draws. ``stream`` 0 gives the suite's draws (its evaluation seeds
    each episode's sampling with the episode's seed), so a policy scores here what it scores in the suite;
    another ``stream`` gives other draws of the same policy."""
    gens = [torch.Generator().manual_seed(stream + int(s)) for s in seeds]

    def act(o: np.ndarray) -> np.ndarray:
        with torch.no_grad():
            probs = Categorical(logits=agent.actor(torch.as_tensor(o))).probs
        return np.array([torch.multinomial(probs[r : r + 1], 1, True, generator=g).item()
                         for r, g in enumerate(gens)])  # fmt: skip

    return act


def references(args: argparse.Namespace, cfg: EnvConfig, seed: int, n: int):
    """(blind spec, its per-seed J, best reference spec, its per-seed J, where they come from) on the
    seeds ``seed .. seed + n - 1``, or None when the blind search has no record of the task."""
    task = args.env_id.split("/", 1)[-1]
    rec = json.loads(Path(args.blind_json).read_text())["tasks"].get(task)
    if rec is None:
        return None
    blind, best = rec["blind_winner"], rec["best_reference"]
    stored = rec["agents"][blind]["per_seed"], rec["agents"][best]["per_seed"]
    if not args.episode_steps and rec["eval_seed"] == seed and n <= len(stored[0]):
        where = f"stored per-seed values in {Path(args.blind_json).name}: its first {n} of {len(stored[0])}"
        return blind, np.asarray(stored[0][:n]), best, np.asarray(stored[1][:n]), where
    why = "--episode-steps changes the task" if args.episode_steps else f"{len(stored[0])} seeds stored"
    where = f"evaluated here by the suite's evaluator ({why})"
    return blind, evaluate_objective(blind, cfg, n, seed), best, evaluate_objective(best, cfg, n, seed), where


def main(argv: list[str] | None = None, parser=None, build=discrete_agent, policy=sampled_policy) -> dict:
    """Train, save, evaluate; a Box's PPO (baselines/ppo_continuous.py) brings its parser, agent, policy."""
    args = parse_args(argv, parser)
    torch.set_num_threads(args.torch_threads)
    torch.manual_seed(args.seed)
    t0 = time.time()
    agent = train(args, build)
    print(f"trained {args.num_iterations} updates ({args.num_iterations * args.batch_size} decisions) "
          f"in {time.time() - t0:.0f} s")  # fmt: skip
    if args.save_model:
        torch.save(agent.state_dict(), args.save_model)
        print(f"saved {args.save_model}")
    return evaluate_and_score(agent, args, {"agent": agent}, policy)


def eval_config(args: argparse.Namespace) -> EnvConfig:
    """The evaluation's environment: the run's id and options, with per-step noise streams (the suite's)."""
    return EnvConfig.from_dict({**id_options(args.env_id), **env_options(args)}, noise_streams="per_step")


def evaluate_and_score(agent: Agent, args: argparse.Namespace, out: dict, policy=sampled_policy) -> dict:
    """The suite's evaluation of ``agent`` (on the CPU) and its blind-zero score, added to ``out``."""
    if args.eval_episodes <= 0:
        return out
    seed, n = 50_000, args.eval_episodes
    cfg = eval_config(args)
    seeds = list(range(seed, seed + n))
    out["J"] = j = evaluate(policy(agent, seeds), cfg, seeds)
    print(f"evaluation: {n} episodes on seeds {seed}..{seed + n - 1}, per-step noise streams, sampled "
          f"actions (the suite's draws), {cfg.episode_steps} physics steps each")  # fmt: skip
    print(f"  PPO (this run)       {j.mean():9.2f} km")
    ref = references(args, cfg, seed, n) if n >= 2 else None
    if ref is None:
        print("no blind-zero score: the task has no blind-search record, or fewer than 2 episodes")
        return out
    blind, jb, best, jr, where = ref
    print(f"  best blind           {jb.mean():9.2f} km  {blind}")
    print(f"  best reference       {jr.mean():9.2f} km  {best}")
    print(f"  (reference values: {where})")
    if jr.mean() >= jb.mean():
        print("  note: the best reference is not better than the blind policy here: the scale is inverted")
    s = paired_ratio_ci(jb, jr, j)
    out.update(score=s["score"], score_lo=s["score_lo"], score_hi=s["score_hi"], J_blind=jb, J_best=jr)
    print(f"blind-zero score: {s['score']:+.3f} [{s['score_lo']:+.3f}, {s['score_hi']:+.3f}] (95 % paired "
          f"bootstrap over {n} seeds; 0 = best blind, 1 = best reference)")  # fmt: skip
    return out


if __name__ == "__main__":
    main()
