"""Numba's on-disk cache of a source checkout, dropped when the source it was compiled from changes.

The kernels are compiled with ``cache=True``. Numba keys a cached kernel on its own source file only: after
an edit to a function it calls from another file, the caller's stale machine code is still loaded, and
the numbers are silently the old ones. :func:`drop_stale_cache` runs when a package is imported, before
any of its kernels is declared: it hashes the source the package's kernels can call and, when the hash
differs from the one stored beside the cache, deletes the package's cached kernels (``*.nbi``, ``*.nbc``
in its ``__pycache__`` folders) so that they compile afresh.

It only touches the in-tree cache. A user-chosen ``NUMBA_CACHE_DIR`` is left to its owner, and an
installed (not editable) package does not change under its cache.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
from collections.abc import Sequence
from pathlib import Path

#: Name of the file, in the package's top ``__pycache__``, that holds the hash of the source last compiled.
STAMP_NAME = "planetnav_numba_source.sha256"


def source_digest(roots: Sequence[Path]) -> str:
    """sha256 over every ``*.py`` file under ``roots`` (relative path and content, in a fixed order)."""
    h = hashlib.sha256()
    for root in roots:
        for path in sorted(root.rglob("*.py")):
            h.update(path.relative_to(root).as_posix().encode())
            h.update(b"\0")
            h.update(path.read_bytes())
    return h.hexdigest()


def drop_stale_cache(package_dir: Path, source_roots: Sequence[Path]) -> bool:
    """Delete ``package_dir``'s cached kernels if the source under ``source_roots`` changed since they were
    compiled; True when it deleted (or found no record of) a cache. Errors of the file system are not
    raised: at worst the kernels compile again."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return False
    digest = source_digest(source_roots)
    stamp = package_dir / "__pycache__" / STAMP_NAME
    with contextlib.suppress(OSError):
        if stamp.read_text() == digest:
            return False
    for cached in [*package_dir.rglob("*.nbi"), *package_dir.rglob("*.nbc")]:
        with contextlib.suppress(OSError):
            cached.unlink()
    with contextlib.suppress(OSError):
        stamp.parent.mkdir(exist_ok=True)
        stamp.write_text(digest)
    return True
