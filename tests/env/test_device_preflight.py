"""The device check's preflight (planetnav_env/device/preflight.py) on the CPU, host mode standing in.

It runs every check it can without a device (NVVM and libdevice loaded, the >4 KB-parameter and libdevice
kernels compiled to PTX, the real kernels in host mode at 256 rows, host mode against the CPU vector env
bit for bit), names the ones it skipped, and a failing check stops the run with one line naming it.
"""

from __future__ import annotations

import numpy as np
import pytest

from planetnav_env.device import preflight as P
from planetnav_env.numerics.cuda_target import require_numba_cuda

pytestmark = pytest.mark.filterwarnings("ignore:.*is out of date.*")

try:
    require_numba_cuda()
except ImportError as exc:  # numba's own deprecated numba.cuda is not the target
    pytest.skip(str(exc), allow_module_level=True)


def test_on_the_cpu_the_preflight_runs_what_it_can_and_names_what_it_skipped() -> None:
    lines: list[str] = []
    results = P.run(on_device=False, emit=lines.append)
    status = {r.name: r.status for r in results}
    assert status == {
        "card": "skipped", "toolchain": "ok", "torch_stream": "skipped", "large_parameters": "skipped",
        "libdevice_math": "skipped", "kernels": "ok", "parity": "ok",
    }  # fmt: skip
    assert len(lines) == len(results)
    by = {r.name: r for r in results}
    tool = by["toolchain"].found
    assert tool["nvvm"]["path"] and tool["libdevice"]["path"].endswith(".bc")
    assert tool["libdevice_bytes"] > 10**5
    assert tool["nvvm_version"].count(".") >= 1
    assert "B of parameters" in by["large_parameters"].reason
    bytes_ = int(by["large_parameters"].reason.split(" with ")[1].split(" B")[0])
    assert bytes_ > P.OLD_PARAM_LIMIT
    assert by["kernels"].found["mode"] == "cpu" and by["kernels"].found["rows"] == P.KERNEL_ROWS
    assert by["parity"].found["bit_for_bit"] is True
    line = P.summary(results, False, 1.0)
    assert line.startswith("PREFLIGHT OK on the CPU, host mode standing in: 3 passed")
    assert line.endswith("skipped (need a device): card, torch_stream, large_parameters, libdevice_math")


def test_a_failing_check_stops_the_run_with_one_line_naming_it(monkeypatch) -> None:
    ran = []

    def fails(on_device: bool) -> dict:
        raise P.CheckFailed("the driver is too old")

    def never(on_device: bool) -> dict:
        ran.append("never")
        return {}

    monkeypatch.setattr(P, "CHECKS", (("toolchain", P.check_toolchain), ("card", fails), ("kernels", never)))
    results = P.run(on_device=False, emit=lambda line: None)
    assert [r.status for r in results] == ["ok", "failed"] and not ran
    assert P.summary(results, False, 2.0) == "PREFLIGHT FAILED at card: the driver is too old"


def test_an_error_inside_a_check_is_that_checks_failure(monkeypatch) -> None:
    def broken(on_device: bool) -> dict:
        raise ZeroDivisionError("float division by zero")

    monkeypatch.setattr(P, "CHECKS", (("parity", broken),))
    (res,) = P.run(on_device=False, emit=lambda line: None)
    assert (res.status, res.reason) == ("failed", "ZeroDivisionError: float division by zero")


def test_the_parameter_block_of_a_ptx_entry_is_measured() -> None:
    ptx = (
        ".visible .entry _Z1kPd(\n\t.param .u64 _Z1kPd_param_0,\n\t.param .f64 _Z1kPd_param_1,\n"
        "\t.param .align 8 .b8 _Z1kPd_param_2[40]\n)\n{\n\tret;\n}\n"
    )
    assert P.ptx_param_bytes(ptx) == 8 + 8 + 40


def test_ulps_count_units_in_the_last_place_across_zero() -> None:
    x = np.array([1.0, -1.0, 0.0])
    assert P._ulps(x, x) == 0
    assert P._ulps(np.nextafter(x, 2.0), x) == 1
    assert P._ulps(np.array([5e-324]), np.array([-5e-324])) == 2
