"""The in-tree numba cache is dropped when the source its kernels were compiled from changes."""

from __future__ import annotations

from pathlib import Path

import pytest

from planetnav_env.numerics.numba_cache import STAMP_NAME, drop_stale_cache, source_digest


def _tree(tmp_path: Path) -> tuple[Path, Path, Path]:
    pkg = tmp_path / "pkg"
    (pkg / "sub" / "__pycache__").mkdir(parents=True)
    (pkg / "a.py").write_text("x = 1\n")
    (pkg / "sub" / "b.py").write_text("y = 2\n")
    nbi = pkg / "sub" / "__pycache__" / "b.f-1.py311.nbi"
    nbc = pkg / "sub" / "__pycache__" / "b.f-1.py311.1.nbc"
    return pkg, nbi, nbc


def _cache(nbi: Path, nbc: Path) -> None:
    nbi.write_bytes(b"index")
    nbc.write_bytes(b"code")


def test_cache_is_kept_while_the_source_is_unchanged_and_dropped_when_it_changes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    pkg, nbi, nbc = _tree(tmp_path)
    _cache(nbi, nbc)
    assert drop_stale_cache(pkg, [pkg])  # no record yet: whatever is cached may be stale
    assert not nbi.exists() and not nbc.exists()
    assert (pkg / "__pycache__" / STAMP_NAME).read_text() == source_digest([pkg])
    _cache(nbi, nbc)  # compiled from the recorded source
    assert not drop_stale_cache(pkg, [pkg])
    assert nbi.exists() and nbc.exists()
    (pkg / "a.py").write_text("x = 2\n")  # a callee in another file changes
    assert drop_stale_cache(pkg, [pkg])
    assert not nbi.exists() and not nbc.exists()
    assert (pkg / "sub" / "b.py").exists() and (pkg / "a.py").exists()  # only the cache goes


def test_a_dependency_outside_the_package_counts(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    pkg, nbi, nbc = _tree(tmp_path)
    dep = tmp_path / "dep"
    dep.mkdir()
    (dep / "k.py").write_text("def f(): pass\n")
    drop_stale_cache(pkg, [pkg, dep])
    _cache(nbi, nbc)
    (dep / "k.py").write_text("def f(): return 1\n")
    assert drop_stale_cache(pkg, [pkg, dep])
    assert not nbc.exists()


def test_a_user_cache_dir_is_left_alone(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    pkg, nbi, nbc = _tree(tmp_path)
    _cache(nbi, nbc)
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "elsewhere"))
    assert not drop_stale_cache(pkg, [pkg])
    assert nbi.exists() and nbc.exists()


def test_the_digest_sees_paths_and_contents(tmp_path: Path) -> None:
    pkg, _, _ = _tree(tmp_path)
    d0 = source_digest([pkg])
    (pkg / "a.py").rename(pkg / "c.py")
    assert source_digest([pkg]) != d0
