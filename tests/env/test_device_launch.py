"""The CUDA backend's launch path without a GPU: a launch that fails for want of registers is named by
its setting, whatever layer of numba-cuda raises the driver's error.

numba-cuda 0.30 launches through ``cuda.core.launch``, which raises cuda.core's ``CUDAError``; its own
driver wrapper (loading the module) raises ``CudaAPIError``. A stand-in kernel raises each in turn.
"""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from planetnav_env.errors import InvalidParameterError

pytest.importorskip("numba.cuda.cudadrv.driver")


def _backend(error: BaseException, threads_per_block: int, regs: int):
    from planetnav_env.device.cuda_kernels import Dispatchers
    from planetnav_env.device.vector_env import _Cuda, launch_errors

    launched = []

    class FailingLaunch:
        def __init__(self) -> None:
            self.overloads = {"sig": SimpleNamespace(regs_per_thread=regs)}

        def __getitem__(self, grid):
            def run(*args):
                launched.append(grid)
                raise error

            return run

    be = object.__new__(_Cuda)  # no GPU here: the attributes the launch path reads, set by hand
    be.cuda = SimpleNamespace(get_current_device=lambda: SimpleNamespace(compute_capability=(9, 0)))
    be._api_error = launch_errors()
    be.tpb = threads_per_block
    be.kernels = Dispatchers(step=FailingLaunch(), autoreset=FailingLaunch())
    return be, launched


def _errors() -> list[BaseException]:
    from numba.cuda.cudadrv.driver import CudaAPIError

    out: list[BaseException] = [CudaAPIError(701, "CUDA_ERROR_LAUNCH_OUT_OF_RESOURCES")]
    try:
        from cuda.core._utils.cuda_utils import CUDAError
    except ImportError:
        return out
    return [*out, CUDAError("CUDA_ERROR_LAUNCH_OUT_OF_RESOURCES: too many resources requested for launch")]


@pytest.mark.parametrize("error", _errors(), ids=lambda e: type(e).__name__)
def test_a_block_too_large_for_the_registers_is_named(error: BaseException) -> None:
    be, launched = _backend(error, threads_per_block=1024, regs=200)
    with pytest.raises(InvalidParameterError, match=r"threads_per_block=1024 cannot launch the step kernel"):
        be._launch("step", 5000, "args")
    assert launched == [(5, 1024)]


@pytest.mark.parametrize("error", _errors(), ids=lambda e: type(e).__name__)
def test_another_launch_failure_is_raised_as_it_came(error: BaseException) -> None:
    be, _ = _backend(error, threads_per_block=128, regs=200)  # 128 threads fit: not the registers
    with pytest.raises(type(error)) as caught:
        be._launch("autoreset", 300, "args")
    assert caught.value is error


def test_the_launch_errors_include_what_numba_cudas_launcher_raises() -> None:
    """numba-cuda's dispatcher launches with cuda.core's ``launch``; its errors are cuda.core's CUDAError."""
    from numba.cuda import dispatcher

    from planetnav_env.device.vector_env import launch_errors

    if not hasattr(dispatcher, "launch"):
        pytest.skip("this numba-cuda launches through its own driver wrapper")
    from cuda.core._utils.cuda_utils import CUDAError

    assert dispatcher.launch.__module__.startswith("cuda.core")
    assert CUDAError in launch_errors()
