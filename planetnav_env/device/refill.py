"""The bank's refill: the next passes of the episode bank, drawn on the host while the rows step.

The device env draws pass 0 of its bank at ``reset`` (:class:`~planetnav_env.device.bank.EpisodeBank`).
A :class:`BankRefill` draws the global episodes that follow, in order, in chunks of contiguous slots, and
writes a chunk into the bank once every row has started the episodes its slots held (the host's copy of
the rows' episode counts says so). Three modes:

* ``"thread"`` (the default): a host thread draws chunks into staging buffers (pinned memory on a GPU)
  while the rows step; each step's :meth:`BankRefill.poll` writes the chunks whose slots are free with an
  asynchronous copy on the current stream and refreshes the episode counts with an asynchronous copy
  back. Nothing in a step waits on the host thread or on the device. Whether a chunk arrives before a
  row needs it depends on the host's drawing speed: a row that gets there first starts a substitute
  (:mod:`planetnav_env.device.bank`), which the env counts, so a run says how much of it was the CPU
  env's sequence.
* ``"inline"``: each step draws and writes, before its autoreset, every chunk whose slots are free, with
  the counts read synchronously. Deterministic: with a bank of at least ``N`` slots and rows that stay
  within a pass of each other no row ever starts a substitute, and every row plays the CPU vector env's
  episodes in order for as long as it runs. The step waits for the drawing.
* ``"off"``: the bank is drawn once; past it rows replay its episodes.

:meth:`BankRefill.flush` makes the thread mode catch up (it waits for the thread and the copies): what
``inline`` does at every step, at a moment the caller chooses.

Ordering on a GPU: a slot is written only after the autoreset that read its previous episode has been
enqueued (the counts that free it were copied after that autoreset on the same stream), and the write is
enqueued before any later autoreset, so the stream orders both without a host wait.
"""

from __future__ import annotations

import queue
import threading
from dataclasses import dataclass

import numpy as np
import torch

from planetnav_env.device.bank import BankRows, EpisodeBank
from planetnav_env.errors import InvalidParameterError, require_count

#: ``refill`` choices of the device env.
REFILL_MODES = ("thread", "inline", "off")
#: Slots a chunk holds at most (a chunk never wraps past the bank's end).
DEFAULT_CHUNK = 1024
#: Staging buffers: how many chunks the thread may draw ahead of the writes.
STAGING_BUFFERS = 3


def check_refill(mode: str, chunk: int) -> None:
    """Raise :class:`~planetnav_env.errors.InvalidParameterError` naming a bad ``refill`` or chunk size."""
    if mode not in REFILL_MODES:
        raise InvalidParameterError(f"refill must be one of {list(REFILL_MODES)}, got {mode!r}")
    require_count("refill_chunk", chunk)


@dataclass
class _Staging:
    """A host buffer of one chunk: tensors (pinned on a GPU) and the numpy views the drawing writes."""

    tensors: list[torch.Tensor]  # f, p, rng (int64), eph: the bank tensors' dtypes
    rows: BankRows  # numpy views of ``tensors`` (rng viewed as uint64)
    start: int = -1  # first global episode drawn into it
    count: int = 0
    copied: torch.cuda.Event | None = None  # set when its copy to the device is enqueued


class BankRefill:
    """Refills ``bank_tensors`` (the bank's slots as the autoreset reads them: f, p, rng as int64, eph) and
    ``passes`` ((M,) int64: the pass each slot holds) with ``bank``'s next global episodes, freed by the
    rows' ``episode_count`` ((N,) int64), per ``mode`` (module docstring). ``chunk``: slots per write."""

    def __init__(
        self,
        bank: EpisodeBank,
        bank_tensors: list[torch.Tensor],
        passes: torch.Tensor,
        episode_count: torch.Tensor,
        mode: str = "thread",
        chunk: int = DEFAULT_CHUNK,
    ) -> None:
        check_refill(mode, chunk)
        self.bank, self.mode = bank, mode
        self.size, self.num_rows = bank.size, bank.num_rows
        self.chunk = int(min(chunk, bank.size))
        self._dst, self._passes, self._count = bank_tensors, passes, episode_count
        self._cuda = passes.is_cuda
        #: The next global episode to write into the bank (pass 0 is written by ``reset``).
        self.written = bank.next_episode
        # The host's copy of the episode counts: read synchronously now (once, at reset), then refreshed
        # by poll (asynchronously on a GPU).
        self._counts = episode_count.cpu().numpy().copy()
        self._counts_host = torch.empty(episode_count.shape, dtype=episode_count.dtype, pin_memory=self._cuda)
        self._counts_copied: torch.cuda.Event | None = None
        self._error: BaseException | None = None
        self._thread: threading.Thread | None = None
        if mode == "off":
            return
        self._free: queue.Queue[_Staging] = queue.Queue()
        self._ready: queue.Queue[_Staging] = queue.Queue()
        self._head: _Staging | None = None  # drawn, not yet written (its slots not free yet)
        self._in_flight: list[_Staging] = []  # written, copy maybe still running
        for _ in range(STAGING_BUFFERS if mode == "thread" else 1):
            self._free.put(self._staging())
        if mode == "thread":
            self._stop = threading.Event()
            self._thread = threading.Thread(target=self._produce, name="planetnav-bank-refill", daemon=True)
            self._thread.start()

    # --- the host side of the buffers ---
    def _staging(self) -> _Staging:
        tensors = [
            torch.empty((self.chunk, *d.shape[1:]), dtype=d.dtype, pin_memory=self._cuda) for d in self._dst
        ]
        f, p, rng, eph = (t.numpy() for t in tensors)
        return _Staging(tensors, BankRows(f=f, p=p, rng=rng.view(np.uint64), eph=eph))

    def _next_count(self, start: int) -> int:
        """Slots of the chunk that starts at global episode ``start`` (it stops at the bank's end)."""
        return min(self.chunk, self.size - start % self.size)

    def _draw(self, buf: _Staging, start: int) -> _Staging:
        count = self._next_count(start)
        self.bank.draw(start, BankRows(*(a[:count] for a in buf.rows)))
        buf.start, buf.count = start, count
        return buf

    def _produce(self) -> None:
        """The thread: draw chunk after chunk, in order, as staging buffers come free."""
        start = self.bank.next_episode
        try:
            while not self._stop.is_set():
                try:
                    buf = self._free.get(timeout=0.05)
                except queue.Empty:
                    continue
                self._ready.put(self._draw(buf, start))
                start += buf.count
        except BaseException as exc:  # surfaced by the next poll, in the stepping thread
            self._error = exc

    # --- the device side ---
    def _free_to_write(self, start: int, count: int) -> bool:
        """Whether every row has started the episodes that slots ``start .. start + count - 1`` (global
        numbering) held: global episode ``g - M`` was row ``(g - M) mod N``'s episode ``(g - M) // N``."""
        prev = np.arange(start - self.size, start - self.size + count)
        return bool(np.all(self._counts[prev % self.num_rows] > prev // self.num_rows))

    def _write(self, buf: _Staging) -> None:
        """Enqueue the copy of ``buf`` into its slots and mark their pass (asynchronous on a GPU)."""
        s0, c = buf.start % self.size, buf.count
        for dst, src in zip(self._dst, buf.tensors, strict=True):
            dst[s0 : s0 + c].copy_(src[:c], non_blocking=True)
        self._passes[s0 : s0 + c].fill_(buf.start // self.size)
        if self._cuda:
            buf.copied = torch.cuda.Event()
            buf.copied.record()
        self.written = buf.start + c
        self._in_flight.append(buf)

    def _recycle(self, wait: bool = False) -> None:
        """Staging buffers whose copies have finished go back to the thread (``wait``: wait for them)."""
        keep = []
        for buf in self._in_flight:
            if buf.copied is not None and not buf.copied.query():
                if not wait:
                    keep.append(buf)
                    continue
                buf.copied.synchronize()
            buf.copied = None
            self._free.put(buf)
        self._in_flight = keep

    def _refresh_counts(self, wait: bool) -> None:
        """The host's copy of the episode counts: the last finished copy (``wait``: the current counts)."""
        if wait or not self._cuda:
            self._counts[:] = self._count.cpu().numpy()
            self._counts_copied = None
            return
        if self._counts_copied is not None:
            if not self._counts_copied.query():
                return
            self._counts[:] = self._counts_host.numpy()
        self._counts_host.copy_(self._count, non_blocking=True)
        self._counts_copied = torch.cuda.Event()
        self._counts_copied.record()

    def _check(self) -> None:
        if self._error is not None:
            raise RuntimeError(f"the bank's refill thread failed: {self._error!r}") from self._error

    def poll(self) -> None:
        """Before an autoreset: write what is drawn and free, per the mode (``inline`` draws it here)."""
        if self.mode == "off":
            return
        if self.mode == "inline":
            self._catch_up()
            return
        self._check()
        self._recycle()
        self._refresh_counts(wait=False)
        while True:
            if self._head is None:
                try:
                    self._head = self._ready.get_nowait()
                except queue.Empty:
                    return
            if not self._free_to_write(self._head.start, self._head.count):
                return
            self._write(self._head)
            self._head = None

    def _catch_up(self) -> None:
        """Draw (inline) or wait for (thread) and write every chunk whose slots are free now."""
        self._refresh_counts(wait=True)
        while True:
            start = self.written
            if not self._free_to_write(start, self._next_count(start)):
                return
            if self.mode == "inline":
                self._recycle(wait=True)
                buf = self._draw(self._free.get_nowait(), start)
            else:
                buf = self._head
                while buf is None:
                    self._check()
                    self._recycle(wait=True)  # the thread may be waiting for a buffer
                    try:
                        buf = self._ready.get(timeout=0.05)
                    except queue.Empty:
                        continue
                self._head = None
            self._write(buf)

    def flush(self) -> None:
        """Write every chunk whose slots are free now, waiting for the drawing and the counts (thread mode:
        catch up; inline: what every step does; off: nothing)."""
        if self.mode != "off":
            self._catch_up()
            self._recycle(wait=True)

    def close(self) -> None:
        """Stop the thread (idempotent)."""
        if self._thread is not None:
            self._stop.set()
            self._thread.join()
            self._thread = None
