"""baselines/ppo_single_file.py: the single-file PPO runs end to end on the native vector env (two tiny
updates, three short evaluation episodes), changes its policy, prints a finite blind-zero score, stays
within 400 lines, its evaluation reproduces the suite's stored per-seed values, its GAE and update equal
Stable-Baselines3's PPO on SB3's own rollout, and its whole training loop ends with SB3's weights when it
is given SB3's random draws."""

from __future__ import annotations

import ast
import importlib.util
import json
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "baselines" / "ppo_single_file.py"
LR = 3e-4
TINY = ["--num-envs", "8", "--num-steps", "16", "--total-timesteps", "256", "--eval-episodes", "3",
        "--episode-steps", "40", "--seed", "0", "--learning-rate", str(LR),
        "--torch-threads", "1"]  # fmt: skip
SCORE = re.compile(r"^blind-zero score: (\S+) \[(\S+), (\S+)\]", re.M)


def _module():
    spec = importlib.util.spec_from_file_location("ppo_single_file", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> tuple[subprocess.CompletedProcess, Path]:
    model = tmp_path_factory.mktemp("ppo") / "agent.pt"
    proc = subprocess.run(
        [sys.executable, str(SCRIPT), *TINY, "--save-model", str(model)],
        cwd=ROOT, capture_output=True, text=True, timeout=900, check=False,
    )  # fmt: skip
    return proc, model


def test_file_is_at_most_400_lines_and_imports_no_sb3() -> None:
    text = SCRIPT.read_text()
    assert len(text.splitlines()) <= 400
    imported = set()
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.Import):
            imported |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            imported.add(node.module or "")
    assert "torch" in imported and "planetnav_env.envs.vector_env" in imported, imported
    assert not {m for m in imported if m.split(".")[0] in ("stable_baselines3", "sb3_contrib")}, imported


def test_runs_two_updates_and_prints_a_finite_blind_zero_score(run) -> None:
    proc, _ = run
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = proc.stdout
    assert re.findall(r"^iter +(\d+)/2 ", out, re.M) == ["1", "2"], out
    head = "evaluation: 3 episodes on seeds 50000..50002, per-step noise streams, sampled actions"
    assert f"{head} (the suite's draws), 40" in out
    m = SCORE.search(out)
    assert m, out
    score, lo, hi = (float(x) for x in m.groups())
    assert all(math.isfinite(x) for x in (score, lo, hi)) and lo <= hi, m.group(0)
    # The three objective values printed are the ones the score is made of: recompute it from them.
    j, jb, jr = (float(re.search(rf"^  {k} +(\S+) km", out, re.M).group(1))
                 for k in ("PPO \\(this run\\)", "best blind", "best reference"))  # fmt: skip
    assert score == pytest.approx((jb - j) / (jb - jr), abs=2e-3 * max(1.0, abs(score)))


def test_updates_change_the_policy_from_its_seeded_initialization(run) -> None:
    proc, model = run
    assert proc.returncode == 0, proc.stderr[-3000:]
    trained = torch.load(model)
    torch.manual_seed(0)  # the script seeds torch, then builds the agent before any other draw
    obs_dim, n_actions = trained["actor.0.weight"].shape[1], trained["actor.4.weight"].shape[0]
    initial = _module().Agent(obs_dim, n_actions).state_dict()
    assert trained.keys() == initial.keys()
    moved = {k: float((trained[k] - initial[k]).abs().max()) for k in initial}
    # Every layer moved (actor and critic): Adam's first step alone moves a weight with a gradient by ~LR,
    # far above the last-bit differences of the orthogonal init under other thread counts (~1e-7); and by
    # at most what 2 updates x 5 epochs x 4 minibatches of Adam can move it from this same initialization
    # (another seed's initialization differs by ~1).
    assert all(v > LR / 10 for v in moved.values()), moved
    assert max(moved.values()) < 40 * LR * 3.5, moved
    loaded = _module().load_agent(model).state_dict()  # what the probes score
    assert loaded.keys() == trained.keys() and all(torch.equal(loaded[k], trained[k]) for k in trained)


def test_evaluation_reproduces_the_stored_blind_winner() -> None:
    """The script's objective equals the blind search's stored per-seed values bit for bit: the winner
    schedule (Venus, Mars, Earth, 20 physics steps each) played as relative actions on its first seeds."""
    from planetnav_env.config import EnvConfig
    from planetnav_env.envs.registration import id_options

    rec = json.loads((ROOT / "docs" / "tasks_v2_blind.json").read_text())["tasks"]["Cruise-Target-v2"]
    assert rec["blind_winner"] == "schedule:targets=0-1-2,steps=20" and rec["eval_seed"] == 50_000
    decision = iter(range(10_000))

    def schedule(obs: np.ndarray) -> np.ndarray:  # relative: 0 stays, 1 moves to the next planet
        d = next(decision)
        return np.full(len(obs), int(d > 0 and d % 2 == 0))

    cfg = EnvConfig.from_dict(id_options("planetnav/Cruise-Target-v2"), noise_streams="per_step")
    j = _module().evaluate(schedule, cfg, [50_000, 50_001, 50_002])
    assert j.tolist() == rec["agents"][rec["blind_winner"]]["per_seed"][:3]


def test_sampled_evaluation_draws_the_suites_draws(tmp_path: Path) -> None:
    """A policy scores in the script what it scores in the suite: the script's sampled evaluation of a
    Stable-Baselines3 policy gives the suite's evaluator's per-episode objective (``PATH@sampled``) on the
    same seeds bit for bit, draw for draw; another ``stream`` gives other draws, hence another J."""
    import yaml

    from planetnav_env.config import EnvConfig
    from planetnav_env.envs.registration import id_options
    from planetnav_train.evaluate import evaluate_agent
    from planetnav_train.suite import OBJECTIVES, get_task

    mod = _module()
    cfg = EnvConfig.from_dict(id_options("planetnav/Cruise-Target-v2"), episode_steps=200,
                              noise_streams="per_step")  # fmt: skip
    model = _sb3_ppo(16, 2, seed=0)  # a policy to score: it is never trained
    with torch.no_grad():  # logits that depend on the observation (the initial head's are nearly uniform)
        model.policy.action_net.weight.mul_(300.0)
    run = tmp_path / "run"
    run.mkdir()
    model.save(run / "model.zip")
    (run / "config.yaml").write_text(yaml.safe_dump({"algo": "ppo"}))
    seeds = [50_000, 50_001, 50_002, 50_003]
    m = evaluate_agent(f"{run}@sampled", cfg, len(seeds), seeds[0], progress=False).metrics
    suite_j = OBJECTIVES[get_task("Cruise-Target-v2").objective].values(m)

    agent = mod.agent_from_sb3(model.policy.state_dict())
    j = mod.evaluate(mod.sampled_policy(agent, seeds), cfg, seeds)
    assert j.tolist() == list(suite_j)
    other = mod.evaluate(mod.sampled_policy(agent, seeds, stream=1), cfg, seeds)
    assert (other != j).all(), (other, j)


def _sb3_ppo(T: int, N: int, seed: int, **hyperparams):
    """Stable-Baselines3's PPO on the suite's training env of Cruise-Target-v2 (N rows, 4-decision
    episodes): T decisions a rollout, minibatches of 32, 2 epochs, entropy 0.01."""
    from stable_baselines3 import PPO

    from planetnav_train.config import parse_config
    from planetnav_train.envs import make_training_env

    tc = parse_config({"algo": "ppo", "env_id": "planetnav/Cruise-Target-v2", "n_envs": N, "seed": seed,
                       "env": {"episode_steps": 40}})  # fmt: skip
    return PPO("MlpPolicy", make_training_env(tc, None), n_steps=T, batch_size=32, n_epochs=2, ent_coef=0.01,
               learning_rate=LR, seed=seed, device="cpu", **hyperparams)  # fmt: skip


def test_gae_and_update_equal_stable_baselines3s_ppo(monkeypatch: pytest.MonkeyPatch) -> None:
    """Stable-Baselines3's PPO is the oracle: on SB3's own rollout (short episodes, so it holds episode
    ends and bootstrapped time limits), the single file's GAE gives SB3's advantages, and its clipped
    update, from SB3's initial weights with SB3's minibatch order, gives SB3's weights after the update.
    The suite's PPO and the device PPO (which imports these functions) are then one algorithm."""
    from stable_baselines3.common.buffers import RolloutBuffer

    mod = _module()
    torch.set_num_threads(1)
    T, N, gamma, lam = 16, 8, 0.95, 0.95
    model = _sb3_ppo(T, N, seed=0, gamma=gamma, gae_lambda=lam)
    seen: dict = {}
    compute = RolloutBuffer.compute_returns_and_advantage

    def record_gae(self, last_values, dones):
        seen["last"] = (last_values.clone().flatten(), torch.as_tensor(dones, dtype=torch.float32))
        return compute(self, last_values, dones)

    sb3_train = model.train

    def record_train():
        seen["before"] = {k: v.clone() for k, v in model.policy.state_dict().items()}
        seen["buffer"] = {k: torch.as_tensor(getattr(model.rollout_buffer, k).copy()) for k in
                          ("observations", "actions", "rewards", "episode_starts", "values", "log_probs",
                           "advantages", "returns")}  # fmt: skip
        np.random.seed(7)  # noqa: NPY002 - SB3's minibatches come from numpy's global generator
        sb3_train()

    monkeypatch.setattr(RolloutBuffer, "compute_returns_and_advantage", record_gae)
    monkeypatch.setattr(model, "train", record_train)
    state = np.random.get_state()  # noqa: NPY002
    try:
        model.learn(T * N)  # one rollout, one update
        b = seen["buffer"]
        assert b["episode_starts"].sum() >= N, "the rollout should hold episode ends"
        adv, ret = mod.gae(b["rewards"], b["values"], b["episode_starts"], seen["last"][0].reshape(1, -1),
                           seen["last"][1], gamma, lam)  # fmt: skip
        torch.testing.assert_close(adv, b["advantages"], rtol=1e-6, atol=1e-6)
        torch.testing.assert_close(ret, b["returns"], rtol=1e-6, atol=1e-6)

        agent = mod.agent_from_sb3(seen["before"])
        args = mod.parse_args(["--num-envs", str(N), "--num-steps", str(T), "--num-minibatches", "4",
                               "--update-epochs", "2", "--learning-rate", str(LR)])  # fmt: skip
        optimizer = torch.optim.Adam(agent.parameters(), lr=LR, eps=1e-5)

        def flat(x: torch.Tensor) -> torch.Tensor:  # SB3's order: row after row (N, T), not (T, N)
            return x.swapaxes(0, 1).reshape(T * N, *x.shape[2:])

        np.random.seed(7)  # noqa: NPY002
        mod.ppo_update(agent, optimizer, args, flat(b["observations"]), flat(b["actions"]).long().flatten(),
                       flat(b["log_probs"]), flat(b["advantages"]), flat(b["returns"]),
                       lambda: torch.as_tensor(np.random.permutation(T * N)))  # noqa: NPY002  # fmt: skip
    finally:
        np.random.set_state(state)  # noqa: NPY002
    after = model.policy.state_dict()
    for ours, theirs in mod.SB3_NAMES.items():
        moved = (after[theirs] - seen["before"][theirs]).abs().max().item()
        assert moved > 1e-4, (theirs, moved)  # every tensor moved, by 100x the tolerance or more
        torch.testing.assert_close(agent.state_dict()[ours], after[theirs], rtol=0, atol=1e-6, msg=ours)


def test_training_loop_equals_stable_baselines3s_ppo_on_its_draws(
    monkeypatch: pytest.MonkeyPatch, sb3_learn, sb3_order
) -> None:
    """The whole loop against Stable-Baselines3's PPO: rollout, same-step autoreset, bootstrapped time
    limits, GAE and update, three updates of 8 rows x 16 decisions with 4-decision episodes. Given SB3's
    initial weights, torch's global generator where SB3's first action draw finds it, and SB3's
    minibatch order, ``train()`` ends with SB3's weights: the single file trains SB3's policy, and only
    the random streams tell the two apart."""
    mod = _module()
    torch.set_num_threads(1)
    T, N, updates, seed = 16, 8, 3, 3
    before, after, at_first_draw = sb3_learn(_sb3_ppo(T, N, seed=seed, gamma=0.95), T * N * updates)

    class SB3Initialized(mod.Agent):
        def __init__(self, *a) -> None:
            super().__init__(*a)
            self.load_state_dict({ours: before[theirs] for ours, theirs in mod.SB3_NAMES.items()})
            torch.set_rng_state(at_first_draw["torch"])  # the initialization above drew from it

    monkeypatch.setattr(mod, "Agent", SB3Initialized)
    monkeypatch.setattr(mod, "shuffler", sb3_order(T, N))
    np.random.set_state(at_first_draw["numpy"])  # noqa: NPY002
    args = mod.parse_args(["--num-envs", str(N), "--num-steps", str(T), "--num-minibatches", "4",
                           "--update-epochs", "2", "--learning-rate", str(LR), "--seed", str(seed),
                           "--episode-steps", "40", "--total-timesteps", str(T * N * updates),
                           "--eval-episodes", "0"])  # fmt: skip
    agent = mod.train(args)
    for ours, theirs in mod.SB3_NAMES.items():
        moved = (after[theirs] - before[theirs]).abs().max().item()
        assert moved > 1e-4, (theirs, moved)  # every tensor moved, by 100x the tolerance or more
        torch.testing.assert_close(agent.state_dict()[ours], after[theirs], rtol=0, atol=1e-6, msg=ours)
