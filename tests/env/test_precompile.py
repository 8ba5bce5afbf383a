"""``python -m planetnav_env.precompile``: every registered id runs on one compiled step and one reset."""

from __future__ import annotations

import subprocess
import sys

import pytest

from planetnav_env.envs.registration import ENV_IDS
from planetnav_env.errors import ConfigError
from planetnav_env.precompile import main, precompile

_COUNT = (
    "from planetnav_env.precompile import main; main([]);"
    "from planetnav_env.core import kernels as K;"
    "print('signatures', len(K.step_range_arrays.signatures), len(K.reset_rows.signatures))"
)


def test_every_id_runs_on_one_compiled_step_and_reset() -> None:
    """In a fresh process (numba lists only what that process compiled or loaded), all ids together need
    one step and one reset: an id whose arrays typed differently would compile the whole step again."""
    proc = subprocess.run([sys.executable, "-c", _COUNT], capture_output=True, text=True, timeout=1200)
    assert proc.returncode == 0, proc.stderr[-3000:]
    lines = proc.stdout.splitlines()
    assert sum(" s  planetnav/" in line for line in lines) == len(ENV_IDS)
    assert lines[-1] == "signatures 1 1"


def test_precompile_returns_each_ids_seconds() -> None:
    ids = ["planetnav/Cruise-Target-v3", "planetnav/Cruise-Torque-v0"]
    seconds = precompile(ids)
    assert list(seconds) == ids
    assert all(s > 0.0 for s in seconds.values())


def test_quiet_prints_only_the_total(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--quiet", "planetnav/Cruise-Target-v3"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert len(out) == 1 and out[0].endswith("in all (1 ids)")


def test_an_unknown_id_is_named_before_anything_compiles(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(ConfigError, match="planetnav/Cruise-Target-v9"):
        main(["planetnav/Cruise-Target-v3", "planetnav/Cruise-Target-v9"])
    assert capsys.readouterr().out == ""


def test_host_mode_runs_the_device_envs_step_and_autoreset_loops() -> None:
    from planetnav_env.device import rows as R
    from planetnav_env.precompile import precompile_host_mode

    ids = ["planetnav/Cruise-Target-v3", "planetnav/Cruise-Torque-v3"]
    seconds = precompile_host_mode(ids)
    assert list(seconds) == ids
    # A target id and a Box id: their action arrays differ in layout, hence one signature each.
    assert len(R.step_rows.signatures) >= 2
    assert R.autoreset_rows.signatures


def test_host_mode_names_an_unknown_id_before_anything_compiles(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(ConfigError, match="planetnav/Cruise-Torque-v9"):
        main(["--host-mode", "planetnav/Cruise-Torque-v9"])
    assert capsys.readouterr().out == ""
