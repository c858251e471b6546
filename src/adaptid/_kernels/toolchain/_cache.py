"""Where numba caches adaptid's kernels, and when a cached kernel is stale.

numba keys each cached function on its own source file. adaptid's kernels
are built of inlined pieces from several files of :mod:`adaptid._kernels`
(the Bierman stages of ``recursions/_bierman.py`` inside the streams of
``recursions/_rls.py``, ...) and read :mod:`adaptid._config`, so an edit to
one of those files must invalidate the kernels built from it. The locators
below give a kernel the stamp of its own module's source, of every module of
``_kernels`` it imports (transitively) and of ``_config.py``
(:func:`module_stamp`; a parallel wrapper built by ``recursions/_parallel.py``
also covers the module of the ``run`` it wraps): an edit elsewhere leaves its
cache valid. Every
kernel of every subpackage is cached in one folder (numba's folder for
``_kernels``, which :func:`adaptid._config.cache_decision` checks). They also
refuse a cache folder that another user could write (numba unpickles the
index it finds there): it must be owned by the current user or root, not
writable by group or others, not a symbolic link, and so must every folder
above it (:func:`adaptid._config._untrusted`); otherwise the next locator is
tried, and with none the kernel is compiled in memory (numba's own rule).
Because the folder could be swapped after that check, every read of an index
or code file goes through :func:`read_trusted` (patch ``tolerant-cache``).

:func:`install` puts them in front of numba's locators (done on import of
:mod:`adaptid._kernels`, patch ``cache-locators``); functions outside
``_kernels`` are not affected. :func:`tolerate` (patch ``tolerant-cache``)
gives a kernel's cache the methods of ``_TolerantCache``.
"""

from __future__ import annotations

import ast
import hashlib
import os
import stat
from functools import lru_cache
from pathlib import Path

from numba.core import caching

from ._patches import codegen_key, enabled

__all__ = ["install", "installed", "tolerate", "module_stamp", "SOURCE_STAMP"]

#: the folder of every kernel (adaptid/_kernels)
_DIR = Path(__file__).resolve().parent.parent


def _source_stamp() -> str:
    h = hashlib.sha256()
    for path in sorted(_DIR.rglob("*.py")) + [_DIR.parent / "_config.py"]:
        h.update(path.relative_to(_DIR.parent).as_posix().encode())
        h.update(path.read_bytes())
    return h.hexdigest()


#: one stamp of all kernel sources (the manifest of the kernels compiled at install)
SOURCE_STAMP = _source_stamp()


def _module_path(parts):
    """The file of module ``adaptid._kernels.<parts>`` (a package's ``__init__.py``), or None."""
    base = _DIR.joinpath(*parts)
    for path in (base.with_suffix(".py"), base / "__init__.py"):
        if path.is_file():
            return path
    return None


def _imports(path: Path):
    """The ``_kernels`` files that ``path`` imports (relative imports, at any depth of code)."""
    pkg = list(path.relative_to(_DIR).parent.parts)
    out = set()
    for node in ast.walk(ast.parse(path.read_bytes())):
        if not isinstance(node, ast.ImportFrom) or node.level == 0:
            continue
        if node.level - 1 > len(pkg):
            continue  # above _kernels (adaptid._config: always in the stamp)
        base = pkg[:len(pkg) - (node.level - 1)] + (node.module.split(".") if node.module else [])
        for parent in range(1, len(base) + 1):  # the packages on the way are imported too
            found = _module_path(base[:parent])
            if found is not None:
                out.add(found)
        for alias in node.names:
            found = _module_path(base + [alias.name])
            if found is not None:
                out.add(found)
    out.discard(path)
    return out


@lru_cache(maxsize=None)
def module_stamp(py_file: str) -> str:
    """SHA-256 of the module ``py_file``, the ``_kernels`` modules it imports
    (transitively), ``_config.py`` and the switches that change compiled code."""
    start = Path(py_file).resolve()
    seen, todo = set(), [start]
    while todo:
        path = todo.pop()
        if path in seen:
            continue
        seen.add(path)
        todo.extend(_imports(path) - seen)
    h = hashlib.sha256(codegen_key().encode())
    for path in sorted(seen) + [_DIR.parent / "_config.py"]:
        h.update(path.relative_to(_DIR.parent).as_posix().encode())
        h.update(path.read_bytes())
    return h.hexdigest()


def _safe_folder(path) -> bool:
    """Owned by us or root, not writable by group or others, not a symbolic link,
    and every folder above it safe too (:func:`adaptid._config._untrusted`)."""
    from ... import _config
    return _config._untrusted(path) is None


class UntrustedCacheError(Exception):
    """The cache folder or one of its files changed since it was checked (not an
    ``OSError``: numba's readers turn those into a miss without a word)."""


def _trusted(st, is_kind) -> bool:
    """``st`` (an ``fstat``) is of kind ``is_kind``, owned by us or root, and not
    writable by group or others."""
    if not is_kind(st.st_mode):
        return False
    if not hasattr(os, "getuid"):  # pragma: no cover - Windows: no POSIX owners
        return True
    return st.st_uid in (os.getuid(), 0) and not st.st_mode & (stat.S_IWGRP | stat.S_IWOTH)


_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)
_DIRECTORY = getattr(os, "O_DIRECTORY", 0)
_CLOEXEC = getattr(os, "O_CLOEXEC", 0)
_NONBLOCK = getattr(os, "O_NONBLOCK", 0)


def read_trusted(folder, name) -> bytes:
    """The bytes of ``folder/name``, read only if neither can have been planted.

    The folder is opened without following a symbolic link and held: the
    descriptor must be the directory now at ``folder`` (``lstat``: same device
    and inode), owned by us or root and not writable by group or others, and
    the folders above it must pass :func:`adaptid._config._untrusted_ancestor`.
    The file is opened relative to the held descriptor, without following a
    symbolic link and without blocking, and must be a regular file owned by us
    or root that group and others cannot write. Entries of such a folder can
    only have been made by us or root, so a folder swapped after the
    import-time check is refused, not read.

    Raises ``FileNotFoundError`` when the file does not exist (a plain miss)
    and :class:`UntrustedCacheError` when anything else is wrong.
    """
    from ... import _config
    if not hasattr(os, "getuid") or not _NOFOLLOW or not _DIRECTORY \
            or os.open not in os.supports_dir_fd:  # pragma: no cover - not POSIX
        with open(os.path.join(folder, name), "rb") as fh:
            return fh.read()
    try:
        dfd = os.open(folder, os.O_RDONLY | _DIRECTORY | _NOFOLLOW | _CLOEXEC)
    except FileNotFoundError:
        raise
    except OSError as err:
        raise UntrustedCacheError(f"{folder} cannot be opened as a folder ({err.strerror})") \
            from None
    try:
        held = os.fstat(dfd)
        try:
            now = os.lstat(folder)
        except OSError as err:
            raise UntrustedCacheError(f"{folder} changed ({err.strerror})") from None
        if (held.st_dev, held.st_ino) != (now.st_dev, now.st_ino):
            raise UntrustedCacheError(f"{folder} was replaced")
        if not _trusted(held, stat.S_ISDIR):
            raise UntrustedCacheError(f"{folder} belongs to another user or others can "
                                      f"write it (uid {held.st_uid}, mode "
                                      f"{stat.S_IMODE(held.st_mode):o})")
        why = _config._untrusted_ancestor(folder)
        if why is not None:
            raise UntrustedCacheError(f"{folder} {why}")
        try:
            fd = os.open(name, os.O_RDONLY | _NOFOLLOW | _NONBLOCK | _CLOEXEC, dir_fd=dfd)
        except FileNotFoundError:
            raise
        except OSError as err:  # ELOOP: a symbolic link
            raise UntrustedCacheError(f"{os.path.join(folder, name)} cannot be opened "
                                      f"safely ({err.strerror})") from None
        with os.fdopen(fd, "rb") as fh:
            st = os.fstat(fh.fileno())
            if not _trusted(st, stat.S_ISREG):
                raise UntrustedCacheError(
                    f"{os.path.join(folder, name)} is not a regular file of this user or "
                    f"root that others cannot write (uid {st.st_uid}, mode "
                    f"{stat.S_IMODE(st.st_mode):o})")
            return fh.read()
    finally:
        os.close(dfd)


class _GuardedCacheFile(caching.IndexDataCacheFile):
    """numba's index and data files, read through :func:`read_trusted`
    (the same format as numba's ``_load_index`` and ``_load_data``)."""

    def _load_index(self):
        import io
        import pickle
        try:
            raw = read_trusted(self._cache_path, self._index_name)
        except FileNotFoundError:
            return {}  # no index yet
        f = io.BytesIO(raw)
        version = pickle.load(f)
        if version != self._version:
            return {}
        stamp, overloads = pickle.loads(f.read())
        return overloads if stamp == self._source_stamp else {}

    def _load_data(self, name):
        import pickle
        return pickle.loads(read_trusted(self._cache_path, name))


def _warn_untrusted(err) -> None:
    """One :class:`~adaptid.CompilationCacheWarning` per process for a refused cache."""
    global _WARNED
    if _WARNED:
        return
    _WARNED = True
    import warnings
    from ..._exceptions import CompilationCacheWarning
    warnings.warn(f"adaptid: the kernel cache is not read: {err}; kernels are compiled in "
                  "memory", CompilationCacheWarning, stacklevel=2)


_WARNED = False


def _ours(py_file) -> bool:
    try:
        return _DIR in Path(py_file).resolve().parents
    except OSError:  # pragma: no cover
        return False


class _KernelsLocator:
    """Mixin: only the functions of ``_kernels``; their stamp; one safe folder."""

    def get_source_stamp(self):
        if not self._sources:
            return ("adaptid-kernels", module_stamp(self._kernel_file))
        # a wrapper built for a function of another module (recursions/_parallel.py)
        h = hashlib.sha256()
        for path in (self._kernel_file, *self._sources):
            h.update(module_stamp(path).encode())
        return ("adaptid-kernels", h.hexdigest())

    @classmethod
    def from_function(cls, py_func, py_file):
        if not _ours(py_file):
            return None
        # numba's folder for _kernels, whatever the subpackage (what _config checks)
        self = super().from_function(py_func, str(_DIR / "__init__.py"))
        if self is None or not _safe_folder(self.get_cache_path()):
            return None
        self._kernel_file = str(Path(py_file).resolve())
        self._sources = tuple(str(Path(f).resolve())
                              for f in getattr(py_func, "__adaptid_sources__", ()))
        return self


class KernelsUserProvidedLocator(_KernelsLocator, caching.UserProvidedCacheLocator):
    """``NUMBA_CACHE_DIR``, when set."""


class KernelsInTreeLocator(_KernelsLocator, caching.InTreeCacheLocator):
    """``__pycache__`` beside the kernels (the installed package's folder)."""


class KernelsUserWideLocator(_KernelsLocator, caching.UserWideCacheLocator):
    """numba's per-user cache folder, for a read-only installation."""


_LOCATORS = (KernelsUserWideLocator, KernelsInTreeLocator, KernelsUserProvidedLocator)


def install() -> bool:
    """Put the locators of this module in front of numba's (idempotent).

    Not done when patch ``cache-locators`` is switched off (numba's own locators
    then cache each kernel with its own file's stamp). Returns whether they are in place.
    """
    from ... import _config

    _config.CACHE_HOOK = tolerate  # every cached kernel's dispatcher passes through it
    if not enabled("cache-locators"):
        return installed()
    classes = caching.CacheImpl._locator_classes
    for cls in _LOCATORS:
        if cls not in classes:
            classes.insert(0, cls)
    return True


def installed() -> bool:
    """Whether numba's locator list holds the locators of this module."""
    return any(cls in caching.CacheImpl._locator_classes for cls in _LOCATORS)


def _start_runtime(target_context):
    """What loading compiled code from the cache needs of numba's target: its runtime.

    numba's ``FunctionCache.load_overload`` first calls ``target_context.refresh()``,
    which also loads every typing and lowering registry of numba (and with them
    scipy.linalg, cffi, ...): about 0.2 s in the first process that loads a
    kernel, needed to *compile* but not to load compiled code. The code of a
    cached kernel needs the runtime (NRT) symbols only; a compilation that
    follows refreshes the context itself (``numba.core.compiler``).
    """
    from numba.core.runtime import rtsys
    rtsys.initialize(target_context)


#: ``load(cache, sig, target_context)`` of the kernels compiled at install, or None;
#: set by :func:`._installed.register` (when :mod:`adaptid._kernels` is imported)
INSTALLED = None


def _load_installed(cache, sig, target_context):
    """A miss: the kernel as compiled when adaptid was installed (:data:`INSTALLED`), or None."""
    if INSTALLED is None:
        return None
    try:
        return INSTALLED(cache, sig, target_context)
    except Exception:  # noqa: BLE001 - a damaged or foreign entry is a miss too
        return None


class _TolerantCache(caching.FunctionCache):
    """numba's FunctionCache whose load and save survive damaged files."""

    def load_overload(self, sig, target_context):
        try:
            return self._load_compiled(sig, target_context)
        except UntrustedCacheError as err:  # swapped or planted: never unpickled
            self._refused = True
            _warn_untrusted(err)
            return None     # a miss: numba compiles in memory
        except Exception:  # noqa: BLE001 - UnpicklingError, EOFError, OSError, ...
            self._drop_index()
            return None     # a miss: numba compiles

    def _load_compiled(self, sig, target_context):
        load = getattr(super(), "_load_overload", None)
        if load is None:                # other numba internals: numba's own path
            return super().load_overload(sig, target_context)
        _start_runtime(target_context)
        data = load(sig, target_context)
        return data if data is not None else _load_installed(self, sig, target_context)

    def save_overload(self, sig, data):
        if getattr(self, "_refused", False):
            return  # not into a folder that failed the check
        try:
            super().save_overload(sig, data)
        except UntrustedCacheError as err:
            self._refused = True
            _warn_untrusted(err)
        except Exception:  # noqa: BLE001 - the index was damaged: start it afresh
            self._drop_index()
            try:
                super().save_overload(sig, data)
            except Exception:  # noqa: BLE001 - caching is only an optimisation
                pass

    def _drop_index(self):
        try:
            self.flush()   # an empty index for this function (numba's own writer)
        except Exception:  # noqa: BLE001
            pass


def tolerate(dispatcher) -> None:
    """Give ``dispatcher``'s cache (numba's ``FunctionCache``) :class:`_TolerantCache`'s
    methods: an index or code file that cannot be unpickled (truncated, garbage)
    makes the kernel compile again and the entry be rewritten, and a miss is
    looked up in the kernels compiled at install. Its index and code files are
    read through :func:`read_trusted` (the folder re-verified on a held
    descriptor at every read): a folder swapped or a file planted since the
    import-time check is never unpickled; the kernel is compiled in memory,
    nothing is saved there, and one :class:`~adaptid.CompilationCacheWarning`
    says why. Nothing is done when patch
    ``tolerant-cache`` is off or numba's cache is of another class."""
    if not enabled("tolerant-cache"):
        return
    cache_obj = getattr(dispatcher, "_cache", None)
    if type(cache_obj) is caching.FunctionCache:
        cache_obj.__class__ = _TolerantCache
        if type(getattr(cache_obj, "_cache_file", None)) is caching.IndexDataCacheFile:
            cache_obj._cache_file.__class__ = _GuardedCacheFile
