"""The row kernels on two targets: the CPU, and CUDA through numba-cuda (the ``[gpu]`` extra).

What a machine without a GPU can check (the rules are in :mod:`planetnav_env.numerics.jit`):

* the rules, read from the source: no numpy function in a row kernel (numpy constants are fine), no
  ``raise`` (``test_row_kernels_call_no_numpy_function``);
* the thread functions a CUDA kernel runs (:func:`~planetnav_env.core.kernels.step_thread`,
  :func:`~planetnav_env.core.kernels.reset_thread`, one row each, scratch as per-row slices), compiled for
  the CPU and looped over the rows, equal the chunked step bit for bit on every id;
* :mod:`planetnav_env.numerics.portable_math`'s scalar ``remainder`` and ``rint`` equal numba's
  ``np.remainder`` and ``np.rint`` bit for bit;
* with numba-cuda installed: every entry point (step, reset; autoreset is a reset of the
  finished rows) compiles to PTX for every registered id, the compute capability supplied (9.0), with no
  unresolved external function. It does not run the PTX: only a device checks the numbers (the CUDA
  simulator runs the ``@njit`` functions a kernel calls as CPU code, so it would compare the CPU with
  itself). That the argument types compiled are those a launch compiles is
  tests/env/test_device_argtypes.py's check (it builds the device env, hence reaches gymnasium).
"""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest
from numba import njit

from planetnav_env.batch import BatchCore
from planetnav_env.config import EnvConfig
from planetnav_env.core import kernels as K
from planetnav_env.core.decoding import raw_action_size
from planetnav_env.core.records import Actions, rows_innermost_like, scratch_row, scratch_rows
from planetnav_env.device import rows as R
from planetnav_env.numerics import portable_math as pm
from planetnav_env.tasks import ID_OPTIONS as ENV_IDS

PACKAGE = Path(__file__).resolve().parents[2] / "planetnav_env"
# The ids' options from the declarations, not the registration: this file reaches no gymnasium, so the
# [ray] pass (another gymnasium, the same numba) leaves it out (the Makefile's RAY_SAME).
#: Every registered id, and the flight world on a cruise and on the Mars approach (its light-path branches).
CONFIGS = {
    **ENV_IDS,
    **{f"{i}+flight": {**ENV_IDS[i], "world": "flight"}
       for i in ("planetnav/Cruise-Target-v2", "planetnav/MarsApproach-Tasking-v2")},
}  # fmt: skip
ROWS = 3
STEPS = 12


# --- the rules, from the source ---
#: numpy names a row kernel may use: constants and the types of annotations.
NUMPY_ALLOWED = {"nan", "pi", "inf", "e", "ndarray", "float64", "int64", "uint64", "bool_"}


def _row_kernels() -> list[tuple[str, ast.FunctionDef]]:
    """Every function of the package compiled as a row kernel (``@row_kernel``, or ``@njit(...)`` with
    ``**ROW_KERNEL_OPTIONS``)."""
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef) and any(
                "row_kernel" in ast.unparse(d) or "ROW_KERNEL_OPTIONS" in ast.unparse(d)
                for d in node.decorator_list
            ):
                found.append((f"{path.relative_to(PACKAGE.parent)}:{node.lineno} {node.name}", node))
    return found


def test_row_kernels_call_no_numpy_function() -> None:
    kernels = _row_kernels()
    assert len(kernels) > 50  # the scan finds them
    bad = []
    for where, fn in kernels:
        for sub in ast.walk(fn):
            if (
                isinstance(sub, ast.Attribute)
                and isinstance(sub.value, ast.Name)
                and sub.value.id == "np"
                and sub.attr not in NUMPY_ALLOWED
            ):
                bad.append(f"{where}: np.{sub.attr}")
            if isinstance(sub, ast.Raise):
                bad.append(f"{where}: raise")
    assert not bad, "row kernels must use math.* / portable_math, and no exceptions:\n" + "\n".join(bad)


# --- portable scalar math ---
@njit
def _ufunc_and_portable(x, y, out):  # pragma: no cover - compiled
    for k in range(x.size):
        out[0, k] = np.remainder(x[k], y[k])
        out[1, k] = pm.remainder(x[k], y[k])
        out[2, k] = np.rint(x[k])
        out[3, k] = pm.rint(x[k])


def test_portable_remainder_and_rint_equal_numbas_ufuncs_bit_for_bit() -> None:
    rng = np.random.default_rng(0)
    special = np.array(
        [0.0, -0.0, 0.5, -0.5, 1.5, 2.5, -2.5, 1.0, -1.0, np.pi, 2 * np.pi, -2 * np.pi, 2.0**52, 2.0**52 + 1,
         -(2.0**52) - 1, 2.0**51 + 0.5, 2.0**53, 5e-324, -5e-324, 1e308, np.inf, -np.inf, np.nan]
    )  # fmt: skip
    n = 50_000
    x = np.concatenate([
        rng.normal(size=n) * 10.0 ** rng.uniform(-8, 20, n), np.repeat(special, special.size),
        np.round(rng.normal(size=n) * 100) * 0.5, rng.integers(-100, 100, 1000) * (2 * np.pi),
    ])  # fmt: skip
    y = np.concatenate([
        rng.normal(size=n) * 10.0 ** rng.uniform(-8, 20, n), np.tile(special, special.size),
        rng.choice(special, n), np.full(1000, 2 * np.pi),
    ])  # fmt: skip
    out = np.empty((4, x.size))
    _ufunc_and_portable(x, y, out)
    bits = out.view(np.uint64)
    # rint: every bit. remainder: every bit, except that a NaN may carry another sign (numba's ufunc gives
    # x86's default NaN for y == 0, the portable one math.nan).
    assert np.array_equal(bits[2], bits[3])
    both_nan = np.isnan(out[0]) & np.isnan(out[1])
    assert np.array_equal(np.isnan(out[0]), np.isnan(out[1]))
    assert np.array_equal(bits[0][~both_nan], bits[1][~both_nan])


# --- PTX (numba-cuda) ---
def _numba_cuda():
    from planetnav_env.numerics.cuda_target import require_numba_cuda

    try:
        return require_numba_cuda()
    except ImportError as exc:
        pytest.skip(str(exc))


@pytest.fixture(scope="module")
def ptx_by_signature():
    """The entry points' argument types per id, and the PTX of each distinct (entry, types), compiled once:
    the ids differ in values (parameters, sizes), and the types, hence the PTX, are shared where equal."""
    _numba_cuda()
    from planetnav_env.core import cuda_entry

    types = {
        env_id: cuda_entry.entry_argtypes(BatchCore(EnvConfig.from_dict(kw), 2))
        for env_id, kw in CONFIGS.items()
    }
    compiled: dict = {}

    def ptx(env_id: str, entry: str) -> str:
        key = (entry, types[env_id][entry])
        if key not in compiled:
            compiled[key] = cuda_entry.compile_ptx(cuda_entry.ENTRY_POINTS[entry], key[1])
        return compiled[key]

    return ptx


@pytest.mark.parametrize("entry", ["step"])
@pytest.mark.parametrize("env_id", list(CONFIGS))
def test_entry_point_compiles_to_ptx(env_id: str, entry: str, ptx_by_signature) -> None:
    ptx = ptx_by_signature(env_id, entry)
    assert ".target sm_90" in ptx
    assert ".visible .entry" in ptx and f"{entry}_kernel" in ptx
    # Everything the kernel calls is in the module (libdevice is linked by NVVM): no runtime (NRT),
    # exception or host helper left to resolve.
    assert ".extern" not in ptx


def test_device_typeof_makes_every_array_writable() -> None:
    """Read-only arrays anywhere in plain, uniform and named tuples become writable; the rest is kept."""
    import numba

    from planetnav_env.numerics.cuda_target import device_typeof

    ro = np.zeros((2, 3))
    ro.setflags(write=False)
    act = Actions(
        raw=np.zeros((2, 1)), targets=np.zeros(2, np.int64), torques=ro, active=np.ones(2, np.bool_)
    )
    value = (ro, (ro, ro), act, 1.5)
    want = (np.zeros((2, 3)), (np.zeros((2, 3)),) * 2, act._replace(torques=np.zeros((2, 3))), 1.5)
    assert "readonly" in str(numba.typeof(value))
    assert device_typeof(value) == numba.typeof(want)


def test_compute_capability_is_supplied_only_inside_the_block() -> None:
    _numba_cuda()
    from numba.cuda import dispatcher

    from planetnav_env.numerics.cuda_target import supplied_compute_capability

    before = dispatcher.get_current_device
    with supplied_compute_capability((8, 0)):
        assert dispatcher.get_current_device().compute_capability == (8, 0)
    assert dispatcher.get_current_device is before


# --- assembled by ptxas: what the driver will do with the PTX on a device ---
@pytest.fixture(scope="module")
def autoreset_ptx():
    from planetnav_env.numerics.cuda_target import require_numba_cuda

    try:
        require_numba_cuda()
    except ImportError as exc:
        pytest.skip(str(exc))
    from planetnav_env.device import cuda_kernels

    compiled: dict = {}

    def ptx(env_id: str) -> str:
        types = cuda_kernels.autoreset_argtypes(BatchCore(EnvConfig.from_dict(ENV_IDS[env_id]), 2))
        if types not in compiled:  # the ids share their types: one compilation
            compiled[types] = cuda_kernels.compile_ptx(cuda_kernels.autoreset_kernel, types)
        return compiled[types]

    return ptx


@pytest.mark.parametrize("env_id", list(ENV_IDS))
def test_autoreset_kernel_compiles_to_ptx(env_id: str, autoreset_ptx) -> None:
    ptx = autoreset_ptx(env_id)
    assert ".target sm_90" in ptx
    assert ".visible .entry" in ptx and "autoreset_kernel" in ptx
    assert ".extern" not in ptx


def test_autoreset_kernel_assembles_for_sm_90(autoreset_ptx) -> None:
    """ptxas accepts the autoreset's PTX, and the device env's default block launches with its registers."""
    from planetnav_env.device.kernel_resources import assemble, find_ptxas
    from planetnav_env.device.occupancy import SM_90, THREADS_PER_BLOCK, require_launchable

    try:
        ptxas = find_ptxas()
    except FileNotFoundError as exc:
        pytest.skip(str(exc))
    (res,) = assemble(autoreset_ptx("planetnav/Cruise-Target-v1"), ptxas=ptxas).values()
    assert "autoreset_kernel" in res.function
    require_launchable("autoreset", res.registers, THREADS_PER_BLOCK, SM_90)


def _ptxas() -> str:
    from planetnav_env.device.kernel_resources import find_ptxas

    try:
        return find_ptxas()
    except FileNotFoundError as exc:
        pytest.skip(str(exc))


@pytest.mark.parametrize("entry", ["step"])
def test_entry_point_assembles_for_sm_90(entry: str, ptx_by_signature) -> None:
    """ptxas accepts the PTX (as the driver must at the first launch), and a block of the device env's
    size launches with the registers it reports. The ids share one PTX per entry (the fixture's check)."""
    from planetnav_env.device.kernel_resources import assemble
    from planetnav_env.device.occupancy import SM_90, THREADS_PER_BLOCK, require_launchable

    ptxas = _ptxas()
    found = assemble(ptx_by_signature("planetnav/Cruise-Target-v1", entry), ptxas=ptxas)
    ((name, res),) = found.items()
    assert f"{entry}_kernel" in name
    assert 1 <= res.registers <= SM_90.max_regs_per_thread
    require_launchable(entry, res.registers, THREADS_PER_BLOCK, SM_90)  # the device env's default


@pytest.mark.parametrize(
    ("layout", "wheel"),
    [("cuda_nvcc/bin/ptxas", "nvidia-cuda-nvcc-cu12"), ("cu13/bin/ptxas", "nvidia-cuda-nvcc 13.x")],
)
def test_ptxas_is_found_in_either_compiler_wheels_layout(tmp_path, layout: str, wheel: str) -> None:
    """The wheels' file lists (pip download --no-deps, unzip -l): CUDA 12 keeps ptxas in
    nvidia/cuda_nvcc/bin, CUDA 13 in nvidia/cu13/bin."""
    from planetnav_env.device.kernel_resources import ptxas_in_wheels

    nvidia = tmp_path / "site-packages" / "nvidia"
    assert ptxas_in_wheels([str(nvidia)]) is None
    (nvidia / layout).parent.mkdir(parents=True)
    (nvidia / layout).write_text("")
    assert ptxas_in_wheels([str(tmp_path / "elsewhere"), str(nvidia)]) == str(nvidia / layout), wheel


def test_memory_operations_and_innermost_loops_are_read_from_ptx() -> None:
    from planetnav_env.device.kernel_resources import innermost_loops, memory_ops

    ptx = (
        ".visible .entry k(\n)\n{\n"
        "\tld.param.u64 %rd1, [k_param_0];\n"
        "$L__BB0_1:\n"
        "\tld.global.f64 %fd1, [%rd1];\n"
        "$L__BB0_2:\n"
        "\tld.f64 %fd2, [%rd2];\n\tfma.rn.f64 %fd3, %fd1, %fd2, %fd3;\n\tst.f64 [%rd2], %fd3;\n"
        "\t@%p1 bra $L__BB0_2;\n"
        "\tst.global.f64 [%rd1], %fd3;\n\tld.global.nc.v2.f64 {%fd4, %fd5}, [%rd3];\n"
        "\t@%p2 bra $L__BB0_1;\n\tret;\n}\n"
    )
    want = {"ld.generic": 1, "ld.global": 2, "ld.param": 1, "st.generic": 1, "st.global": 1}
    assert memory_ops(ptx) == want
    (inner,) = innermost_loops(ptx)  # the outer loop holds the inner one: not innermost
    assert inner["instructions"] == 4 and inner["fma_f64"] == 1
    assert (inner["ld.generic"], inner["st.generic"]) == (1, 1) and "ld.global" not in inner


def test_ptxas_rejection_is_reported() -> None:
    from planetnav_env.device.kernel_resources import assemble

    ptxas = _ptxas()
    with pytest.raises(RuntimeError, match=r"ptxas rejected the PTX for sm_90: .*"):
        assemble(".version 8.5\n.target sm_90\n.address_size 64\nnot an instruction;\n", ptxas=ptxas)


def test_ptxas_report_is_parsed() -> None:
    """The report's shape (ptxas 12.9): an entry's own frame and registers; a callee's frame is not the
    entry's."""
    from planetnav_env.device.kernel_resources import parse_ptxas_verbose

    text = (
        "ptxas info    : 648 bytes gmem\n"
        "ptxas info    : Compiling entry function '_Z6kernelPd' for 'sm_90'\n"
        "ptxas info    : Function properties for _Z6kernelPd\n"
        "    40 bytes stack frame, 8 bytes spill stores, 12 bytes spill loads\n"
        "ptxas info    : Used 200 registers, used 0 barriers, 40 bytes cumulative stack size\n"
        "ptxas info    : Compile time = 8323.124 ms\n"
        "ptxas info    : Function properties for __internal_trig_reduction_slowpathd\n"
        "    0 bytes stack frame, 0 bytes spill stores, 0 bytes spill loads\n"
    )
    (res,) = parse_ptxas_verbose(text).values()
    assert (res.function, res.registers, res.stack_bytes) == ("_Z6kernelPd", 200, 40)
    assert (res.spill_store_bytes, res.spill_load_bytes) == (8, 12)


# --- the thread functions on the CPU (last: make test starts this file before the host-mode cache is
# written, and the PTX compiling above takes minutes) ---
@njit
def _row_zero(rows):  # pragma: no cover - compiled
    return scratch_row(rows, 0)


def test_a_rows_scratch_views_have_one_type_for_every_task() -> None:
    """The tasks' scratch rows differ in numba type (sizes of 0 or 1 change the arrays' layout flags), and
    the views a thread reads have one type for all of them, so the row kernels are compiled once."""
    for kw in CONFIGS.values():
        _row_zero(scratch_rows(BatchCore(EnvConfig.from_dict(kw), ROWS).params, ROWS))
    signatures = _row_zero.nopython_signatures
    assert len({s.args for s in signatures}) > 1
    assert len({s.return_type for s in signatures}) == 1


def _state_bytes(core: BatchCore) -> list[bytes]:
    return [a.tobytes() for a in (core.f, core.p, core.i, core.rng, core.eph, core.obs)]


@pytest.mark.parametrize("env_id", list(CONFIGS))
def test_thread_functions_equal_the_chunked_step_bit_for_bit(env_id: str, monkeypatch) -> None:
    """Row by row with per-row scratch slices, state, actions and scratch rows innermost (the device's
    layout), gives the CPU step's numbers."""
    cfg = EnvConfig.from_dict(CONFIGS[env_id])
    chunked, threads = BatchCore(cfg, ROWS), BatchCore(cfg, ROWS)
    rows = scratch_rows(threads.params, ROWS)
    all_rows = np.arange(ROWS, dtype=np.int64)
    chunked.reset_rows(all_rows, [np.random.default_rng(11 + r) for r in range(ROWS)])
    # The same host-side draws; the compiled part of the reset by reset_thread.
    with monkeypatch.context() as m:
        m.setattr(K, "reset_rows", lambda prm, st, reset: R.reset_rows(prm, st, reset, rows))
        threads.reset_rows(all_rows, [np.random.default_rng(11 + r) for r in range(ROWS)])
    assert _state_bytes(threads) == _state_bytes(chunked)
    st = rows_innermost_like(threads.state)
    assert st.f.strides[0] == 8 and st.p.strides[0] == 8
    rng = np.random.default_rng(3)
    width = raw_action_size(int(threads.params.scalars[0]["mode"]), cfg.n_planets)
    decoded = (np.zeros(ROWS, np.int64), np.zeros((ROWS, 3)))  # the chunked step's decoding buffers
    act = rows_innermost_like(Actions(raw=np.zeros((ROWS, width)), targets=decoded[0],
                                      torques=decoded[1], active=np.ones(ROWS, np.bool_)))  # fmt: skip
    for k in range(STEPS):
        if cfg.action_mode == "target":
            # Hold each action a few steps (slews, settling, pulsar integration), change it now and then.
            if k % 4 == 0:
                raw = rng.integers(0, cfg.n_target_actions, (ROWS, 1)).astype(float)
        else:  # Box actions, some outside [-1, 1] (the decoding clips them)
            raw = rng.uniform(-1.2, 1.2, (ROWS, width))
        active = np.ones(ROWS, dtype=np.bool_)
        active[k % ROWS] = k % 5 != 0  # an inactive row now and then
        K.step_range_arrays(
            chunked.params, chunked.f, chunked.p, chunked.i, chunked.rng, chunked.eph, chunked.obs,
            raw, *decoded, active, 0, ROWS, True, cfg.decision_steps,
        )  # fmt: skip
        act.raw[:] = raw
        act.active[:] = active
        R.step_rows(threads.params, st, act, rows)
        assert [np.ascontiguousarray(a).tobytes() for a in st] == _state_bytes(chunked), f"step {k}"
