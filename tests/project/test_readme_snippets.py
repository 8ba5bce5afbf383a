"""Every ```python block of the README runs as written, each in a fresh interpreter from the repository root,
with every warning an error (Gymnasium's, among them its "out of date" DeprecationWarning for an old id, and
planetnav's: planetnav defines no warning category of its own and warns with DeprecationWarning, as its
deprecated names do) and ResourceWarning shown, and leaves no file open (an unclosed file, such as the
DE421 kernel, fails it)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from test_readme import PYTHON_BLOCKS

ROOT = Path(__file__).resolve().parents[2]

#: Run before a block. Gymnasium's logger adds a "once" filter for its DeprecationWarnings when it is
#: imported, in front of any filter set earlier (``-W error`` included): it is imported first, and the
#: filters go in front of it. ResourceWarning is shown rather than raised: one raised in a finalizer or
#: at exit is dropped (Python prints "Exception ignored" or nothing and exits 0); shown, it is on stderr.
PRELUDE = """\
import gc as _gc, io as _io, warnings as _warnings
import gymnasium as _gymnasium
_warnings.simplefilter("error")
_warnings.simplefilter("always", ResourceWarning)
_FILES = (_io.FileIO, _io.BufferedReader, _io.BufferedWriter, _io.BufferedRandom, _io.TextIOWrapper)
_OPEN_BEFORE = {id(f) for f in _gc.get_objects() if type(f) in _FILES and not f.closed}
"""
#: Run after a block: the files it opened are closed (gc first, so a file only waiting for collection
#: counts as closed only if collecting it closes it, which is what ResourceWarning then reports).
EPILOGUE = """
_gc.collect()
_left = [getattr(f, "name", f) for f in _gc.get_objects()
         if type(f) in _FILES and not f.closed and id(f) not in _OPEN_BEFORE]
assert not _left, f"the block left files open: {_left}"
"""


def run_strict(code: str) -> subprocess.CompletedProcess:
    """Run ``code`` between PRELUDE and EPILOGUE in a fresh interpreter from the repository root."""
    return subprocess.run(
        [sys.executable, "-X", "dev", "-c", PRELUDE + code + EPILOGUE],
        cwd=ROOT, capture_output=True, text=True, timeout=600, check=False,
    )  # fmt: skip


def _failure(done: subprocess.CompletedProcess) -> str | None:
    if done.returncode != 0:
        return f"exit {done.returncode}:\n{done.stderr}"
    if "Warning" in done.stderr:
        return f"warned:\n{done.stderr}"
    return None


@pytest.mark.parametrize("index", range(len(PYTHON_BLOCKS)))
def test_readme_python_block_runs_without_warnings(index: int) -> None:
    done = run_strict(PYTHON_BLOCKS[index])
    failure = _failure(done)
    assert failure is None, f"README python block {index}:\n{PYTHON_BLOCKS[index]}\n{failure}"


def test_an_old_id_fails() -> None:
    """The check can fail: the first block on the -v0 id raises Gymnasium's "out of date" warning."""
    block = PYTHON_BLOCKS[0]
    assert "Cruise-Target-v3" in block
    done = run_strict(block.replace("Cruise-Target-v3", "Cruise-Target-v0"))
    assert done.returncode != 0 and "out of date" in done.stderr, done.stderr


def test_an_unregistered_id_fails() -> None:
    done = run_strict(PYTHON_BLOCKS[0].replace("Cruise-Target-v3", "Cruise-Target-v99"))
    assert done.returncode != 0


def test_a_file_left_open_fails() -> None:
    """An unclosed file fails the check, whether or not its ResourceWarning gets printed."""
    done = run_strict("handle = open('README.md')\n")
    assert _failure(done) is not None and "left files open" in done.stderr, done.stderr
    done = run_strict("open('README.md')\n")  # collected at once: its ResourceWarning is shown
    assert _failure(done) is not None and "ResourceWarning" in done.stderr, done.stderr
