"""Where numba caches adaptid's kernels, and when a cached kernel is stale.

numba keys each cached function on its own source file. adaptid's kernels
are built of inlined pieces from several files of this folder (the Bierman
stages of :mod:`._bierman` inside the streams of :mod:`._rls`, ...) and read
:mod:`adaptid._config`, so an edit to one file must invalidate the cache of
all of them. The locators below give every kernel of this folder one source
stamp: the SHA-256 of all these files' contents. They also refuse a cache
folder that another user could write (numba unpickles the index it finds
there): it must be owned by the current user or root and not writable by
group or others; otherwise the next locator is tried, and with none the
kernel is compiled in memory (numba's own rule).

:func:`install` puts them in front of numba's locators (done on import of
:mod:`adaptid._kernels`); functions outside this folder are not affected.
"""

from __future__ import annotations

import hashlib
import os
import stat
from pathlib import Path

from numba.core import caching

__all__ = ["install", "SOURCE_STAMP"]

_DIR = Path(__file__).resolve().parent


def _source_stamp() -> str:
    h = hashlib.sha256()
    for path in sorted(_DIR.glob("*.py")) + [_DIR.parent / "_config.py"]:
        h.update(path.name.encode())
        h.update(path.read_bytes())
    return h.hexdigest()


#: one stamp for every kernel: changes whenever any file of the kernels changes
SOURCE_STAMP = _source_stamp()


def _safe_folder(path) -> bool:
    """Owned by us or root, and not writable by group or others."""
    try:
        st = os.stat(path)
    except OSError:
        return False
    if not hasattr(os, "getuid"):  # pragma: no cover - Windows: no POSIX owners
        return True
    if st.st_uid not in (os.getuid(), 0):
        return False
    return not st.st_mode & (stat.S_IWGRP | stat.S_IWOTH)


class _KernelsLocator:
    """Mixin: only this folder's functions; the shared stamp; a safe folder."""

    def get_source_stamp(self):
        return ("adaptid-kernels", SOURCE_STAMP)

    @classmethod
    def from_function(cls, py_func, py_file):
        try:
            if Path(py_file).resolve().parent != _DIR:
                return None
        except OSError:  # pragma: no cover
            return None
        self = super().from_function(py_func, py_file)
        if self is None or not _safe_folder(self.get_cache_path()):
            return None
        return self


class KernelsUserProvidedLocator(_KernelsLocator, caching.UserProvidedCacheLocator):
    """``NUMBA_CACHE_DIR``, when set."""


class KernelsInTreeLocator(_KernelsLocator, caching.InTreeCacheLocator):
    """``__pycache__`` beside the kernels (the installed package's folder)."""


class KernelsUserWideLocator(_KernelsLocator, caching.UserWideCacheLocator):
    """numba's per-user cache folder, for a read-only installation."""


def install() -> None:
    """Put the locators of this module in front of numba's (idempotent)."""
    classes = caching.CacheImpl._locator_classes
    for cls in (KernelsUserWideLocator, KernelsInTreeLocator, KernelsUserProvidedLocator):
        if cls not in classes:
            classes.insert(0, cls)
