"""The observation blocks the CPU writes in Python after the compiled step, as masked torch operations.

:class:`~planetnav_env.core.batch.BatchCore` fills four optional blocks of the observation outside the
compiled step, with the numpy functions of :mod:`planetnav_env.core.decisions` on the rows it stepped
(``since_measured``, ``image_log``, ``residual_log``) and ``_observe_position_correlation``. The device
env keeps its state on the GPU, so it does the same arithmetic on torch tensors, written without index
lists: every function takes a bool (N,) ``mask`` of the rows to update and leaves the other rows' values
as they were (``torch.where``, ``masked_fill_``, or an added 0.0), so nothing waits on the host (a
boolean index would read the count of rows back to the host every step).

The arithmetic is the numpy functions', operation for operation (an increment of a count, ``x + 0.0``
for the rows a count does not reach, leaves it as it was: counts and NIS sums are non-negative), so on the
CPU these give the CPU env's numbers bit for bit; ``tests/env/test_device_env.py`` holds them to
:mod:`~planetnav_env.core.decisions` and to the CPU vector env. ``log1p`` and ``sqrt`` are passed in:
on the CPU the C library's log1p (:func:`planetnav_env.numerics.portable_math.log1p`) and numpy's sqrt,
since torch's float64 ``sqrt`` on an AVX-512 CPU is not correctly rounded (torch 2.13: some
values one ulp off, where numpy's and the C library's are exact); on the device ``torch.log1p``, which may
differ from the C library's in the last bit before the float32 rounding of the observation, and
``torch.sqrt``, which CUDA rounds correctly.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import torch

from planetnav_env.core import layout as L
from planetnav_env.core.decisions import _SINCE_LOG_SCALE, RESIDUAL_CAP

#: An elementwise float64 function (``log1p``, ``sqrt``) chosen by the backend (see above).
Elementwise = Callable[[torch.Tensor], torch.Tensor]


class BlockMath(Protocol):
    """The elementwise functions a backend hands the blocks (see above)."""

    def log1p(self, t: torch.Tensor) -> torch.Tensor: ...

    def sqrt(self, t: torch.Tensor) -> torch.Tensor: ...


def target_onehot(target: torch.Tensor, width: int, columns: torch.Tensor | None = None) -> torch.Tensor:
    """(N, width) bool: column ``target[n]`` of each row, none where the target is outside ``0 .. width - 1``
    (-1: none; a pulsar's index for a block of planets). ``columns``: ``arange(width)`` if already made.
    The env builds it once a physics step and the blocks share it."""
    if columns is None:
        columns = torch.arange(width, device=target.device)
    return columns[None, :] == target[:, None]


def _write(obs: torch.Tensor, lo: int, hi: int | None, values: torch.Tensor, mask: torch.Tensor) -> None:
    """``obs[mask, lo:hi] = values[mask]`` without an index list."""
    block = obs[:, lo:hi]
    block.copy_(torch.where(mask[:, None], values.to(obs.dtype), block))


def advance_since(since: torch.Tensor, measured: torch.Tensor, hot: torch.Tensor, mask: torch.Tensor) -> None:
    """:func:`~planetnav_env.core.decisions.advance_since_measured` of the ``mask`` rows, in place: one
    more physics step [steps] since each target was measured, 0 for the one measured now (``hot``: the
    targets' one-hot, :func:`target_onehot`)."""
    since.add_(mask.to(since.dtype)[:, None])
    since.masked_fill_(hot & (measured & mask)[:, None], 0.0)


def since_values(since: torch.Tensor, log1p: Elementwise) -> torch.Tensor:
    """:func:`~planetnav_env.core.decisions.since_measured_values`: (N, T) float32."""
    finite = torch.isfinite(since)
    scaled = log1p(torch.where(finite, since, 0.0)) / _SINCE_LOG_SCALE
    return torch.where(finite, torch.clamp(scaled, max=1.0), 1.0).to(torch.float32)


def advance_image_log(
    log: torch.Tensor, fixed: torch.Tensor, failed: torch.Tensor, hot: torch.Tensor, mask: torch.Tensor
) -> None:
    """:func:`~planetnav_env.core.decisions.advance_image_log` of the ``mask`` rows, in place (counts;
    ``hot``: the targets' one-hot over the planets)."""
    fix = (hot & (fixed & mask)[:, None]).to(log.dtype)
    fail = (hot & (failed & mask)[:, None]).to(log.dtype)
    log[:, 0] += fix + fail  # whole counts: the sum is exact
    log[:, 1] += fix


def image_log_values(log: torch.Tensor, log1p: Elementwise) -> torch.Tensor:
    """:func:`~planetnav_env.core.decisions.image_log_values`: (N, 2, P) float32."""
    images, fixes = log[:, 0], log[:, 1]
    mean = (fixes + 1.0) / (images + 2.0)
    scaled = torch.clamp(log1p(images) / _SINCE_LOG_SCALE, max=1.0)
    return torch.stack([mean, scaled], dim=1).to(torch.float32)


def advance_residual_log(
    log: torch.Tensor, fixed: torch.Tensor, nis_norm: torch.Tensor, hot: torch.Tensor, mask: torch.Tensor
) -> None:
    """:func:`~planetnav_env.core.decisions.advance_residual_log` of the ``mask`` rows, in place (``hot``:
    the targets' one-hot)."""
    hit = hot & (fixed & mask & torch.isfinite(nis_norm))[:, None]
    log[:, 0] += hit.to(log.dtype)
    log[:, 1] += torch.where(hit, nis_norm[:, None], 0.0)


def residual_log_values(log: torch.Tensor) -> torch.Tensor:
    """:func:`~planetnav_env.core.decisions.residual_log_values`: (N, T) float32."""
    mean = (log[:, 1] + 2.0) / (log[:, 0] + 2.0)
    return (torch.clamp(mean, max=RESIDUAL_CAP) / RESIDUAL_CAP).to(torch.float32)


def position_correlation_values(p: torch.Tensor, sqrt: Elementwise) -> torch.Tensor:
    """``BatchCore._observe_position_correlation``'s values: (N, 3) rho_xy, rho_xz, rho_yz of ``P_rr``."""
    prr = p[:, :3, :3]
    sigma = sqrt(torch.diagonal(prr, dim1=1, dim2=2))
    rho = prr / (sigma[:, :, None] * sigma[:, None, :])
    values = torch.stack([rho[:, 0, 1], rho[:, 0, 2], rho[:, 1, 2]], dim=1)
    return torch.clamp(values, -1.0, 1.0)


class ObservationBlocks:
    """The Python-side blocks of one configuration's observation on ``N`` rows of torch state: their
    counters (``since`` (N, T) [steps], ``image_log`` (N, 2, P), ``residual_log`` (N, 2, T)) and the calls
    the env makes: :meth:`count` after each physics step (the ``mask`` rows took it), :meth:`write` once a
    decision (the blocks of the rows it stepped, into the observation), :meth:`after_reset` (the ``mask``
    rows were reset: cleared, counted and written).

    The CPU core writes a row's blocks after each physics step; only the last write of a decision is
    observed, and a row's counters and covariance change only while it steps, so one write at the end of
    the decision gives every stepped row the values of its last step: the same numbers, with the writes'
    operations (each a kernel launch on a GPU) once a decision instead of once a physics step."""

    def __init__(self, core, num_rows: int, device: torch.device, math: BlockMath) -> None:
        cfg, lay = core.config, core.layout
        self.layout, self.math = lay, math
        n, f64 = num_rows, torch.float64
        self.since = (
            torch.full((n, cfg.n_targets), torch.inf, dtype=f64, device=device)
            if lay.since_measured
            else None
        )
        self.image_log = (
            torch.zeros((n, 2, cfg.n_planets), dtype=f64, device=device) if lay.image_log else None
        )
        self.residual_log = (
            torch.zeros((n, 2, cfg.n_targets), dtype=f64, device=device) if lay.residual_log else None
        )
        self.position_correlation = bool(lay.position_correlation)
        self.fix_dof = torch.as_tensor(core._fix_dof, dtype=f64, device=device)
        self.n_targets, self.n_planets = cfg.n_targets, cfg.n_planets
        self._columns = torch.arange(cfg.n_targets, device=device)
        self.any = any(
            (self.since is not None, self.image_log is not None, self.residual_log is not None,
             self.position_correlation)
        )  # fmt: skip

    def after_reset(self, f, p, i, obs, mask: torch.Tensor) -> None:
        """The blocks of freshly reset rows: counters cleared, then one step's count (BatchCore's order),
        written into ``obs``."""
        if self.since is not None:
            self.since.masked_fill_(mask[:, None], torch.inf)
        if self.image_log is not None:
            self.image_log.masked_fill_(mask[:, None, None], 0.0)
        if self.residual_log is not None:
            self.residual_log.masked_fill_(mask[:, None, None], 0.0)
        self.count(f, i, mask)
        self.write(p, obs, mask)

    def count(self, f, i, mask: torch.Tensor) -> None:
        """Count the last physics step of the ``mask`` rows in the counters, as ``BatchCore.step`` does for
        the rows it stepped."""
        target = i[:, L.I_TARGET]
        hot = target_onehot(target, self.n_targets, self._columns)
        if self.since is not None:
            advance_since(self.since, i[:, L.I_MEASURED] != 0, hot, mask)
        if self.image_log is not None:
            fixed = i[:, L.I_SENSOR] == L.SENSOR_CAMERA
            failed = i[:, L.I_REASON] == L.REASON_IMAGE_FAILED
            # Planets come first among the targets: their one-hot is the first n_planets columns.
            advance_image_log(self.image_log, fixed, failed, hot[:, : self.n_planets], mask)
        if self.residual_log is not None:
            dof = self.fix_dof[torch.clamp(target, 0, self.fix_dof.shape[0] - 1)]
            advance_residual_log(self.residual_log, i[:, L.I_SENSOR] != L.SENSOR_NONE, f[:, L.F_NIS] / dof,
                                 hot, mask)  # fmt: skip

    def write(self, p, obs, mask: torch.Tensor) -> None:
        """Write the blocks of the ``mask`` rows into ``obs`` (N, D) float64 (the state's observation) from
        their counters and covariance ``p``."""
        lay = self.layout
        if self.since is not None:
            values = since_values(self.since, self.math.log1p)
            _write(obs, lay.since_measured_start, lay.image_log_start, values, mask)
        if self.image_log is not None:
            values = image_log_values(self.image_log, self.math.log1p).reshape(obs.shape[0], -1)
            _write(obs, lay.image_log_start, lay.residual_log_start, values, mask)
        if self.residual_log is not None:
            _write(obs, lay.residual_log_start, None, residual_log_values(self.residual_log), mask)
        if self.position_correlation:
            values = position_correlation_values(p, self.math.sqrt)
            _write(obs, lay.position_correlation_start, None, values, mask)
