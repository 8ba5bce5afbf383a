"""The device env's host side, without a GPU (planetnav_env/device/).

* the episode bank: its rows, after the compiled part of the reset (``kernels.reset_thread`` row by row,
  the device's layout), equal the CPU env's reset bit for bit, first and later episodes, on ids with and
  without per-episode events;
* :class:`~planetnav_env.device.vector_env.DeviceVectorEnv` in host mode (numpy state viewed by torch CPU
  tensors, the thread functions run on the CPU): its observations, rewards, terminations and truncations
  equal the CPU vector env's (``gym.make_vec``) bit for bit over many steps with autoresets, in both
  autoreset modes, and its buffers have the layout the device uses;
* asked for CUDA without one, the env says what is missing;
* the kernels compile once per process (numba-cuda installed); they compile to PTX in
  tests/env/test_cuda_ptx.py.

What only a device checks: the numbers of the kernels on the GPU, the launch itself and the speed
(benchmarks/bench_gpu.py).
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
import torch
from gymnasium.utils import seeding

import planetnav_env  # noqa: F401
from planetnav_env.batch import BatchCore
from planetnav_env.config import EnvConfig
from planetnav_env.core.records import scratch_rows
from planetnav_env.device import rows as R
from planetnav_env.device.bank import EpisodeBank, bank_slot
from planetnav_env.device.vector_env import DeviceVectorEnv, cuda_unavailable_reason
from planetnav_env.envs.registration import id_options
from planetnav_env.errors import InvalidParameterError

ROWS = 3

pytestmark = pytest.mark.filterwarnings("ignore:.*is out of date.*")


BANK_IDS = [
    "planetnav/Cruise-Target-v1",
    "planetnav/RandomCruise-Target-v2",  # per-episode events, a drawn epoch (a table per episode)
    "planetnav/MarsApproach-Tasking-v1",
    "planetnav/ThrustArc-TCM-v2",  # operations
]


@pytest.mark.parametrize("env_id", BANK_IDS)
def test_bank_rows_after_the_compiled_reset_equal_the_cpu_reset(env_id: str) -> None:
    cfg = EnvConfig.from_dict(id_options(env_id))
    n, episodes = ROWS, 2
    bank = EpisodeBank(BatchCore(cfg, 1), n, episodes * n, [7 + r for r in range(n)])
    cpu = BatchCore(cfg, n)
    gens = [seeding.np_random(7 + r)[0] for r in range(n)]
    dev = BatchCore(cfg, n)
    rows = scratch_rows(dev.params, n)
    all_rows = np.arange(n, dtype=np.int64)
    for e in range(episodes):  # the second reset continues each row's generator, as an autoreset does
        cpu.reset_rows(all_rows, gens)
        k = bank_slot(e, all_rows, n, bank.size)
        for name in ("f", "p", "rng", "eph"):
            getattr(dev, name)[:] = getattr(bank.rows, name)[k]
        R.reset_rows(dev.params, dev.state, all_rows, rows)
        for name in ("f", "p", "i", "rng", "eph", "obs"):
            assert getattr(dev, name).tobytes() == getattr(cpu, name).tobytes(), (e, name)
        assert [bank.episodes[s] for s in k] == [cpu.episodes[r] for r in range(n)]


def test_bank_slots_cycle_past_the_bank() -> None:
    assert bank_slot(np.array([0, 1, 2, 3]), np.array([1, 1, 1, 1]), 4, 8).tolist() == [1, 5, 1, 5]
    rows, eps = torch.arange(4), torch.tensor([0, 0, 1, 1])
    assert bank_slot(eps, rows, 4, 3).tolist() == [0, 1, 0, 1]  # a bank smaller than N: rows share


# --- the host mode against the CPU vector env ---
PARITY = [
    # id, overrides, autoreset mode, steps
    ("planetnav/Cruise-Target-v1", {"episode_steps": 60}, "next_step", 40),  # 10 physics steps a decision
    ("planetnav/Cruise-Target-v1", {"episode_steps": 60}, "same_step", 40),
    ("planetnav/RandomCruise-Target-v2", {"episode_steps": 40}, "next_step", 20),  # events, image log
    ("planetnav/RandomCruise-Target-v2", {"episode_steps": 35}, "same_step", 20),  # ends inside a hold
    ("planetnav/MarsApproach-Tasking-v1", {"episode_steps": 40}, "next_step", 30),
    ("planetnav/Cruise-TorqueControl-v1", {"episode_steps": 25}, "next_step", 100),  # 1-s torque control
    ("planetnav/Cruise-Hybrid-v1", {"episode_steps": 25}, "same_step", 60),
    (
        "planetnav/Cruise-TargetTorque-v1",
        {"episode_steps": 25, "observe_residual_log": True},
        "next_step",
        60,
    ),
    ("planetnav/ThrustArc-TCM-v2", {"episode_steps": 48}, "next_step", 12),  # operations, 12-step decisions
]


def _actions(space: gym.Space, n: int, rng: np.random.Generator, k: int) -> np.ndarray:
    if isinstance(space, gym.spaces.Discrete):
        return rng.integers(0, space.n, n) if k % 3 == 0 else np.zeros(n, np.int64)
    return rng.uniform(-1.2, 1.2, (n, *space.shape)).astype(np.float32)


@pytest.mark.parametrize(("env_id", "overrides", "mode", "steps"), PARITY)
def test_host_mode_equals_the_cpu_vector_env_bit_for_bit(env_id, overrides, mode, steps) -> None:
    n = ROWS
    ref = gym.make_vec(env_id, num_envs=n, autoreset_mode=mode, **overrides)
    # A bank deep enough for every row's episodes in the run: the CPU env's episodes, in order.
    dev = DeviceVectorEnv(
        env_id, n, device="cpu", bank_size=n * (steps + 2), autoreset_mode=mode, **overrides
    )
    assert dev.config == ref.unwrapped.config
    assert dev.single_observation_space == ref.single_observation_space
    assert dev.single_action_space == ref.single_action_space
    o_ref, _ = ref.reset(seed=3)
    o_dev, _ = dev.reset(seed=3)
    assert o_dev.dtype == torch.float32 and o_dev.shape == (n, dev.layout.size)
    assert o_dev.numpy().tobytes() == o_ref.tobytes()
    rng = np.random.default_rng(1)
    ended = 0
    for k in range(steps):
        a = _actions(ref.single_action_space, n, rng, k)
        o_r, r_r, term_r, trunc_r, info_r = ref.step(a)
        o_d, r_d, term_d, trunc_d, info_d = dev.step(torch.as_tensor(a))
        assert o_d.numpy().tobytes() == o_r.tobytes(), f"obs, step {k}"
        assert r_d.dtype == torch.float64 and r_d.numpy().tobytes() == r_r.tobytes(), f"reward, step {k}"
        assert np.array_equal(term_d.numpy(), term_r) and np.array_equal(trunc_d.numpy(), trunc_r), k
        if mode == "same_step" and (term_r | trunc_r).any():
            done = term_r | trunc_r
            last = np.stack(info_r["final_obs"][done])
            assert info_d["final_obs"].numpy()[done].tobytes() == last.tobytes()
        assert np.array_equal(info_d["pos_err_km"].numpy(), info_r["pos_err_km"])
        ended += int((term_r | trunc_r).sum())
    assert ended >= n  # every row autoreset at least once (on average)
    core = ref.unwrapped.core
    state = dev.state_arrays()
    for name in ("f", "p", "i", "rng", "eph", "obs"):
        assert state[name].tobytes() == getattr(core, name).tobytes(), name
    dev.check_status()


@pytest.mark.parametrize("mode", ["same_step", "next_step"])
def test_a_partial_reset_equals_the_cpu_vector_envs(mode: str) -> None:
    """``reset(options={"reset_mask": m})`` starts the ``m`` rows' next episodes, the ones the CPU vector
    env's partial reset starts (bit for bit), leaves the other rows as they are, and the rows then step
    on equal to the CPU env's, through autoresets."""
    env_id, n, steps = "planetnav/RandomCruise-Target-v2", 4, 20
    ref = gym.make_vec(env_id, num_envs=n, autoreset_mode=mode, episode_steps=60)
    dev = DeviceVectorEnv(env_id, n, device="cpu", bank_size=n * 24, autoreset_mode=mode, episode_steps=60)
    ref.reset(seed=5)
    dev.reset(seed=5)
    masks = {2: [True, False, True, False], 3: [False, False, False, True], 9: [True, True, True, True]}
    rng = np.random.default_rng(2)
    for k in range(steps):
        a = _actions(ref.single_action_space, n, rng, k)
        o_r, r_r, *_ = ref.step(a)
        o_d, r_d, *_ = dev.step(torch.as_tensor(a))
        assert o_d.numpy().tobytes() == o_r.tobytes() and r_d.numpy().tobytes() == r_r.tobytes(), k
        if k in masks:
            m = np.array(masks[k])
            before = dev.obs.clone()
            episodes = dev.episode_count.clone()
            o_r, _ = ref.reset(options={"reset_mask": m})
            o_d, info = dev.reset(options={"reset_mask": torch.as_tensor(m)})
            assert o_d.numpy().tobytes() == o_r.tobytes(), f"partial reset after step {k}"
            assert torch.equal(o_d[~m], before[~m])
            assert not torch.equal(o_d[m], before[m])
            assert torch.equal(info["episode"], episodes + torch.as_tensor(m))
    core = ref.unwrapped.core
    state = dev.state_arrays()
    for name in ("f", "p", "i", "rng", "eph", "obs"):
        assert state[name].tobytes() == getattr(core, name).tobytes(), name
    assert dev.bank_stats()["substituted"] == 0


def test_a_partial_reset_refuses_what_it_cannot_do() -> None:
    dev = DeviceVectorEnv("planetnav/Cruise-Target-v1", 2, device="cpu")
    mask = torch.tensor([True, False])
    with pytest.raises(RuntimeError, match=r"call reset\(seed=...\)"):
        dev.reset(options={"reset_mask": mask})
    dev.reset(seed=0)
    with pytest.raises(InvalidParameterError, match=r"seed=3 with reset_mask"):
        dev.reset(seed=3, options={"reset_mask": mask})
    with pytest.raises(InvalidParameterError, match=r"shape \(2,\), got dtype torch.bool and shape \(3,\)"):
        dev.reset(options={"reset_mask": [True, False, True]})
    with pytest.raises(InvalidParameterError, match=r"got dtype torch.int64"):
        dev.reset(options={"reset_mask": np.array([1, 0])})
    with pytest.raises(InvalidParameterError, match=r"unknown option\(s\) \['mask'\].*reset_mask"):
        dev.reset(options={"mask": mask})
    assert dev.episode_count.tolist() == [1, 1]  # nothing was reset by the refused calls


def test_host_buffers_are_views_of_one_memory() -> None:
    """The torch tensors the env hands out and the arrays the kernels write are one memory (no copy)."""
    dev = DeviceVectorEnv("planetnav/Cruise-Target-v1", 2, device="cpu")
    dev.reset(seed=0)
    assert dev.f.data_ptr() == dev._state.f.ctypes.data
    assert dev._rng.dtype == torch.int64 and dev._state.rng.dtype == np.uint64
    assert dev._rng.data_ptr() == dev._state.rng.ctypes.data
    # The device's layout: every per-row array with the rows innermost (a row axis stride of one element).
    per_row = [*dev._state, dev._act.torques, *dev._scratch]
    assert all(a.strides[0] == a.itemsize for a in per_row if a.size)  # (an empty array has no strides)
    assert dev.f.stride() == (1, dev.num_envs) and dev.p.stride() == (1, 6 * dev.num_envs, dev.num_envs)
    assert dev.bytes_per_row() > 2000
    assert dev.episode_count.tolist() == [1, 1]


def test_without_refill_the_bank_wraps_and_episodes_repeat() -> None:
    """With ``refill="off"``, past ``bank_size / N`` episodes a row replays its bank episodes, and each
    replay counts as a substitute."""
    dev = DeviceVectorEnv(
        "planetnav/Cruise-TorqueControl-v1", 2, device="cpu", bank_size=2, refill="off", episode_steps=3
    )
    o0, _ = dev.reset(seed=4)
    first = o0.clone()
    zero = torch.zeros((2, 3))
    for _ in range(3):  # ends at the third step; next_step: the fourth starts the next episode
        dev.step(zero)
    assert dev.substituted.tolist() == [0, 0]
    o, *_ = dev.step(zero)
    assert dev.episode_count.tolist() == [2, 2]
    assert torch.equal(o, first)
    assert dev.substituted.tolist() == [1, 1]
    assert dev.bank_stats() == {"episodes": 4, "substituted": 2, "drawn": 2, "written": 2, "bank_size": 2}


# --- CUDA: the error without a device, the PTX of the autoreset ---
def test_asking_for_cuda_without_it_names_what_is_missing() -> None:
    why = cuda_unavailable_reason()
    if why is None:
        pytest.skip("a CUDA device is available here")
    with pytest.raises(RuntimeError, match=r"needs a CUDA GPU.*pip install"):
        DeviceVectorEnv("planetnav/Cruise-Target-v1", 4, device="cuda")


def test_launch_settings_are_checked() -> None:
    for bad, match in [
        ({"threads_per_block": 0}, "threads_per_block must be a positive integer, got 0"),
        ({"threads_per_block": 2048}, "threads_per_block must be at most 1024, got 2048"),
        ({"max_registers": 8}, r"max_registers must be in \[16, 255\] \(or None: no cap\), got 8"),
        ({"max_registers": 1.5}, "max_registers must be a positive integer, got 1.5"),
    ]:
        with pytest.raises(InvalidParameterError, match=match):
            DeviceVectorEnv("planetnav/Cruise-Target-v1", 2, device="cpu", **bad)


def test_the_kernels_compile_once_per_process() -> None:
    """Every device env of a process launches the same dispatchers (one compilation, minutes of a device's
    time saved in a benchmark that creates a dozen envs); a register cap is its own pair."""
    from planetnav_env.numerics.cuda_target import require_numba_cuda

    try:
        require_numba_cuda()
    except ImportError as exc:
        pytest.skip(str(exc))
    from planetnav_env.device.cuda_kernels import dispatchers

    assert dispatchers() is dispatchers(None)
    capped = dispatchers(128)
    assert capped.step is not dispatchers().step
    assert capped.step.targetoptions["max_registers"] == 128
    assert "max_registers" not in dispatchers().step.targetoptions
