"""The episode bank: what ``M`` resets draw on the host, drawn in advance and laid out like the state rows.

A reset of a row has two parts (:meth:`BatchCore.reset_rows <planetnav_env.core.batch.BatchCore.reset_rows>`):
the host draws the episode from the row's ``numpy`` generator (scenario, ephemeris table fit, initial
filter error, attitude, the compiled noise stream's seed, the episode's events) with
:meth:`BatchCore.draw_row <planetnav_env.core.batch.BatchCore.draw_row>`, then the compiled part
(``kernels.reset_row``) takes the first star fix, rate measurement and observation. A GPU thread cannot run
the first part, so the device env draws it here, once, into arrays of the state's row layout
(:class:`BankRows`: ``f`` (M, NF), ``p`` (M, 6, 6), ``rng`` (M, STATE_WORDS) uint64, ``eph`` (M, table)),
and a device autoreset copies bank row ``k`` into state row ``n`` and runs the compiled part
(:func:`planetnav_env.device.rows.autoreset_thread`).

Which bank row a reset takes: row ``n``'s ``e``-th episode (``e = 0`` at ``reset``) is bank row
``(e * N + n) mod M`` (:func:`bank_slot`), and bank row ``k < M`` is drawn as episode ``k // N`` of row
``k mod N``'s generator, seeded as the CPU vector env seeds it (``seed + n``). So while ``e < M / N`` the
device env's row ``n`` plays the CPU vector env's row ``n``'s episodes, bit for bit in what is drawn; past
that the bank cycles (an episode, its noise stream included, is played again), and with ``M < N`` rows
``n`` and ``n + M`` start from the same episode. The bank is drawn once per ``reset(seed=...)``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from gymnasium.utils import seeding

from planetnav_env.core.batch import BatchCore, RowEpisode
from planetnav_env.core.rng import STATE_WORDS
from planetnav_env.errors import InvalidParameterError


class BankRows(NamedTuple):
    """The host-drawn part of ``M`` episodes, one per row, in the state's layout (a record the autoreset
    kernel reads; device arrays in place of the numpy ones on a GPU)."""

    f: np.ndarray  # (M, NF) float state as drawn (the columns reset_row fills are zero)
    p: np.ndarray  # (M, 6, 6) initial filter covariance [km^2, km^2/s, km^2/s^2]
    rng: np.ndarray  # (M, STATE_WORDS) uint64 seed state of each episode's compiled noise stream
    eph: np.ndarray  # (M, *TableSpec.shape) each episode's ephemeris table


def bank_slot(episode: np.ndarray, row: np.ndarray, num_rows: int, size: int) -> np.ndarray:
    """Bank row of row ``row``'s ``episode``-th episode (0: the one ``reset`` starts), for ``num_rows``
    rows and a bank of ``size`` rows: ``(episode * num_rows + row) mod size``. Works on numpy arrays and
    torch tensors alike (the device env computes it on the device)."""
    return (episode * num_rows + row) % size


class EpisodeBank:
    """``size`` episodes' host-side reset results for a batch of ``num_rows`` rows (module docstring).

    ``core`` is a :class:`~planetnav_env.core.batch.BatchCore` of the configuration (any number of rows: only
    its drawing code and its table cache are used); ``seeds`` one seed (or None: fresh entropy) per row,
    as ``PlanetNavVectorEnv.reset(seed=...)`` takes them.
    """

    def __init__(self, core: BatchCore, num_rows: int, size: int, seeds: Sequence[int | None]) -> None:
        if int(size) != size or size < 1:
            raise InvalidParameterError(f"bank size must be a positive integer, got {size!r}")
        if len(seeds) != num_rows:
            raise InvalidParameterError(f"seeds must have {num_rows} entries, got {len(seeds)}")
        self.num_rows, self.size = int(num_rows), int(size)
        m = self.size
        self.rows = BankRows(
            f=np.zeros((m, core.f.shape[1])),
            p=np.zeros((m, 6, 6)),
            rng=np.zeros((m, STATE_WORDS), dtype=np.uint64),
            eph=np.zeros((m, *core.table_spec.shape)),
        )
        self.episodes: list[RowEpisode | None] = [None] * m
        # One generator per row (only the rows the bank reaches), continued episode after episode, as the
        # CPU vector env continues a row's generator at its autoresets.
        used = min(self.num_rows, m)
        self.generators = [seeding.np_random(seeds[n])[0] for n in range(used)]
        r = self.rows
        for k in range(m):  # k = e * N + n: episode e of every row before episode e + 1 of any
            gen = self.generators[k % self.num_rows]
            self.episodes[k] = core.draw_row(gen, r.f[k], r.p[k], r.rng[k], r.eph[k])

    @classmethod
    def for_vector_env(
        cls, core: BatchCore, num_rows: int, size: int, seed: int | Sequence[int | None] | None
    ) -> EpisodeBank:
        """A bank seeded as ``PlanetNavVectorEnv.reset(seed=seed)`` seeds its rows: an int ``s`` gives
        row ``n`` the seed ``s + n``, a list one seed per row, None fresh entropy."""
        if seed is None:
            seeds: list[int | None] = [None] * num_rows
        elif isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
            seeds = [int(seed) + n for n in range(num_rows)]
        else:
            seeds = list(seed)
        return cls(core, num_rows, size, seeds)

    def nbytes(self) -> int:
        """Bytes the bank's arrays hold (what a device copy of it takes)."""
        return sum(a.nbytes for a in self.rows)
