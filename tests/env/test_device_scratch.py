"""The device env reads no memory it has not written: its scratch may start as anything.

A device allocation is not zeroed (``numba.cuda.device_array``, ``torch.empty``), and memory a process
reuses holds the previous owner's numbers. So the results must not depend on what the scratch arrays hold
before the first step: here, in host mode (the thread functions run row by row on the CPU, the device's
layout), every scratch array is filled with NaN (integer arrays with -1, every bit set) before the first
reset, and the rows must still equal the CPU vector env's bit for bit, autoresets included.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
import torch

import planetnav_env  # noqa: F401
from planetnav_env.device.vector_env import DeviceVectorEnv

ROWS = 3

pytestmark = pytest.mark.filterwarnings("ignore:.*is out of date.*")


def poison(scratch) -> int:
    """Fill every array of ``scratch`` with NaN (floats) or all bits set (integers); the number filled."""
    filled = 0
    for a in scratch:
        if np.issubdtype(a.dtype, np.floating):
            a[...] = np.nan
        else:
            a[...] = np.array(-1).astype(a.dtype)  # every bit set
        filled += 1
    return filled


CASES = [
    # id, overrides, decisions: attitude held and slewing, pulsars, torque control, operations
    ("planetnav/Cruise-Target-v1", {"episode_steps": 40}, 30),
    ("planetnav/MarsApproach-Tasking-v1", {"episode_steps": 30}, 25),
    ("planetnav/Cruise-TorqueControl-v1", {"episode_steps": 20}, 30),
    ("planetnav/ThrustArc-TCM-v2", {"episode_steps": 36}, 8),
]


@pytest.mark.parametrize(("env_id", "overrides", "steps"), CASES)
def test_nan_filled_scratch_gives_the_cpu_vector_envs_rows_bit_for_bit(env_id, overrides, steps) -> None:
    n = ROWS
    ref = gym.make_vec(env_id, num_envs=n, **overrides)
    dev = DeviceVectorEnv(env_id, n, device="cpu", bank_size=n * (steps + 2), **overrides)
    assert poison(dev._scratch) == len(dev._scratch._fields)
    assert all(np.isnan(a).all() for a in dev._scratch if a.dtype == np.float64)
    o_ref, _ = ref.reset(seed=11)
    o_dev, _ = dev.reset(seed=11)
    assert o_dev.numpy().tobytes() == o_ref.tobytes(), "reset"
    rng = np.random.default_rng(4)
    space = ref.single_action_space
    ended = 0
    for k in range(steps):
        if isinstance(space, gym.spaces.Discrete):
            a = rng.integers(0, space.n, n) if k % 3 == 0 else np.zeros(n, np.int64)
        else:
            a = rng.uniform(-1.0, 1.0, (n, *space.shape)).astype(np.float32)
        o_r, r_r, term_r, trunc_r, _ = ref.step(a)
        o_d, r_d, term_d, trunc_d, _ = dev.step(torch.as_tensor(a))
        assert o_d.numpy().tobytes() == o_r.tobytes(), f"obs, decision {k}"
        assert r_d.numpy().tobytes() == r_r.tobytes(), f"reward, decision {k}"
        assert np.array_equal(term_d.numpy(), term_r) and np.array_equal(trunc_d.numpy(), trunc_r), k
        ended += int((term_r | trunc_r).sum())
    assert ended >= 1  # an autoreset ran on the poisoned scratch's leftovers too
    core = ref.unwrapped.core
    state = dev.state_arrays()
    for name in ("f", "p", "i", "rng", "eph", "obs"):
        assert state[name].tobytes() == getattr(core, name).tobytes(), name
    dev.check_status()
