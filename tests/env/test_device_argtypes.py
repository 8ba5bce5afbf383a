"""The types the PTX checks compile (tests/env/test_cuda_ptx.py) are the types a launch compiles: the
device env's own records, typed as numba-cuda types what it passes. Apart from the PTX file because it
builds the device env (a Gymnasium vector env), so it runs under both gymnasium versions, while the PTX
compiles, which reach no gymnasium, run once."""

from __future__ import annotations

import numpy as np
import pytest
from test_cuda_ptx import CONFIGS, _numba_cuda

from planetnav_env.batch import BatchCore
from planetnav_env.config import EnvConfig
from planetnav_env.core.records import map_arrays


def _as_launched(value):
    """``value`` with every non-empty numpy array replaced by numba-cuda's own device array of its shape,
    strides and dtype (the memory a stand-in: typing reads none), as the device env passes its records;
    an empty array by a writable one (numba-cuda's needs a context to exist)."""
    from numba.cuda.cudadrv.devicearray import DeviceNDArray

    def device(a: np.ndarray):
        if a.size == 0:
            return np.zeros(a.shape, a.dtype)
        return DeviceNDArray(a.shape, a.strides, a.dtype, gpu_data=object())

    return map_arrays(device, value)


@pytest.mark.parametrize("env_id", list(CONFIGS))
def test_argument_types_are_the_launchs(env_id: str) -> None:
    """The PTX checks compile the types a launch compiles: numba-cuda's typing of the records the device
    env passes (its host mode's arrays: the same shapes, dtypes and strides, rows innermost), with device
    arrays, which are writable where the host's are read-only (the star catalogue's)."""
    _numba_cuda()
    import numba

    from planetnav_env.core import cuda_entry
    from planetnav_env.device.bank import BankRows
    from planetnav_env.device.cuda_kernels import autoreset_argtypes
    from planetnav_env.device.vector_env import DeviceVectorEnv

    core = BatchCore(EnvConfig.from_dict(CONFIGS[env_id]), 2)
    n = core.num_rows
    dev = DeviceVectorEnv(CONFIGS[env_id], n, device="cpu")
    prm, st, act, rows = dev._prm, dev._state, dev._act, dev._scratch
    bank = BankRows(f=core.f, p=core.p, rng=core.rng, eph=core.eph)  # as EpisodeBank.rows: rows outermost
    launched = {
        "step": (prm, st, act, rows),
        "autoreset": (prm, st, bank, dev._slots_view, dev._mask_view, rows),
    }
    compiled = {**cuda_entry.entry_argtypes(core), "autoreset": autoreset_argtypes(core)}
    for entry, args in launched.items():
        assert compiled[entry] == tuple(numba.typeof(_as_launched(a)) for a in args), entry
    host = numba.typeof(core.params)
    if "readonly" in str(host):  # ids with a star catalogue: the host's types are not the launch's
        assert compiled["step"][0] != host and "readonly" not in str(compiled["step"][0])
