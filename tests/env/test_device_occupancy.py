"""The occupancy rule (planetnav_env.device.occupancy) against NVIDIA's published examples and against a
brute-force placement of warps into an SM's register sub-partitions."""

from __future__ import annotations

import dataclasses

import pytest

from planetnav_env.device import occupancy as O
from planetnav_env.errors import InvalidParameterError

#: Compute capability 7.0 (the Best Practices Guide's examples): the same register file and warp slots.
SM_70 = dataclasses.replace(O.SM_90, name="compute capability 7.0")


def test_the_best_practices_guides_example() -> None:
    # "a kernel with 128-thread blocks using 37 registers per thread results in an occupancy of 75% with 12
    # active 128-thread blocks per multi-processor, whereas a kernel with 320-thread blocks using the same
    # 37 registers per thread results in an occupancy of 63% because only four 320-thread blocks can reside"
    assert O.blocks_per_sm(37, 128, SM_70) == 12
    assert O.occupancy(37, 128, SM_70) == 0.75
    assert O.blocks_per_sm(37, 320, SM_70) == 4
    assert round(100 * O.occupancy(37, 320, SM_70)) == 62  # 40 of 64 warps: the guide's "63%" rounded up


def test_a_block_that_exceeds_the_register_file_does_not_launch() -> None:
    # 72 registers x 1,024 threads = 73,728 > 65,536: no launch; blocks of 256 fit three to an SM.
    assert O.blocks_per_sm(72, 1024) == 0
    assert O.blocks_per_sm(72, 256) == 3
    # The hardware's check rounds a block's warps up to the 4 sub-partitions: 200 registers and 10 warps
    # need 6,400 x 12 = 76,800 registers although 6,400 x 10 = 64,000 would fit.
    assert O.blocks_per_sm(200, 320) == 0
    assert O.blocks_per_sm(200, 256) == 1
    assert O.blocks_per_sm(8, 2048) == 0  # more threads than a block may have


def _brute_force_blocks(regs: int, tpb: int, lim: O.SmLimits) -> int:
    """Place whole blocks one after another, each warp on the emptiest sub-partition that has room, until
    a block does not fit or a per-SM limit is reached (a different computation of the same rule)."""
    per_warp = -(-regs * lim.warp_size // lim.reg_alloc_unit) * lim.reg_alloc_unit
    warps = -(-tpb // lim.warp_size)
    warps_checked = -(-warps // lim.sub_partitions) * lim.sub_partitions
    if tpb > lim.max_threads_per_block or per_warp * warps_checked > lim.regs_per_block:
        return 0
    free = [lim.regs_per_sm // lim.sub_partitions] * lim.sub_partitions
    blocks = resident = 0
    while blocks < lim.max_blocks_per_sm and resident + warps <= lim.max_warps_per_sm:
        trial = list(free)
        for _ in range(warps):
            k = max(range(len(trial)), key=lambda j: trial[j])
            if trial[k] < per_warp:
                return blocks
            trial[k] -= per_warp
        free, blocks, resident = trial, blocks + 1, resident + warps
    return blocks


@pytest.mark.parametrize("regs", [16, 32, 37, 40, 64, 72, 96, 128, 136, 164, 168, 200, 232, 255])
def test_blocks_equal_a_brute_force_placement(regs: int) -> None:
    for tpb in range(32, 1025, 32):
        assert O.blocks_per_sm(regs, tpb) == _brute_force_blocks(regs, tpb, O.SM_90), (regs, tpb)


def test_register_steps_are_where_occupancy_changes() -> None:
    steps = O.register_steps()
    assert steps[0] == (255, 8)  # the most registers a thread may have still leaves 8 warps
    assert (128, 16) in steps and (168, 12) in steps and (32, 64) in steps
    for regs, warps in steps:
        assert O.warps_per_sm(regs, 128) == warps  # at the step's register count
        if regs < 255:
            assert O.warps_per_sm(regs + 1, 128) < warps  # one register more loses warps


def test_best_block_size() -> None:
    assert O.best_threads_per_block(32) == 1024  # full occupancy; the largest such block
    assert O.best_threads_per_block(200) == 256  # 8 warps whatever the size; 256 is the largest holding them
    assert O.warps_per_sm(200, O.best_threads_per_block(200)) == 8


def test_bad_input_is_named() -> None:
    with pytest.raises(InvalidParameterError, match="regs_per_thread must be at most 255"):
        O.blocks_per_sm(256, 128)
    with pytest.raises(InvalidParameterError, match="threads_per_block must be a positive integer, got 0"):
        O.blocks_per_sm(64, 0)
    with pytest.raises(InvalidParameterError, match=r"no occupancy limits for compute capability \(7, 5\)"):
        O.limits_for((7, 5))
    assert O.limits_for((9, 0)) is O.SM_90
    with pytest.raises(InvalidParameterError, match=r"threads_per_block=320 cannot launch step.*at most 256"):
        O.require_launchable("step", 200, 320, O.SM_90)
    O.require_launchable("step", 200, 256, O.SM_90)
