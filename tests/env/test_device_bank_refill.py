"""The device env's bank refill, in host mode (planetnav_env/device/refill.py).

* ``refill="inline"``: past the bank's first pass every row keeps playing the CPU vector env's episodes
  in order, bit for bit, with no substitute, in both autoreset modes and on an id with per-episode events;
* ``refill="thread"`` with a flush after each step: the same sequence, drawn by the host thread;
* a thread that cannot keep up: the rows start substitutes, counted exactly, and after a flush they are back
  on their own episodes (the ones the inline refill gives them);
* a pool of drawing processes draws the same bank as one process, bit for bit, and feeds the refill;
* a failing thread's or worker's error reaches the stepping thread; bad settings are named.
"""

from __future__ import annotations

import threading

import gymnasium as gym
import numpy as np
import pytest
import torch

import planetnav_env  # noqa: F401
from planetnav_env.batch import BatchCore
from planetnav_env.device.bank import EpisodeBank
from planetnav_env.device.draw_pool import DrawPool
from planetnav_env.device.vector_env import DeviceVectorEnv
from planetnav_env.errors import InvalidParameterError

pytestmark = pytest.mark.filterwarnings("ignore:.*is out of date.*")

N = 3


def _actions(space: gym.Space, rng: np.random.Generator) -> np.ndarray:
    if isinstance(space, gym.spaces.Discrete):
        return rng.integers(0, space.n, N)
    return rng.uniform(-1.0, 1.0, (N, *space.shape)).astype(np.float32)


CASES = [
    # id, overrides, autoreset mode, refill, decisions (each row runs through five or more banks' worth)
    ("planetnav/Cruise-TorqueControl-v1", {"episode_steps": 4}, "next_step", "inline", 26),
    ("planetnav/Cruise-TorqueControl-v1", {"episode_steps": 4}, "same_step", "inline", 21),
    ("planetnav/RandomCruise-Target-v2", {"episode_steps": 20}, "next_step", "inline", 13),  # events
    ("planetnav/Cruise-TorqueControl-v1", {"episode_steps": 4}, "next_step", "thread", 26),
]


@pytest.mark.parametrize(("env_id", "overrides", "mode", "refill", "steps"), CASES)
def test_refilled_bank_plays_the_cpu_vector_envs_episodes(env_id, overrides, mode, refill, steps) -> None:
    ref = gym.make_vec(env_id, num_envs=N, autoreset_mode=mode, **overrides)
    # A bank of N slots in chunks of 2: the chunks straddle rows, and one of each pass is a single slot.
    dev = DeviceVectorEnv(
        env_id, N, device="cpu", bank_size=N, autoreset_mode=mode, refill=refill, refill_chunk=2, **overrides
    )
    o_ref, _ = ref.reset(seed=11)
    o_dev, _ = dev.reset(seed=11)
    assert o_dev.numpy().tobytes() == o_ref.tobytes()
    rng = np.random.default_rng(5)
    for k in range(steps):
        a = _actions(ref.single_action_space, rng)
        o_r, r_r, term_r, trunc_r, _ = ref.step(a)
        o_d, r_d, term_d, trunc_d, _ = dev.step(torch.as_tensor(a))
        if refill == "thread":
            dev.flush_bank()
        assert o_d.numpy().tobytes() == o_r.tobytes(), f"obs, step {k}"
        assert r_d.numpy().tobytes() == r_r.tobytes(), f"reward, step {k}"
        assert np.array_equal(term_d.numpy() | trunc_d.numpy(), term_r | trunc_r), k
    stats = dev.bank_stats()
    assert stats["substituted"] == 0
    assert stats["episodes"] >= 5 * N  # five passes of the bank
    assert stats["written"] >= stats["episodes"]
    dev.close()


def _hold_the_refill(monkeypatch) -> threading.Event:
    """Make the bank's draws past pass 0 wait until the returned event is set (a slow host)."""
    release = threading.Event()
    draw = EpisodeBank.draw

    def slow_draw(self, start, out):
        if start >= self.size:
            release.wait(timeout=60)
        return draw(self, start, out)

    monkeypatch.setattr(EpisodeBank, "draw", slow_draw)
    return release


def test_a_refill_that_falls_behind_counts_substitutes_and_catches_up(monkeypatch) -> None:
    env_id, steps = "planetnav/Cruise-TorqueControl-v1", {"episode_steps": 3}
    inline = DeviceVectorEnv(env_id, N, device="cpu", bank_size=N, refill="inline", **steps)
    release = _hold_the_refill(monkeypatch)
    dev = DeviceVectorEnv(env_id, N, device="cpu", bank_size=N, refill="thread", **steps)
    dev.reset(seed=2)
    inline.reset(seed=2)
    zero = torch.zeros((N, 3))
    # Three decisions an episode, and next_step autoreset: steps 4, 8 and 12 start episodes 1, 2 and 3.
    for _ in range(8):
        dev.step(zero)
    # Episodes 1 and 2 of every row found their slots unwritten: the thread is held.
    assert dev.episode_count.tolist() == [3] * N
    assert dev.substituted.tolist() == [2] * N
    assert dev.bank_stats()["written"] == N
    release.set()
    dev.flush_bank()  # catch up: every slot whose episode has been started
    stats = dev.bank_stats()
    assert stats["written"] == 3 * N + N  # episodes 1 .. 3 of every row: up to one bank past the rows
    # Episode 3, the rows' own again: its first observation is the one the inline refill gives.
    for _ in range(4):
        o, *_ = dev.step(zero)
    for _ in range(12):
        o_in, *_ = inline.step(zero)
    assert dev.episode_count.tolist() == inline.episode_count.tolist() == [4] * N
    assert o.numpy().tobytes() == o_in.numpy().tobytes()
    assert dev.substituted.tolist() == [2] * N and inline.substituted.tolist() == [0] * N
    dev.close()


def test_a_failing_refill_thread_raises_in_the_step(monkeypatch) -> None:
    def broken(self, start, out):
        if start >= self.size:
            raise ValueError("table fit failed")
        return original(self, start, out)

    original = EpisodeBank.draw
    monkeypatch.setattr(EpisodeBank, "draw", broken)
    dev = DeviceVectorEnv("planetnav/Cruise-TorqueControl-v1", N, device="cpu", bank_size=N, episode_steps=3)
    dev.reset(seed=0)
    dev.refill._thread.join(timeout=10)  # the thread stops at its first draw
    with pytest.raises(RuntimeError, match=r"refill thread failed.*table fit failed"):
        dev.step(torch.zeros((N, 3)))


def test_a_pool_of_workers_draws_what_one_process_draws(monkeypatch) -> None:
    """Two processes, each owning every other row's generator, fill pass 0 and the refill's chunks with
    the episodes one process draws, bit for bit; the env on them plays the CPU env's sequence."""
    monkeypatch.setattr("planetnav_env.device.draw_pool.BLOCK_EPISODES", 5)  # several rounds a draw
    env_id, steps = "planetnav/RandomCruise-Target-v2", {"episode_steps": 20}  # a table per episode
    dev = DeviceVectorEnv(env_id, N, device="cpu", bank_size=7, bank_workers=2, refill_chunk=4, **steps)
    solo = EpisodeBank.for_vector_env(BatchCore(dev.config, 1), N, 7, 9)
    try:
        dev.reset(seed=9)
        for name in ("f", "p", "rng", "eph"):
            assert getattr(dev.bank.rows, name).tobytes() == getattr(solo.rows, name).tobytes(), name
        assert dev.bank.episodes == solo.episodes
        ref = gym.make_vec(env_id, num_envs=N, **steps)
        ref.reset(seed=9)
        rng = np.random.default_rng(3)
        for k in range(13):  # five episodes a row: past the bank's first pass twice
            a = rng.integers(0, ref.single_action_space.n, N)
            o_r, *_ = ref.step(a)
            o_d, *_ = dev.step(torch.as_tensor(a))
            dev.flush_bank()
            assert o_d.numpy().tobytes() == o_r.tobytes(), k
        assert dev.bank_stats()["substituted"] == 0 and dev.bank_stats()["written"] > 2 * 7
    finally:
        dev.close()
    assert dev._pool is None


def test_a_failing_worker_names_its_error() -> None:
    core = BatchCore(DeviceVectorEnv("planetnav/Cruise-Target-v1", 1, device="cpu").config, 1)
    pool = DrawPool(core.config, 2)
    try:
        with pytest.raises(RuntimeError, match=r"bank-drawing worker failed.*Seed must be"):
            EpisodeBank(core, 2, 2, [1, "not a seed"], pool)
    finally:
        pool.close()


def test_a_dead_worker_is_named_with_the_spawn_rule() -> None:
    pool = DrawPool(DeviceVectorEnv("planetnav/Cruise-Target-v1", 1, device="cpu").config, 1)
    try:
        pool._procs[0].kill()
        pool._procs[0].join(timeout=10)
        with pytest.raises(RuntimeError, match=r"worker exited.*if __name__ == '__main__'"):
            pool.seed([0])
    finally:
        pool.close()


def test_host_mode_draws_in_process_by_default() -> None:
    dev = DeviceVectorEnv("planetnav/Cruise-Target-v1", 2, device="cpu")
    assert dev.bank_workers == 0 and dev._pool is None


def test_the_bank_draws_in_order_only() -> None:
    dev = DeviceVectorEnv("planetnav/Cruise-TorqueControl-v1", 2, device="cpu", refill="off")
    dev.reset(seed=0)
    with pytest.raises(InvalidParameterError, match="in order: next is 4, asked for 6"):
        dev.bank.draw(6, dev.bank.rows)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"refill": "sometimes"}, "refill must be one of"),
        ({"refill_chunk": 0}, "refill_chunk must be a positive integer, got 0"),
        ({"bank_size": 0}, "bank_size must be a positive integer, got 0"),
        ({"bank_size": 2.5}, "bank_size must be a positive integer, got 2.5"),
        ({"bank_workers": -1}, "bank_workers must be a non-negative integer, got -1"),
    ],
)
def test_bad_bank_settings_are_named(kwargs, match) -> None:
    with pytest.raises(InvalidParameterError, match=match):
        DeviceVectorEnv("planetnav/Cruise-Target-v1", 2, device="cpu", **kwargs)
