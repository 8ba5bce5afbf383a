"""Single-file PPO that stays on the device: rollout, GAE and minibatches as torch tensors on the GPU.

    python baselines/ppo_device.py --device cuda --env-id planetnav/Cruise-Target-v2 --num-envs 16384
    python baselines/ppo_device.py --device cpu  ...   # the same loop on the CPU's native vector env

In the style of PureJaxRL: the environment (:class:`~planetnav_env.device.vector_env.DeviceVectorEnv` on
CUDA: state, autoreset and observations on the GPU), the policy and the rollout buffers live on one device,
and nothing is copied to the host per step (one host read per update, for the log line). The agent, GAE,
the clipped update and the evaluation are baselines/ppo_single_file.py's (imported: one formula in one
place); this file adds the device loop and its environments:

* ``--device cuda``: the device env, ``same_step`` autoreset, resets from its episode bank
  (``--bank-size``, default 2 N) refilled on a host thread while the rows step (``--refill``, drawn by
  ``--bank-workers`` processes); the last line says how many episodes were substitutes (a row got there
  before the refill: the env's ``bank_stats``);
* ``--device cpu``: the native vector env (``gym.make_vec``) behind a small adapter that hands out torch
  CPU tensors (what CI runs); ``--env host`` the device env's host mode instead (its CPU build);
* ``--stagger-starts``: each row's first episode is cut at a random decision, so the rows do not all end
  their episodes on the same decision (:class:`StaggeredStarts`).

The evaluation is the suite's (sampled actions on seeds 50,000.., on the CPU's native vector env), so its
scores compare with the single-file PPO's and the suite's. A timestep is one decision of one env. Each
update's line gives the cumulative rate (SPS, from before the reset) and the update's own rate (the steady
one: the first update's includes the kernels' compilation).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parent))
import ppo_single_file as single

import planetnav_env  # noqa: F401  (registers the planetnav/* ids)
from planetnav_env.device.refill import REFILL_MODES
from planetnav_env.device.vector_env import DeviceVectorEnv, cuda_unavailable_reason
from planetnav_env.envs.vector_env import PlanetNavVectorEnv


def parse_args(argv: list[str] | None = None):
    p = single.make_parser("Single-file PPO on the device (planetnav's device vector env).")
    p.set_defaults(num_envs=4096, num_steps=32)
    p.add_argument("--device", default="cuda", help="cuda, cuda:K or cpu")
    p.add_argument("--env", choices=("native", "host"), default="native",
                   help="--device cpu: the native vector env, or the device env's host mode")  # fmt: skip
    p.add_argument("--bank-size", type=int, default=None, help="device env: bank slots (default 2 N)")
    p.add_argument("--refill", choices=REFILL_MODES, default="thread", help="device env: the bank's refill")
    p.add_argument("--bank-workers", type=int, default=None,
                   help="device env: processes drawing the bank (default: the env's)")  # fmt: skip
    p.add_argument("--stagger-starts", action="store_true",
                   help="cut each row's first episode at a random decision (StaggeredStarts)")  # fmt: skip
    return single.finish_args(p.parse_args(argv))


class NativeTorchEnv:
    """The native vector env (``same_step`` autoreset) with the device env's torch interface, on the CPU:
    ``reset(seed)`` -> (obs, info), ``step(actions)`` -> (obs, reward, terminated, truncated, info) with
    ``info["final_obs"]`` an (N, D) tensor (the finished rows' last observations)."""

    def __init__(self, args) -> None:
        self.env = gym.make_vec(args.env_id, num_envs=args.num_envs, autoreset_mode="same_step",
                                **single.env_options(args))  # fmt: skip
        assert isinstance(self.env, PlanetNavVectorEnv), type(self.env).__name__
        self.single_action_space = self.env.single_action_space
        self.single_observation_space = self.env.single_observation_space
        self.config = self.env.config
        self.final_obs = torch.zeros((args.num_envs, *self.single_observation_space.shape))

    def reset(self, seed: int | None = None, options: dict | None = None):
        o, info = self.env.reset(seed=seed, options=options)  # a CPU tensor mask reads as an array
        return torch.as_tensor(o), info

    def step(self, actions: torch.Tensor):
        o, reward, terminated, truncated, info = self.env.step(actions.numpy())
        done = terminated | truncated
        if done.any():
            self.final_obs[torch.as_tensor(done)] = torch.as_tensor(np.stack(info["final_obs"][done]))
        info = {"final_obs": self.final_obs}
        return (torch.as_tensor(o), torch.as_tensor(reward), torch.as_tensor(terminated),
                torch.as_tensor(truncated), info)  # fmt: skip

    def close(self) -> None:
        self.env.close()


class StaggeredStarts:
    """Row ``n``'s first episode is cut (a truncation, bootstrapped) after ``cut_at[n]`` decisions, drawn
    uniformly from 1..L, L the task's decisions an episode (L: not cut). All rows start together and an
    episode lasts L decisions unless it terminates, so without the cut every row ends on the same decision,
    and an update's T decisions see one phase of the episode only (the value loss jumps each time the
    phase wraps). After the cuts the phases are spread over 0..L-1 and stay so. Isaac Lab starts its rows
    at random episode lengths for the same reason. The cuts are drawn on the host, so knowing which rows
    to cut reads nothing back from the device."""

    def __init__(self, num_envs: int, episode_decisions: int, seed: int) -> None:
        g = torch.Generator().manual_seed(seed)
        self.episode_decisions = episode_decisions
        self.cut_at = torch.randint(1, episode_decisions + 1, (num_envs,), generator=g)
        self.decision = 0

    def next_cut(self) -> torch.Tensor | None:
        """Called once after each decision: the rows (bool (N,), on the host) to cut now, or None."""
        self.decision += 1
        if self.decision >= self.episode_decisions:
            return None
        cut = self.cut_at == self.decision
        return cut if bool(cut.any()) else None


def env_step(envs, action: torch.Tensor, stagger: StaggeredStarts | None):
    """One decision of every row (``same_step`` autoreset), and the cuts of ``stagger``. Returns ``(obs,
    reward, ended, done, cut, last)``: ``obs`` after the resets, ``reward`` float32, ``ended`` the rows
    whose episode ended by itself, ``done`` those and the rows cut now, ``cut`` the rows whose value is
    bootstrapped from their ``last`` observation (a time limit or a stagger cut is not a terminal state),
    all on the env's device. ``last`` holds the final observation of every row that ended or was cut (the
    other rows' entries are stale and masked by ``cut``), so nothing reads a mask back to the host."""
    o, reward, terminated, truncated, info = envs.step(action)
    reward = reward.to(torch.float32)
    ended = terminated | truncated
    cut = truncated & ~terminated
    last = info["final_obs"]
    staggered = stagger.next_cut() if stagger is not None else None
    if staggered is None:
        return o, reward, ended, ended, cut, last
    staggered = staggered.to(ended.device) & ~ended  # a row that has just ended is not cut
    last = torch.where(staggered[:, None], o, last)  # before the reset overwrites o
    o = envs.reset(options={"reset_mask": staggered})[0]
    return o, reward, ended, ended | staggered, cut | staggered, last


def make_env(args):
    """The environment of ``args.device`` (module docstring)."""
    if args.device.startswith("cuda"):
        why = cuda_unavailable_reason()
        if why is not None:
            raise SystemExit(f"--device {args.device}: {why}. Install with pip install -e \".[gpu]\" on a "
                             "machine with a GPU, or run with --device cpu")  # fmt: skip
    if args.device == "cpu" and args.env == "native":
        return NativeTorchEnv(args)
    return DeviceVectorEnv(args.env_id, args.num_envs, device=args.device, bank_size=args.bank_size,
                           autoreset_mode="same_step", refill=args.refill, bank_workers=args.bank_workers,
                           **single.env_options(args))  # fmt: skip


def train(args) -> tuple[single.Agent, list[dict]]:
    dev = torch.device(args.device)
    envs = make_env(args)
    obs_dim = int(np.prod(envs.single_observation_space.shape))
    agent = single.discrete_agent(envs.single_action_space, obs_dim).to(dev)  # a Box refused by name
    optimizer = torch.optim.Adam(agent.parameters(), lr=args.learning_rate, eps=1e-5)
    gen = torch.Generator(device=dev).manual_seed(args.seed)  # minibatch shuffling

    # Rollout storage, on the device
    T, N = args.num_steps, args.num_envs
    obs = torch.zeros((T, N, obs_dim), device=dev)
    actions = torch.zeros((T, N), dtype=torch.long, device=dev)
    logprobs, rewards, dones, values = (torch.zeros((T, N), device=dev) for _ in range(4))
    ep_return = torch.zeros(N, device=dev)
    finished_sum, finished_n = torch.zeros((), device=dev), torch.zeros((), device=dev)

    stagger = StaggeredStarts(N, envs.config.episode_decisions, args.seed) if args.stagger_starts else None
    history: list[dict] = []
    global_step, start = 0, time.time()
    next_obs = envs.reset(seed=args.seed)[0]
    next_done = torch.zeros(N, device=dev)
    update_start = time.time()
    for iteration in range(1, args.num_iterations + 1):
        single.anneal_lr(optimizer, args, iteration)
        for step in range(T):
            global_step += N
            obs[step], dones[step] = next_obs, next_done
            with torch.no_grad():
                action, logprob, _, value = agent.get_action_and_value(next_obs)
            values[step], actions[step], logprobs[step] = value.flatten(), action, logprob
            o, reward, ended, done, cut, last = env_step(envs, action, stagger)
            ep_return += reward
            with torch.no_grad():
                boot = agent.get_value(last).flatten()
            rewards[step] = reward + args.gamma * torch.where(cut, boot, 0.0)
            finished_sum += torch.where(ended, ep_return, 0.0).sum()  # the return of whole episodes
            finished_n += ended.sum()
            ep_return = torch.where(done, 0.0, ep_return)
            next_obs, next_done = o, done.to(torch.float32)

        with torch.no_grad():
            advantages, returns = single.gae(rewards, values, dones, agent.get_value(next_obs).reshape(1, -1),
                                             next_done, args.gamma, args.gae_lambda)  # fmt: skip
        st = single.ppo_update(
            agent, optimizer, args, obs.reshape((-1, obs_dim)), actions.reshape(-1), logprobs.reshape(-1),
            advantages.reshape(-1), returns.reshape(-1),
            lambda: torch.randperm(args.batch_size, device=dev, generator=gen),
        )  # fmt: skip
        var_y = returns.var()
        st["explained_var"] = 1 - (returns - values).var() / var_y
        st["episode_return"] = finished_sum / finished_n.clamp(min=1)
        row = {k: float(v.detach()) for k, v in st.items()}  # the one host read of the update
        # The read waits for the device, so the time between two reads is the update's: its rate is the
        # steady one (the first update's includes the kernels' compilation, the cumulative rate the reset).
        now = time.time()
        row.update(iteration=iteration, decisions=global_step, sps=global_step / (now - start),
                   update_sps=T * N / (now - update_start))  # fmt: skip
        update_start = now
        history.append(row)
        finished_sum.zero_(), finished_n.zero_()
        print(f"iter {iteration:4d}/{args.num_iterations}  decisions {global_step:9d}  episode return "
              f"{row['episode_return']:9.2f}  pg {row['pg_loss']:+.4f}  v {row['v_loss']:.4f}  entropy "
              f"{row['entropy']:.3f}  kl {row['approx_kl']:.4f}  clipfrac {row['clipfrac']:.3f}  "
              f"SPS {int(row['sps'])} (this update {int(row['update_sps'])})", flush=True)  # fmt: skip
    if isinstance(envs, DeviceVectorEnv):
        bank = envs.bank_stats()
        print(f"bank: {bank['episodes']} episodes started, {bank['substituted']} substitutes, "
              f"{bank['drawn']} drawn on the host ({args.refill} refill)")  # fmt: skip
    envs.close()
    return agent, history


def main(argv: list[str] | None = None) -> dict:
    args = parse_args(argv)
    torch.set_num_threads(args.torch_threads)
    torch.manual_seed(args.seed)
    t0 = time.time()
    agent, history = train(args)
    seconds = time.time() - t0
    print(f"trained {args.num_iterations} updates ({args.num_iterations * args.batch_size} decisions) "
          f"in {seconds:.0f} s on {args.device}")  # fmt: skip
    if args.save_model:
        torch.save(agent.state_dict(), args.save_model)
        print(f"saved {args.save_model}")
    out = {"agent": agent.cpu(), "history": history, "train_seconds": seconds}
    return single.evaluate_and_score(agent, args, out)


if __name__ == "__main__":
    main()
