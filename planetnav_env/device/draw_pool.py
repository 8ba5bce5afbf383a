"""Worker processes that draw the episode bank's episodes in parallel, each for its own rows.

Drawing an episode on the host takes 40-200 us of Python (the scenario's Kepler state, the filter's
initial error, the ephemeris table; ``benchmarks/bench_gpu.py`` prints the rate), so one thread feeds a
GPU's rows only up to about a million decisions per second on a target-choice task. A :class:`DrawPool`
of ``W`` processes splits every draw by row: worker ``w`` owns the rows ``n`` with ``n mod W = w``, keeps
their generators (seeded as the CPU vector env seeds them, continued episode after episode) and draws
their global episodes into a shared-memory block. Each row's episodes are drawn in order by the one
generator that owns it, so what the bank holds does not depend on ``W``: the pool's draws equal the
in-process draws bit for bit (``tests/env/test_device_bank_refill.py``).

Why processes, not threads: drawing is Python, and a thread that draws holds the interpreter lock that the
stepping thread needs to launch its kernels (in host mode on a 2-core machine, a drawing thread cut the
step rate of 8-decision episodes to 0.22-0.28 of the rate without a refill, one drawing process to 0.81-0.90:
``research/probes/refill_gil_probe.py``). The processes are spawned (not forked: the parent may hold a
CUDA context), once per pool, so a script that makes them must guard its entry under ``if __name__ ==
"__main__":``; ``seed`` starts a new sequence at each ``reset``.
"""

from __future__ import annotations

import multiprocessing as mp
from collections.abc import Sequence
from multiprocessing import shared_memory

import numpy as np

from planetnav_env.batch import BatchCore, RowEpisode
from planetnav_env.config import EnvConfig
from planetnav_env.device.bank import BankRows, RowGenerators, empty_rows
from planetnav_env.errors import require_count

#: Episodes one round of the pool draws at most (the shared block's rows).
BLOCK_EPISODES = 2048


def _views(core: BatchCore, buf: memoryview, count: int) -> BankRows:
    """``count`` bank rows of ``core``'s layout laid over the shared block ``buf`` (f, p, rng, eph)."""
    shapes = empty_rows(core, 0)
    out, offset = [], 0
    for a in shapes:
        shape = (count, *a.shape[1:])
        n = int(np.prod(shape)) * a.itemsize
        out.append(np.ndarray(shape, dtype=a.dtype, buffer=buf, offset=offset))
        offset += n
    return BankRows(*out)


def block_bytes(core: BatchCore, count: int) -> int:
    """Bytes of ``count`` bank rows of ``core``'s layout."""
    return sum(a.itemsize * int(np.prod(a.shape[1:])) * count for a in empty_rows(core, 0))


def _worker(  # pragma: no cover - runs in the spawned processes
    conn, config: EnvConfig, worker: int, workers: int, shm_name: str, block: int
) -> None:
    """One process of the pool: answers ``seed``, ``draw`` and ``stop`` messages on ``conn``."""
    core = BatchCore(config, 1)
    shm = shared_memory.SharedMemory(name=shm_name)
    rows = _views(core, shm.buf, block)
    generators = RowGenerators(())
    try:
        while True:
            msg = conn.recv()
            if msg[0] == "stop":
                break
            try:
                if msg[0] == "seed":
                    generators = RowGenerators(msg[1])
                    conn.send(("ok", None))
                    continue
                _, start, count = msg
                out = BankRows(*(a[:count] for a in rows))
                conn.send(("ok", generators.draw(core, start, out, worker, workers)))
            except Exception as exc:  # sent to the parent, which raises it
                conn.send(("error", repr(exc)))
    finally:
        del rows
        shm.close()


class DrawPool:
    """``workers`` processes drawing ``config``'s episodes for an
    :class:`~planetnav_env.device.bank.EpisodeBank` (module docstring). Close it with :meth:`close` (the
    env does). ``block``: episodes a round draws at most (default :data:`BLOCK_EPISODES`)."""

    def __init__(self, config: EnvConfig, workers: int, block: int | None = None) -> None:
        self.workers = require_count("bank_workers", workers)
        self.block = require_count("block", block if block is not None else BLOCK_EPISODES)
        self._core = BatchCore(config, 1)  # the layout of the shared block
        self._shm = shared_memory.SharedMemory(create=True, size=block_bytes(self._core, self.block))
        self._rows = _views(self._core, self._shm.buf, self.block)
        ctx = mp.get_context("spawn")
        self._conns, self._procs = [], []
        for w in range(self.workers):
            parent, child = ctx.Pipe()
            args = (child, config, w, self.workers, self._shm.name, self.block)
            proc = ctx.Process(target=_worker, args=args, daemon=True, name=f"planetnav-bank-draw-{w}")
            proc.start()
            self._conns.append(parent)
            self._procs.append(proc)

    def _round(self, msg: tuple) -> list:
        try:
            for c in self._conns:
                c.send(msg)
            replies = [c.recv() for c in self._conns]
        except (EOFError, OSError) as exc:  # a worker died: its pipe closed
            codes = {p.name: p.exitcode for p in self._procs if not p.is_alive()}
            raise RuntimeError(
                f"a bank-drawing worker exited ({codes or exc!r}). Worker processes are spawned: a script "
                "that makes a device env with bank_workers > 0 must do so under if __name__ == '__main__': "
                "(or pass bank_workers=0 to draw in this process)"
            ) from exc
        errors = [r[1] for r in replies if r[0] == "error"]
        if errors:
            raise RuntimeError(f"a bank-drawing worker failed: {errors[0]}")
        return [r[1] for r in replies]

    def seed(self, seeds: Sequence[int | None]) -> None:
        """Start a new sequence: row ``n``'s generator is seeded with ``seeds[n]`` when first drawn."""
        self._round(("seed", list(seeds)))

    def draw(self, start: int, out: BankRows) -> list[RowEpisode]:
        """Global episodes ``start ..`` into ``out``'s rows (as :meth:`EpisodeBank.draw` draws them), in
        rounds of at most ``block``."""
        total, episodes = out.f.shape[0], []
        for lo in range(0, total, self.block):
            count = min(self.block, total - lo)
            drawn: dict[int, RowEpisode] = {}
            for part in self._round(("draw", start + lo, count)):
                drawn.update(part)
            for dst, src in zip(out, self._rows, strict=True):
                dst[lo : lo + count] = src[:count]
            episodes.extend(drawn[j] for j in range(count))
        return episodes

    def close(self) -> None:
        """Stop the workers and free the shared block (idempotent)."""
        for c in self._conns:
            try:
                c.send(("stop",))
            except (BrokenPipeError, OSError):
                pass
        for p in self._procs:
            p.join(timeout=5)
            if p.is_alive():
                p.kill()
        self._conns, self._procs = [], []
        if self._shm is not None:
            del self._rows
            self._shm.close()
            self._shm.unlink()
            self._shm = None
