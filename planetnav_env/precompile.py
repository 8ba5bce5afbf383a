"""Compile the environment's kernels before first use: ``python -m planetnav_env.precompile [ids...]``.

numba compiles the step and the reset the first time an environment runs them (about three minutes on one
core) and caches the machine code beside the source, where every later process loads it in about a second.
Run this once after installing, wherever processes would otherwise each meet a cold cache: a container image,
the nodes of a cluster that share no disk, the start of a CI job whose test processes start together.

Every id shares one compiled step and one compiled reset (the kernels take the task as data), so the first
id compiles and the others only check that they reuse it.

``--host-mode`` compiles instead the device env's thread functions as its host mode runs them on the CPU
(:class:`~planetnav_env.device.vector_env.DeviceVectorEnv` with ``device="cpu"``; needs torch): a second
compilation of the row kernels, about as long, with one signature for the target ids and one for the Box
ids (their action arrays differ in layout). The CUDA kernels are compiled by the device's own launch.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
import time
import warnings
from collections.abc import Callable, Iterator, Sequence

import gymnasium as gym
import numpy as np

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_env.config import EnvConfig
from planetnav_env.envs.registration import ENV_IDS, id_options


@contextlib.contextmanager
def _superseded_ids_allowed() -> Iterator[None]:
    """Without gymnasium's warning that an id has a newer version: every id is compiled on purpose."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", ".*is out of date", DeprecationWarning)
        yield


def _each_id(env_ids: Sequence[str] | None, run: Callable[[str], None]) -> dict[str, float]:
    """``run`` on each id of ``env_ids`` (every registered id when None), every id checked first; the seconds
    each took, in order."""
    ids = list(ENV_IDS) if env_ids is None else list(env_ids)
    for env_id in ids:
        id_options(env_id)
    seconds: dict[str, float] = {}
    for env_id in ids:
        start = time.perf_counter()
        with _superseded_ids_allowed():
            run(env_id)
        seconds[env_id] = time.perf_counter() - start
    return seconds


def precompile(env_ids: Sequence[str] | None = None) -> dict[str, float]:
    """Reset and step a two-row vector env of each id in ``env_ids`` (every registered id when None), so
    numba has compiled, and cached, the kernels they run. Returns the seconds each id took, in order.

    Raises :class:`~planetnav_env.errors.ConfigError` naming an id that is not a registered planetnav id,
    before anything compiles.
    """

    def run(env_id: str) -> None:
        env = gym.make_vec(env_id, num_envs=2)
        try:
            env.reset(seed=0)
            env.action_space.seed(0)
            env.step(np.asarray(env.action_space.sample()))
        finally:
            env.close()

    return _each_id(env_ids, run)


def precompile_host_mode(env_ids: Sequence[str] | None = None) -> dict[str, float]:
    """Reset and step a two-row host-mode device env of each id (every registered id when None) through an
    autoreset, and run the reset's thread loop, so numba has compiled, and cached, the loops of
    :mod:`planetnav_env.device.rows`. Returns the seconds each id took; an unknown id is named before
    anything compiles."""

    def run(env_id: str) -> None:
        import torch

        from planetnav_env.device.vector_env import DeviceVectorEnv

        # One-decision episodes: the second step autoresets, so the autoreset loop compiles too.
        env = DeviceVectorEnv(env_id, 2, device="cpu", bank_size=2, refill="inline", episode_steps=1)
        try:
            env.reset(seed=0)
            env.single_action_space.seed(0)
            for _ in range(2):
                sample = [env.single_action_space.sample() for _ in range(2)]
                env.step(torch.as_tensor(np.asarray(sample)))
        finally:
            env.close()
        _reset_as_threads_run_it(env.config)

    return _each_id(env_ids, run)


def _reset_as_threads_run_it(cfg: EnvConfig) -> None:
    """The compiled part of the reset row by row (:func:`planetnav_env.device.rows.reset_rows`) on a
    freshly drawn two-row batch, as the tests that hold it to the CPU reset call it."""
    from planetnav_env.batch import BatchCore
    from planetnav_env.core.records import scratch_rows
    from planetnav_env.device.rows import reset_rows

    core = BatchCore(cfg, 2)
    rows = np.arange(2, dtype=np.int64)
    core.reset_rows(rows, [np.random.default_rng(r) for r in rows])
    reset_rows(core.params, core.state, rows, scratch_rows(core.params, 2))


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m planetnav_env.precompile",
        description="Compile and cache the environment's kernels before first use.",
    )
    parser.add_argument("ids", nargs="*", help="registered ids (default: all)")
    parser.add_argument("-q", "--quiet", action="store_true", help="print only the total")
    parser.add_argument(
        "--host-mode",
        action="store_true",
        help="compile the device env's thread functions for its host mode (device='cpu') instead of the step",
    )
    args = parser.parse_args(argv)
    start = time.perf_counter()
    seconds = (precompile_host_mode if args.host_mode else precompile)(args.ids or None)
    for env_id, s in seconds.items():
        if not args.quiet:
            print(f"{s:8.1f} s  {env_id}")
    print(f"{time.perf_counter() - start:8.1f} s  in all ({len(seconds)} ids)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
