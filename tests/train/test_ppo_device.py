"""baselines/ppo_device.py on the CPU (CI has no GPU): the device loop trains on the native vector env and
on the device env's host mode for a few updates, with finite losses, a policy that moved, and the suite's
evaluation computed, the host mode's agent equal to the native env's weight for weight; it shares the
single-file PPO's formulas instead of copying them; asked for CUDA without one, it says what is
missing."""

from __future__ import annotations

import ast
import importlib.util
import math
from pathlib import Path

import pytest
import torch

from planetnav_env.core import layout as L

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "baselines" / "ppo_device.py"
TINY = ["--device", "cpu", "--num-envs", "8", "--num-steps", "8", "--total-timesteps", "192",
        "--episode-steps", "40", "--seed", "0", "--torch-threads", "1"]  # fmt: skip

pytestmark = pytest.mark.filterwarnings("ignore:.*is out of date.*")


def _module():
    spec = importlib.util.spec_from_file_location("ppo_device", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _initial_agent(mod, out: dict):
    torch.manual_seed(0)  # main seeds torch before building the agent: the same initial weights
    first = next(iter(out["agent"].parameters()))
    return mod.single.Agent(first.shape[1], int(out["agent"].actor[-1].out_features))


@pytest.fixture(scope="module")
def trained() -> dict[str, dict]:
    """The tiny run on each CPU env: the native vector env (evaluated on 2 seeds) and the host mode, its
    bank refilled inline (a refill thread that falls behind hands out substitutes: another run)."""
    mod = _module()
    host = ["--env", "host", "--refill", "inline", "--eval-episodes", "0"]
    stagger = ["--stagger-starts", "--eval-episodes", "0"]
    return {
        "native": mod.main([*TINY, "--env", "native", "--eval-episodes", "2"]),
        "host": mod.main([*TINY, *host]),
        "native-staggered": mod.main([*TINY, "--env", "native", *stagger]),
        "host-staggered": mod.main([*TINY, *host, *stagger]),
    }


@pytest.mark.parametrize("env", ["native", "host"])
def test_trains_a_few_updates_on_the_cpu(env: str, trained: dict[str, dict]) -> None:
    mod = _module()
    out = trained[env]
    hist = out["history"]
    assert len(hist) == 3 and hist[-1]["decisions"] == 192
    for row in hist:
        for k in ("pg_loss", "v_loss", "entropy", "approx_kl", "clipfrac"):
            assert math.isfinite(row[k]), (k, row)
        assert row["update_sps"] > 0 and row["sps"] > 0
    # The cumulative rate is the decisions over the sum of the updates' times (and the reset before them).
    total = sum(64 / r["update_sps"] for r in hist)
    assert hist[-1]["sps"] <= 192 / total * (1 + 1e-9)
    init = _initial_agent(mod, out)
    moved = [not torch.equal(a, b) for a, b in zip(init.parameters(), out["agent"].parameters(), strict=True)]
    assert any(moved)
    if env == "native":
        assert out["J"].shape == (2,) and (out["J"] > 0).all()
        assert math.isfinite(out["score"])


def test_the_host_mode_trains_the_native_envs_policy(trained: dict[str, dict]) -> None:
    """The host mode's rows (bank, autoreset, torch views) equal the native env's, so the same seeds train
    the same agent, weight for weight, and log the same losses."""
    native, host = trained["native"]["agent"], trained["host"]["agent"]
    for (name, a), b in zip(native.named_parameters(), host.parameters(), strict=True):
        assert torch.equal(a, b), name
    keys = ("pg_loss", "v_loss", "entropy", "approx_kl", "episode_return")
    assert [[r[k] for k in keys] for r in trained["native"]["history"]] == [
        [r[k] for k in keys] for r in trained["host"]["history"]
    ]


def test_staggered_starts_train_the_same_agent_on_the_host_mode(trained: dict[str, dict]) -> None:
    """The host mode's partial resets start the native env's episodes, so the staggered runs train the same
    agent weight for weight; the cuts change the training (another agent than without them)."""
    native, host = trained["native-staggered"]["agent"], trained["host-staggered"]["agent"]
    for (name, a), b in zip(native.named_parameters(), host.parameters(), strict=True):
        assert torch.equal(a, b), name
    plain = trained["native"]["agent"]
    assert any(not torch.equal(a, b) for a, b in zip(plain.parameters(), native.parameters(), strict=True))


def test_staggered_starts_cut_each_first_episode_once() -> None:
    mod = _module()
    st = mod.StaggeredStarts(2000, 5, seed=3)
    assert st.cut_at.min() == 1 and st.cut_at.max() == 5
    assert torch.bincount(st.cut_at)[1:].min() > 300  # about 400 rows on each of the 5 phases
    cuts = [st.next_cut() for _ in range(8)]
    assert all(c is None for c in cuts[4:])  # the fifth decision ends the uncut episodes by themselves
    for k, c in enumerate(cuts[:4], start=1):
        assert torch.equal(c, st.cut_at == k)


def test_staggered_steps_spread_the_episodes_and_bootstrap_the_cut_rows() -> None:
    """Stepped with the cuts beside a reference without them (the same seed and actions): a cut row's
    bootstrap observation is the reference's observation on that decision (the row was unchanged up to
    its cut), the cut rows are done and bootstrapped but not ended, and after a whole episode each row
    is as far into its episode as its cut put it."""
    mod = _module()
    args = mod.parse_args([*TINY, "--num-envs", "32", "--episode-steps", "40"])
    envs, ref = mod.NativeTorchEnv(args), mod.NativeTorchEnv(args)
    envs.reset(seed=0), ref.reset(seed=0)
    decisions, per = envs.config.episode_decisions, envs.config.decision_steps
    st = mod.StaggeredStarts(32, decisions, seed=1)
    assert len(set(st.cut_at.tolist())) == decisions  # every phase drawn (32 rows, 4 phases)
    gen = torch.Generator().manual_seed(0)
    for k in range(1, decisions + 1):
        action = torch.randint(0, int(envs.single_action_space.n), (32,), generator=gen)
        o_ref, *_ = ref.step(action)
        o, reward, ended, done, cut, last = mod.env_step(envs, action, st)
        assert reward.dtype == torch.float32
        now = st.cut_at == k if k < decisions else torch.zeros(32, dtype=torch.bool)
        assert torch.equal(done, ended | now) and torch.equal(cut & now, now) and not (ended & now).any()
        assert torch.equal(last[now], o_ref[now])
        assert not torch.equal(o[now], o_ref[now]) or not now.any()
    steps_in = torch.as_tensor(envs.env.core.i[:, L.I_K])
    assert torch.equal(steps_in, (decisions - st.cut_at) % decisions * per)


def test_shares_the_single_file_formulas_and_stays_short() -> None:
    text = SCRIPT.read_text()
    assert len(text.splitlines()) <= 400
    calls = {n.attr for n in ast.walk(ast.parse(text)) if isinstance(n, ast.Attribute)}
    assert {"gae", "ppo_update", "Agent", "evaluate_and_score"} <= calls
    assert "lastgaelam" not in text and "clip_grad_norm_" not in text  # no second copy of GAE / the update


def test_cuda_without_a_device_is_a_clear_error() -> None:
    from planetnav_env.device.vector_env import cuda_unavailable_reason

    if cuda_unavailable_reason() is None:
        pytest.skip("a CUDA device is available here")
    mod = _module()
    with pytest.raises(SystemExit, match=r"--device cuda: .*pip install"):
        mod.main([*TINY[2:], "--device", "cuda"])
