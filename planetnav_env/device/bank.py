"""The episode bank: what resets draw on the host, drawn in advance and laid out like the state rows.

A reset of a row has two parts (:meth:`BatchCore.reset_rows <planetnav_env.batch.BatchCore.reset_rows>`):
the host draws the episode from the row's ``numpy`` generator (scenario, ephemeris table fit, initial
filter error, attitude, the compiled noise stream's seed, the episode's events) with
:meth:`BatchCore.draw_row <planetnav_env.batch.BatchCore.draw_row>`, then the compiled part
(``kernels.reset_row``) takes the first star fix, rate measurement and observation. A GPU thread cannot run
the first part, so the device env draws it here, into arrays of the state's row layout
(:class:`BankRows`: ``f`` (M, NF), ``p`` (M, 6, 6), ``rng`` (M, STATE_WORDS) uint64, ``eph`` (M, table)),
and a device autoreset copies bank row ``k`` into state row ``n`` and runs the compiled part
(:func:`planetnav_env.device.rows.autoreset_thread`).

Numbering. For ``N`` rows, row ``n``'s ``e``-th episode (``e = 0`` at ``reset``) is the *global episode*
``g = e N + n``, drawn as episode ``e`` of row ``n``'s generator, seeded as the CPU vector env seeds it
(``seed + n``) and continued episode after episode as the CPU env continues it at its autoresets. So
global episode ``g`` is, in what is drawn, bit for bit the CPU vector env's row ``g mod N``'s episode
``g // N``. The bank has ``M`` slots: global episode ``g`` belongs in slot ``g mod M`` (:func:`bank_slot`)
in *pass* ``g // M``. ``reset`` draws pass 0 (global episodes ``0 .. M-1``); the refill
(:mod:`planetnav_env.device.refill`) draws the later passes in order (:meth:`EpisodeBank.draw`) and writes
each slot once every row has started the episode it held. A row that reaches a slot before its pass is
written starts the episode the slot still holds (a *substitute*: another row's, or an earlier pass's), and
the env counts it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple, Protocol

import numpy as np
from gymnasium.utils import seeding

from planetnav_env.batch import BatchCore, RowEpisode
from planetnav_env.core.rng import STATE_WORDS
from planetnav_env.envs.vector_env import row_seeds
from planetnav_env.errors import InvalidParameterError, require_count


class BankRows(NamedTuple):
    """The host-drawn part of ``M`` episodes, one per row, in the state's layout (a record the autoreset
    kernel reads; device arrays in place of the numpy ones on a GPU)."""

    f: np.ndarray  # (M, NF) float state as drawn (the columns reset_row fills are zero)
    p: np.ndarray  # (M, 6, 6) initial filter covariance [km^2, km^2/s, km^2/s^2]
    rng: np.ndarray  # (M, STATE_WORDS) uint64 seed state of each episode's compiled noise stream
    eph: np.ndarray  # (M, *TableSpec.shape) each episode's ephemeris table


def global_episode(episode: np.ndarray, row: np.ndarray, num_rows: int) -> np.ndarray:
    """Global number of row ``row``'s ``episode``-th episode (0: the one ``reset`` starts) among
    ``num_rows`` rows: ``episode * num_rows + row``; its slot is this mod the bank's size, its pass this
    floor-divided by it. Works on numpy arrays and torch tensors alike (the device env computes it on the
    device)."""
    return episode * num_rows + row


def bank_slot(episode: np.ndarray, row: np.ndarray, num_rows: int, size: int) -> np.ndarray:
    """Bank slot of row ``row``'s ``episode``-th episode in a bank of ``size`` slots."""
    return global_episode(episode, row, num_rows) % size


class RowGenerators:
    """Each row's episode generator, seeded with ``seeds[n]`` (as the CPU vector env seeds row ``n``) when
    its first episode is drawn and continued episode after episode, as the CPU env continues it at its
    autoresets. Created lazily: a bank smaller than ``N``, or a worker owning some rows, reaches only some
    of them."""

    def __init__(self, seeds: Sequence[int | None]) -> None:
        self.seeds, self.num_rows = list(seeds), len(seeds)
        self._generators: dict[int, np.random.Generator] = {}

    def draw(
        self, core: BatchCore, start: int, out: BankRows, worker: int = 0, workers: int = 1
    ) -> dict[int, RowEpisode]:
        """Draw global episodes ``start .. start + len(out.f) - 1`` of the rows ``n`` with ``n mod workers
        == worker`` into ``out``'s rows (``out`` row ``j`` holds global episode ``start + j``); returns
        their scenarios by ``j``."""
        drawn = {}
        for j in range(out.f.shape[0]):
            n = (start + j) % self.num_rows
            if n % workers != worker:
                continue
            gen = self._generators.get(n)
            if gen is None:
                gen = self._generators[n] = seeding.np_random(self.seeds[n])[0]
            drawn[j] = core.draw_row(gen, out.f[j], out.p[j], out.rng[j], out.eph[j])
        return drawn


class Drawer(Protocol):
    """What draws a bank's episodes in parallel (:class:`~planetnav_env.device.draw_pool.DrawPool`)."""

    def seed(self, seeds: Sequence[int | None]) -> None: ...

    def draw(self, start: int, out: BankRows) -> list[RowEpisode]: ...


def empty_rows(core: BatchCore, count: int) -> BankRows:
    """Zeroed host arrays for ``count`` bank rows of ``core``'s configuration."""
    return BankRows(
        f=np.zeros((count, core.f.shape[1])),
        p=np.zeros((count, 6, 6)),
        rng=np.zeros((count, STATE_WORDS), dtype=np.uint64),
        eph=np.zeros((count, *core.table_spec.shape)),
    )


class EpisodeBank:
    """The episodes of ``num_rows`` rows in global order, and pass 0 of a bank of ``size`` slots (module
    docstring).

    ``core`` is a :class:`~planetnav_env.batch.BatchCore` of the configuration (any number of rows: only
    its drawing code and its table cache are used); ``seeds`` one seed (or None: fresh entropy) per row,
    as ``PlanetNavVectorEnv.reset(seed=...)`` takes them; ``pool`` worker processes that draw in parallel
    (:mod:`planetnav_env.device.draw_pool`; None: draw in this process, the same numbers). ``rows`` holds
    pass 0 (global episodes ``0 .. size-1``) and ``episodes`` their scenarios; :meth:`draw` continues from
    ``size``.
    """

    def __init__(
        self,
        core: BatchCore,
        num_rows: int,
        size: int,
        seeds: Sequence[int | None],
        pool: Drawer | None = None,
    ) -> None:
        require_count("bank_size", size)
        if len(seeds) != num_rows:
            raise InvalidParameterError(f"seeds must have {num_rows} entries, got {len(seeds)}")
        self.core = core
        self.num_rows, self.size = int(num_rows), int(size)
        self._generators = RowGenerators(seeds)
        self._pool = pool
        if pool is not None:
            pool.seed(seeds)
        #: The next global episode :meth:`draw` must draw (episodes are drawn in order, once each).
        self.next_episode = 0
        self.rows = empty_rows(core, self.size)
        self.episodes = self.draw(0, self.rows)

    def draw(self, start: int, out: BankRows) -> list[RowEpisode]:
        """Draw global episodes ``start .. start + len(out.f) - 1`` into ``out``'s rows, in order, and return
        their scenarios. ``start`` must be :attr:`next_episode`: a row's generator draws its episodes in
        order, so the sequence is the CPU env's only if no episode is skipped or drawn twice."""
        if start != self.next_episode:
            raise InvalidParameterError(
                f"the bank draws global episodes in order: next is {self.next_episode}, asked for {start}"
            )
        count = out.f.shape[0]
        if self._pool is not None:
            episodes = self._pool.draw(start, out)
        else:
            drawn = self._generators.draw(self.core, start, out)
            episodes = [drawn[j] for j in range(count)]
        self.next_episode = start + count
        return episodes

    @classmethod
    def for_vector_env(
        cls,
        core: BatchCore,
        num_rows: int,
        size: int,
        seed: int | Sequence[int | None] | None,
        pool: Drawer | None = None,
    ) -> EpisodeBank:
        """A bank seeded as ``PlanetNavVectorEnv.reset(seed=seed)`` seeds its rows
        (:func:`~planetnav_env.envs.vector_env.row_seeds`)."""
        return cls(core, num_rows, size, row_seeds(seed, num_rows), pool)

    def nbytes(self) -> int:
        """Bytes the bank's slots hold (what a device copy of it takes)."""
        return sum(a.nbytes for a in self.rows)
