"""The GPU parity's comparison and tolerance (planetnav_env.device.parity) on runs whose differences are
known: what it must accept (last-bit differences) and what it must not."""

from __future__ import annotations

import numpy as np
import pytest

from planetnav_env.device.parity import PARITY_TOLERANCE, compare_runs, row_differences


def _run(rng: np.random.Generator) -> dict:
    a = rng.normal(size=(5, 6, 6))
    return {
        "obs": rng.normal(size=(20, 5, 8)).astype(np.float32),
        "reward": rng.normal(size=(20, 5)) * 100.0,
        "f": rng.normal(size=(5, 12)) * 1e8,
        "p": a @ a.transpose(0, 2, 1) * 1e4,  # covariances
        "i": rng.integers(0, 5, (5, 4)),
    }


def _copy(run: dict) -> dict:
    return {k: v.copy() for k, v in run.items()}


def test_equal_runs_are_bit_for_bit() -> None:
    run = _run(np.random.default_rng(0))
    out = compare_runs(_copy(run), run)
    assert out["bit_for_bit"] and out["all_within_tolerance"]
    assert out["observation"]["entries_differing"] == "0 of 800"


def test_last_bit_differences_are_within_tolerance_and_not_bit_for_bit() -> None:
    rng = np.random.default_rng(1)
    cpu = _run(rng)
    gpu = _copy(cpu)
    gpu["obs"] = np.nextafter(gpu["obs"], np.float32(np.inf))  # one float32 ulp up, everywhere
    gpu["reward"] = gpu["reward"] * (1 + 4e-16)
    gpu["p"] = gpu["p"] * (1 + 1e-14)
    out = compare_runs(gpu, cpu)
    assert not out["bit_for_bit"]
    assert out["all_within_tolerance"], out["within_tolerance"]


def _obs_off(r: dict) -> None:
    r["obs"][3, 1, 2] += 1e-4


def _obs_nan(r: dict) -> None:
    r["obs"][0, 0, 0] = np.nan


def _reward_off(r: dict) -> None:
    r["reward"][7, 2] += 1e-6 * np.abs(r["reward"]).max()


def _covariance_off(r: dict) -> None:
    r["p"][1, 0, 3] += 3e-9 * np.sqrt(r["p"][1, 0, 0] * r["p"][1, 3, 3])


def _counter_off(r: dict) -> None:
    r["i"][4, 1] += 1


@pytest.mark.parametrize(
    ("what", "change"),
    [("observation", _obs_off), ("observation", _obs_nan), ("reward", _reward_off),
     ("covariance", _covariance_off), ("discrete_state_equal", _counter_off)],
)  # fmt: skip
def test_a_difference_beyond_the_tolerance_is_caught(what: str, change) -> None:
    cpu = _run(np.random.default_rng(2))
    gpu = _copy(cpu)
    change(gpu)
    out = compare_runs(gpu, cpu)
    assert not out["within_tolerance"][what] and not out["all_within_tolerance"]
    others = {k: v for k, v in out["within_tolerance"].items() if k != what}
    assert all(others.values()), others


def test_covariance_tolerance_is_the_entrys_own_scale() -> None:
    cpu = _run(np.random.default_rng(3))
    gpu = _copy(cpu)
    s = np.sqrt(cpu["p"][2, 1, 1] * cpu["p"][2, 4, 4])
    gpu["p"][2, 1, 4] += 0.5 * PARITY_TOLERANCE["covariance"] * s
    out = compare_runs(gpu, cpu)
    assert out["within_tolerance"]["covariance"]
    half = 0.5 * PARITY_TOLERANCE["covariance"]
    assert out["state_p"]["max_of_sqrt_pii_pjj"] == pytest.approx(half, rel=1e-6)
    gpu["p"][2, 1, 4] += 1.0 * PARITY_TOLERANCE["covariance"] * s
    assert not compare_runs(gpu, cpu)["within_tolerance"]["covariance"]


def test_a_value_near_zero_does_not_inflate_the_scaled_difference() -> None:
    cpu = np.array([[1e3, 1e-20], [2e3, -1e3]])
    gpu = cpu + np.array([[0.0, 1e-18], [0.0, 0.0]])
    d = row_differences(gpu, cpu)
    assert d["max_rel"] == pytest.approx(100.0)  # relative to the entry: 1e-18 / 1e-20
    assert d["max_scaled"] == pytest.approx(1e-21)  # relative to its column's scale, 1e3
    assert d["entries_differing"] == "1 of 4"
