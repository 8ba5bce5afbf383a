"""DeviceVectorEnv: N environment rows whose state stays on a GPU, stepped by the core's CUDA kernels.

    env = DeviceVectorEnv("planetnav/Cruise-Target-v1", num_envs=2**16, device="cuda")
    obs, info = env.reset(seed=0)                 # obs: (N, D) float32 torch tensor on the device
    obs, reward, terminated, truncated, info = env.step(actions)   # actions: a device tensor

Its own class, not ``gym.make_vec(id, num_envs=N, device="cuda")``: Gymnasium's ``VectorEnv`` contract is
numpy arrays (its wrappers, ``batch_space`` samples and checkers read them on the host), and this env
returns torch tensors on the device and takes them, as gymnax, Isaac Lab and PufferLib's device envs do.
It keeps the rest of the vector env's interface: ``num_envs``, ``single_observation_space``,
``single_action_space``, ``reset(seed=...)``, ``reset(options={"reset_mask": mask})`` (the ``mask`` rows
start their next episode), ``step(actions)`` returning ``(obs, reward, terminated, truncated, info)``,
``autoreset_mode`` ``"next_step"`` (Gymnasium's default) or ``"same_step"`` (the finished rows' last
observations in ``info["final_obs"]``).

Where things run. On the device: the physics step and the compiled part of the reset
(:mod:`planetnav_env.core.cuda_entry`, :mod:`planetnav_env.device.cuda_kernels`, one thread per row), the
autoreset (a bank row copied in, then the compiled reset, for the rows a mask marks), the decision (one
launch: each thread runs the CPU's compiled decision rule over ``decision_steps`` physics steps and sums
their rewards, after decoding each row's raw action by the CPU's compiled rule,
:mod:`planetnav_env.core.decoding`) and the float32 observation
(every block written by the compiled kernels, :mod:`planetnav_env.core.observation`, as on the CPU). On
the host, once per ``reset(seed=...)``: the episode bank (:mod:`planetnav_env.device.bank`), and on a host
thread its refill (:mod:`planetnav_env.device.refill`). A step copies nothing between host and device but the
refill's asynchronous writes and its asynchronous read of the episode counts, and nothing waits on the
device: the state, the buffers and the bank are torch tensors, and numba-cuda reads them without a copy
(``numba.cuda.as_cuda_array``, the ``__cuda_array_interface__``).

What differs from the CPU vector env (``gym.make_vec``):

* resets come from a bank of ``bank_size`` pre-drawn episodes (:mod:`~planetnav_env.device.bank`): row
  ``n``'s ``e``-th episode is the CPU vector env's row ``n``'s ``e``-th (same seed), taken from slot
  ``(e N + n) mod bank_size``. ``reset(seed=...)`` draws the first ``bank_size`` of them; the refill
  (:mod:`~planetnav_env.device.refill`, ``refill=``) draws the next ones on the host while the rows step.
  A row that reaches a slot before the refill has written it starts the episode the slot still holds, a
  *substitute* (another row's, or one played before), counted per row in ``substituted``
  (:meth:`DeviceVectorEnv.bank_stats`). ``refill="inline"`` never lets that happen while rows stay within
  a bank of each other (the step waits for the drawing); ``"thread"`` (the default) never waits, so it
  substitutes when the rows start episodes faster than one host thread draws them; ``"off"`` cycles the
  first bank. With a bank smaller than ``N`` rows share their first episodes;
* actions are not validated (a check would read a flag back to the host every step): a target action
  outside the action space is taken modulo the targets, Box actions are clipped to [-1, 1] as on the CPU,
  NaN is not caught;
* a row whose attitude or camera geometry becomes invalid is not raised as ``NonFiniteError`` at the step:
  :meth:`DeviceVectorEnv.check_status` reads the status codes (a host read) when called;
* ``info`` holds tensors of a few numeric keys (:meth:`DeviceVectorEnv.info_tensors`), not the CPU env's
  full info;
* only ``observation="box"`` configurations.

What stays equal: the configuration, spaces, physics and observation; on the CPU (``device="cpu"``, the
host mode: numpy state viewed by torch CPU tensors, the thread functions run row by row on the CPU) the
rows equal the CPU vector env's bit for bit, autoresets included, for every row that has started no
substitute (``tests/env/test_device_env.py``). On a GPU the numbers are expected to differ from the
CPU's in the last bits where NVVM fuses a multiply and an add or where libdevice's functions differ from
glibc's (docs/architecture.md, "Two targets"): :mod:`planetnav_env.device.parity` states the tolerance
the benchmark's parity check holds them to on a device.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

import numpy as np
import torch

from planetnav_env.batch import BatchCore
from planetnav_env.config import EnvConfig
from planetnav_env.core import layout as L
from planetnav_env.core.records import (
    Actions,
    CoreParams,
    RowState,
    make_scratch,
    map_arrays,
    rows_innermost,
    scratch_rows,
)
from planetnav_env.device import rows as R
from planetnav_env.device.bank import BankRows, EpisodeBank, global_episode
from planetnav_env.device.draw_pool import DrawPool
from planetnav_env.device.occupancy import SM_90, THREADS_PER_BLOCK
from planetnav_env.device.refill import DEFAULT_CHUNK, BankRefill, check_refill
from planetnav_env.envs.env import check_reset_options, resolve_config
from planetnav_env.envs.spaces import action_size, action_space, observation_space
from planetnav_env.errors import InvalidParameterError, require_count

#: ``autoreset_mode`` choices.
AUTORESET_MODES = ("next_step", "same_step")


def check_launch(threads_per_block: int, max_registers: int | None) -> None:
    """Raise :class:`InvalidParameterError` naming a block size or register cap no CUDA device takes (a block
    size the kernels' registers do not fit is named at the first launch, when they are known)."""
    most_threads, most_regs = SM_90.max_threads_per_block, SM_90.max_regs_per_thread
    if require_count("threads_per_block", threads_per_block) > most_threads:
        raise InvalidParameterError(
            f"threads_per_block must be at most {most_threads}, got {threads_per_block}"
        )
    if max_registers is not None and not 16 <= require_count("max_registers", max_registers) <= most_regs:
        raise InvalidParameterError(
            f"max_registers must be in [16, {most_regs}] (or None: no cap), got {max_registers}"
        )


def cuda_unavailable_reason() -> str | None:
    """Why this process cannot run the device env on CUDA (None: it can): numba-cuda missing, torch without
    CUDA, or no device visible."""
    try:
        from planetnav_env.numerics.cuda_target import require_numba_cuda

        cuda = require_numba_cuda()
    except ImportError as exc:
        return f"numba-cuda is not installed ({exc})"
    if not torch.cuda.is_available():
        return f"torch {torch.__version__} sees no CUDA device (a CPU-only torch build, or no GPU/driver)"
    if not cuda.is_available():
        return "numba-cuda finds no CUDA driver or device"
    return None


def launch_errors() -> tuple[type[BaseException], ...]:
    """The exception classes a numba-cuda kernel launch raises for a driver error: numba-cuda's own
    ``CudaAPIError`` (its driver wrapper: loading the module, context calls) and, from numba-cuda 0.30 on,
    where the launch itself goes through ``cuda.core.launch``, cuda.core's ``CUDAError`` (a launch out of
    resources, too many threads a block)."""
    from numba.cuda.cudadrv.driver import CudaAPIError

    errors: list[type[BaseException]] = [CudaAPIError]
    try:  # cuda.core keeps it in a private module (re-exported by its cu12 and cu13 builds under this name)
        from cuda.core._utils.cuda_utils import CUDAError
    except ImportError:  # an older numba-cuda, launching through its own driver wrapper only
        pass
    else:
        errors.append(CUDAError)
    return tuple(errors)


class _Host:
    """Host mode: numpy arrays viewed by torch CPU tensors; the thread functions looped on the CPU."""

    kind = "cpu"

    def __init__(self) -> None:
        self.device = torch.device("cpu")

    def zeros(self, shape: tuple, dtype: np.dtype) -> tuple[torch.Tensor, np.ndarray]:
        """Zeros of ``shape``, rows (the first axis) innermost in memory (the device's layout)."""
        a = rows_innermost(shape, dtype)
        return torch.from_numpy(a.view(np.int64) if a.dtype == np.uint64 else a), a

    def upload(self, a: np.ndarray) -> tuple[torch.Tensor, np.ndarray]:
        a = np.ascontiguousarray(a)
        return torch.from_numpy(a.view(np.int64) if a.dtype == np.uint64 else a), a

    def params(self, prm: CoreParams) -> CoreParams:
        return prm

    def scratch(self, prm: CoreParams, n: int) -> Any:
        return scratch_rows(prm, n)  # zeros, rows innermost

    def step(self, prm, st, act, scratch) -> None:
        R.step_rows(prm, st, act, scratch)

    def autoreset(self, prm, st, bank, slots, mask, scratch) -> None:
        R.autoreset_rows(prm, st, bank, slots, mask, scratch)

    def kernel_registers(self) -> dict[str, int]:
        """No CUDA kernels in host mode."""
        return {}


class _Cuda:
    """CUDA mode: torch tensors on the device, read by numba-cuda without a copy; the kernels launched
    one thread per row."""

    kind = "cuda"

    def __init__(self, device: str, threads_per_block: int, max_registers: int | None) -> None:
        why = cuda_unavailable_reason()
        if why is not None:
            raise RuntimeError(
                f"DeviceVectorEnv(device={device!r}) needs a CUDA GPU, numba-cuda and a CUDA build of torch: "
                f'{why}. Install with pip install -e ".[gpu]" on a machine with a GPU, or use device="cpu"'
            )
        from numba import cuda

        from planetnav_env.device import cuda_kernels

        self.cuda, self._api_error = cuda, launch_errors()
        self.device = torch.device(device)
        self.tpb = int(threads_per_block)
        self.kernels = cuda_kernels.dispatchers(max_registers)

    def zeros(self, shape: tuple, dtype: np.dtype) -> tuple[torch.Tensor, Any]:
        """Zeros of ``shape`` on the device, rows (the first axis) innermost in memory
        (:func:`~planetnav_env.core.records.rows_innermost`: a warp's accesses to one column coalesce)."""
        tdtype = torch.int64 if np.dtype(dtype) == np.uint64 else torch.from_numpy(np.zeros(0, dtype)).dtype
        t = torch.zeros((*shape[1:], shape[0]), dtype=tdtype, device=self.device).movedim(-1, 0)
        return t, self._as(t, dtype)

    def upload(self, a: np.ndarray) -> tuple[torch.Tensor, Any]:
        host = torch.from_numpy(np.ascontiguousarray(a.view(np.int64) if a.dtype == np.uint64 else a))
        t = host.to(self.device)
        return t, self._as(t, a.dtype)

    def _as(self, t: torch.Tensor, dtype: np.dtype) -> Any:
        view = self.cuda.as_cuda_array(t)
        return view.view(np.uint64) if np.dtype(dtype) == np.uint64 else view

    def params(self, prm: CoreParams) -> CoreParams:
        return map_arrays(self.cuda.to_device, prm)

    def scratch(self, prm: CoreParams, n: int) -> Any:
        # Zeroed as the host mode's (torch.zeros; a device_array is not): no row kernel reads scratch it
        # has not written (tests/env/test_device_scratch.py), and zeros keep a bug of that kind repeatable.
        one = make_scratch(prm)
        self._scratch_tensors = []
        views = {}
        for k, a in one._asdict().items():
            t, views[k] = self.zeros((n, *a.shape), a.dtype)
            self._scratch_tensors.append(t)  # keeps the memory alive
        return type(one)(**views)

    def _grid(self, n: int) -> tuple[int, int]:
        return (n + self.tpb - 1) // self.tpb, self.tpb

    def _launch(self, name: str, n: int, *args: Any) -> None:
        kernel = getattr(self.kernels, name)
        try:
            kernel[self._grid(n)](*args)
        except self._api_error:
            self._explain_launch_failure(name, kernel)
            raise

    def _explain_launch_failure(self, name: str, kernel: Any) -> None:
        """A block too large for the kernel's registers fails at the launch with the driver's terse code;
        name the setting instead (only when that is the cause)."""
        from planetnav_env.device.occupancy import SM_LIMITS, require_launchable

        limits = SM_LIMITS.get(tuple(self.cuda.get_current_device().compute_capability))
        for overload in list(kernel.overloads.values()) if limits is not None else []:
            require_launchable(f"the {name} kernel", overload.regs_per_thread, self.tpb, limits)

    def step(self, prm, st, act, scratch) -> None:
        self._launch("step", st.f.shape[0], prm, st, act, scratch)

    def autoreset(self, prm, st, bank, slots, mask, scratch) -> None:
        self._launch("autoreset", st.f.shape[0], prm, st, bank, slots, mask, scratch)

    def kernel_registers(self) -> dict[str, int]:
        """Registers per thread of each kernel compiled so far (the device's own assembly)."""
        out = {}
        for name in self.kernels._fields:
            for overload in getattr(self.kernels, name).overloads.values():
                out[name] = int(overload.regs_per_thread)
        return out


class DeviceVectorEnv:
    """``num_envs`` rows on ``device`` ("cuda", "cuda:k", or "cpu": the host mode), see the module
    docstring. ``config``: a registered id, an ``EnvConfig`` or a mapping of options; ``overrides`` as
    ``gym.make_vec`` takes them. ``bank_size``: the bank's slots, episodes drawn by ``reset`` (default
    ``2 N``). ``refill``: ``"thread"``, ``"inline"`` or ``"off"`` (:mod:`~planetnav_env.device.refill`);
    ``refill_chunk``: slots the refill writes at a time. ``bank_workers``: processes that draw the bank
    (:mod:`~planetnav_env.device.draw_pool`; 0: the refill's thread draws in this process). Default: 0 in
    host mode; on CUDA the CPUs but one, at most 8, so that drawing never holds the interpreter lock the
    kernel launches need. On CUDA only: ``threads_per_block`` (at most 1024; the kernels' registers may
    allow fewer, named at the first launch) and ``max_registers`` (a cap on the kernels' registers per
    thread: more resident warps, paid in spills; :mod:`~planetnav_env.device.occupancy`). Every env of a
    process with the same ``max_registers`` shares one compilation of the kernels
    (:func:`~planetnav_env.device.cuda_kernels.dispatchers`)."""

    def __init__(
        self,
        config: EnvConfig | Mapping | str | None = None,
        num_envs: int = 1,
        device: str = "cuda",
        bank_size: int | None = None,
        autoreset_mode: str = "next_step",
        threads_per_block: int = THREADS_PER_BLOCK,
        refill: str = "thread",
        refill_chunk: int = DEFAULT_CHUNK,
        bank_workers: int | None = None,
        max_registers: int | None = None,
        **overrides: Any,
    ) -> None:
        require_count("num_envs", num_envs)
        check_launch(threads_per_block, max_registers)
        if autoreset_mode not in AUTORESET_MODES:
            raise InvalidParameterError(
                f"autoreset_mode must be one of {list(AUTORESET_MODES)}, got {autoreset_mode!r}"
            )
        check_refill(refill, refill_chunk)
        if bank_workers is not None:
            require_count("bank_workers", bank_workers, minimum=0)
        self.refill_mode, self.refill_chunk = refill, int(refill_chunk)
        cfg = resolve_config(config, overrides)
        if cfg.observation != "box":
            raise InvalidParameterError(
                f"the device env returns box observations only, got observation={cfg.observation!r}"
            )
        self.config, self.autoreset_mode = cfg, autoreset_mode
        self.num_envs = n = int(num_envs)
        self.bank_size = require_count("bank_size", bank_size) if bank_size is not None else 2 * n
        dev = str(device)
        self.backend = _Host() if dev == "cpu" else _Cuda(dev, threads_per_block, max_registers)
        self.device = self.backend.device
        # One row of the core: its parameters, layout and drawing code (the bank's), not its state.
        self.core = core = BatchCore(cfg, 1)
        self.layout = core.layout
        self.single_action_space = action_space(cfg)
        self.single_observation_space = observation_space(cfg, self.layout)
        be = self.backend
        self._prm = be.params(core.params)
        self._scratch = be.scratch(core.params, n)
        (self.f, f), (self.p, p), (self.i, i) = (
            be.zeros((n, *a.shape[1:]), a.dtype) for a in (core.f, core.p, core.i)
        )
        (self._rng, rng), (self.eph, eph), (self._obs64, obs) = (
            be.zeros((n, *a.shape[1:]), a.dtype) for a in (core.rng, core.eph, core.obs)
        )
        self._state = RowState(f=f, p=p, i=i, rng=rng, eph=eph, obs=obs)
        dev_ = self.device
        self.obs = torch.zeros((n, self.layout.size), dtype=torch.float32, device=dev_)
        self.final_obs = torch.zeros_like(self.obs) if autoreset_mode == "same_step" else None
        self._raw, raw = be.zeros((n, action_size(self.single_action_space)), np.float64)
        _, targets = be.zeros((n,), np.int64)  # the decoding, written by the step kernel
        _, torques = be.zeros((n, 3), np.float64)
        self._active, active = be.zeros((n,), np.bool_)
        self._act = Actions(raw=raw, targets=targets, torques=torques, active=active)
        self._slots, self._slots_view = be.zeros((n,), np.int64)
        self._mask, self._mask_view = be.zeros((n,), np.bool_)
        self._rows = torch.arange(n, device=dev_)
        self.episode_count = torch.zeros(n, dtype=torch.int64, device=dev_)
        self._needs_reset = torch.zeros(n, dtype=torch.bool, device=dev_)
        self._all = torch.ones(n, dtype=torch.bool, device=dev_)
        #: Per row: episodes started that were not the row's own (substitutes, see the module docstring).
        self.substituted = torch.zeros(n, dtype=torch.int64, device=dev_)
        self._passes = torch.zeros(self.bank_size, dtype=torch.int64, device=dev_)
        self.bank: EpisodeBank | None = None
        self._bank: BankRows | None = None
        self.refill: BankRefill | None = None
        if bank_workers is None:
            bank_workers = 0 if self.backend.kind == "cpu" else max(1, min(8, (os.cpu_count() or 2) - 1))
        self.bank_workers = int(bank_workers)
        self._pool = DrawPool(cfg, self.bank_workers) if self.bank_workers > 0 else None

    # ------------------------------------------------------------------------------------------
    def bytes_per_row(self) -> int:
        """Device bytes of one row: state, scratch and buffers (the bank not included)."""
        state = sum(t.nbytes for t in (self.f, self.p, self.i, self._rng, self.eph, self._obs64, self.obs))
        scratch = sum(int(np.prod(a.shape)) * np.dtype(a.dtype).itemsize for a in self._scratch)
        return (state + scratch) // self.num_envs

    def reset(self, *, seed: int | list[int | None] | None = None, options: dict | None = None):
        """Draw the bank (seeded as the CPU vector env seeds its rows: ``seed + n``) and start every row
        on its first bank episode. Returns ``(obs, info)``.

        ``options={"reset_mask": mask}`` (bool (N,), a tensor on any device or an array), after a first
        reset: only the ``mask`` rows start their next bank episode, as an autoreset does, on the device;
        the bank is kept, so ``seed`` must be None. Row ``n``'s next episode is the one the CPU vector
        env's row ``n`` starts on the same call (its generator continues there too)."""
        check_reset_options(options, ("reset_mask",), "DeviceVectorEnv")
        if options and "reset_mask" in options:
            return self._reset_rows(options["reset_mask"], seed)
        n, be = self.num_envs, self.backend
        if self.refill is not None:
            self.refill.close()
        self.bank = EpisodeBank.for_vector_env(self.core, n, self.bank_size, seed, self._pool)
        uploaded = [be.upload(a) for a in self.bank.rows]
        self._bank_tensors = [t for t, _ in uploaded]  # keeps the device copies alive
        self._bank = BankRows(*(v for _, v in uploaded))
        self._passes.zero_()
        self.episode_count.zero_()
        self.substituted.zero_()
        self._autoreset(self._all)
        self._needs_reset.zero_()
        self.refill = BankRefill(
            self.bank, self._bank_tensors, self._passes, self.episode_count,
            self.refill_mode, self.refill_chunk,
        )  # fmt: skip
        self.obs.copy_(self._obs64)
        return self.obs, self.info_tensors()

    def _reset_rows(self, mask: Any, seed: Any) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
        if self._bank is None:
            raise RuntimeError("call reset(seed=...) (every row) before reset(options={'reset_mask': ...})")
        if seed is not None:
            raise InvalidParameterError(
                f"DeviceVectorEnv.reset: seed={seed!r} with reset_mask; the rows' next episodes come from "
                "the bank that reset(seed=...) drew, so a partial reset takes no seed"
            )
        m = torch.as_tensor(mask, device=self.device)
        if m.dtype != torch.bool or tuple(m.shape) != (self.num_envs,):
            raise InvalidParameterError(
                f"reset_mask must be a bool tensor or array of shape ({self.num_envs},), got dtype "
                f"{m.dtype} and shape {tuple(m.shape)}"
            )
        self.refill.poll()
        self._autoreset(m)
        self._needs_reset &= ~m
        self.obs.copy_(self._obs64)
        return self.obs, self.info_tensors()

    def _autoreset(self, mask: torch.Tensor) -> None:
        """Rows ``mask`` start their next bank episode (on the device, whatever the mask); a row whose slot
        does not hold its own episode's pass counts a substitute."""
        g = global_episode(self.episode_count, self._rows, self.num_envs)
        self._slots.copy_(g % self.bank_size)
        own = self._passes[self._slots] == g // self.bank_size
        self.substituted += mask & ~own
        self._mask.copy_(mask)
        self.backend.autoreset(
            self._prm, self._state, self._bank, self._slots_view, self._mask_view, self._scratch
        )
        self.episode_count += mask

    def _load(self, actions: torch.Tensor) -> None:
        """Actions (a tensor on the env's device, unchecked) into the raw action buffer as float64; the
        step kernel's threads decode them (:mod:`planetnav_env.core.decoding`, the CPU's own rule)."""
        a = torch.as_tensor(actions, device=self.device)
        self._raw.copy_(a.reshape(self._raw.shape))

    def _advance(self, active: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """One decision of the ``active`` rows: one launch of the step kernel, whose threads run the
        compiled decision rule (``kernels.decide_row``, the CPU's own: the hold of ``decision_steps``
        physics steps, the reward sum, a row that ends inside the hold stopping there); (reward,
        terminated, truncated)."""
        f, i = self.f, self.i
        self._active.copy_(active)
        self.backend.step(self._prm, self._state, self._act, self._scratch)
        reward = torch.where(active, f[:, L.F_REWARD], 0.0)
        terminated = (i[:, L.I_TERMINATED] != 0) & active
        truncated = (i[:, L.I_TRUNCATED] != 0) & active
        return reward, terminated, truncated

    def step(self, actions: torch.Tensor):
        """One decision of every row with ``actions`` ((N,) target actions or (N, A) Box actions, a tensor
        on the env's device); autoreset per ``autoreset_mode``. Returns ``(obs, reward, terminated,
        truncated, info)``: ``obs`` (N, D) float32 (the env's buffer, overwritten by the next step),
        ``reward`` (N,) float64, ``terminated`` / ``truncated`` (N,) bool, all on the device."""
        if self._bank is None:
            raise RuntimeError("call reset() before step()")
        self.refill.poll()
        self._load(actions)
        if self.autoreset_mode == "next_step":
            needs = self._needs_reset
            self._autoreset(needs)
            active = ~needs
        else:
            active = self._all
        reward, terminated, truncated = self._advance(active)
        done = terminated | truncated
        info = self.info_tensors()
        if self.autoreset_mode == "same_step":
            self.final_obs.copy_(self._obs64)
            info["final_obs"] = self.final_obs
            info["_final_obs"] = done
            self._autoreset(done)
        else:
            self._needs_reset = done
        self.obs.copy_(self._obs64)
        return self.obs, reward, terminated, truncated, info

    # ------------------------------------------------------------------------------------------
    def info_tensors(self) -> dict[str, torch.Tensor]:
        """Numeric info of every row as new tensors on the device: ``pos_err_km`` [km], ``pos_sigma_km``
        [km], ``nees``, ``measured`` (bool), ``target_index`` (-1: none), ``episode`` (episodes started)."""
        f, i = self.f, self.i
        return {
            "pos_err_km": f[:, L.F_POS_ERR].clone(),
            "pos_sigma_km": f[:, L.F_POS_SIGMA].clone(),
            "nees": f[:, L.F_NEES].clone(),
            "measured": i[:, L.I_MEASURED] != 0,
            "target_index": i[:, L.I_TARGET].clone(),
            "episode": self.episode_count.clone(),
        }

    def check_status(self) -> None:
        """Raise :class:`~planetnav_env.errors.NonFiniteError` if a row's status code is not OK (reads the
        codes back to the host: call it now and then, not every step)."""
        from planetnav_env.errors import NonFiniteError

        status = self.i[:, L.I_STATUS].cpu().numpy()
        if status.any():
            bad = np.flatnonzero(status)
            raise NonFiniteError(f"rows {bad.tolist()[:20]} have status codes {status[bad][:20].tolist()}")

    def state_arrays(self) -> dict[str, np.ndarray]:
        """Copies of the state on the host (f, p, i, rng, eph, obs as the CPU core holds them): for checks."""
        rng = self._rng.cpu().numpy().view(np.uint64)
        return {"f": self.f.cpu().numpy().copy(), "p": self.p.cpu().numpy().copy(),
                "i": self.i.cpu().numpy().copy(), "rng": rng.copy(), "eph": self.eph.cpu().numpy().copy(),
                "obs": self._obs64.cpu().numpy().copy()}  # fmt: skip

    def bank_stats(self) -> dict[str, int]:
        """How the bank has served the rows since ``reset`` (reads a few numbers back to the host):
        ``episodes`` started, ``substituted`` (episodes that were not the row's own), ``drawn`` (global
        episodes drawn on the host), ``written`` (written into the bank, ``bank_size`` by ``reset``),
        ``bank_size``."""
        if self.refill is None:
            raise RuntimeError("call reset() before bank_stats()")
        return {
            "episodes": int(self.episode_count.sum()),
            "substituted": int(self.substituted.sum()),
            "drawn": self.bank.next_episode,
            "written": self.refill.written,
            "bank_size": self.bank_size,
        }

    def flush_bank(self) -> None:
        """Write every bank slot that is free now, waiting for the refill's drawing (thread mode: catch up
        at a moment of the caller's choosing)."""
        if self.refill is None:
            raise RuntimeError("call reset() before flush_bank()")
        self.refill.flush()

    def close(self) -> None:
        """Stop the refill's thread and the drawing processes (idempotent)."""
        if self.refill is not None:
            self.refill.close()
        if getattr(self, "_pool", None) is not None:
            self._pool.close()
            self._pool = None

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # at interpreter shutdown there is nothing left to stop
            pass
