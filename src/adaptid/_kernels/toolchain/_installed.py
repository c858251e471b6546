"""Kernels compiled when adaptid was installed (ahead of time), loaded on a cache miss.

numba compiles a kernel the first time a process calls it with new argument
types and keeps the machine code in its cache folder (:mod:`adaptid._config`).
On a fresh install that folder is empty, and the first ``RLS(n).run`` or
``adaptid demo`` spends most of its time in numba's compiler. So ``pip
install`` compiles the kernels that first calls need, once, at build time
(the build backend ``tools/pep517/aot_backend.py`` runs ``python -m
adaptid.cli._aot build``, which lists them), and ships numba's cache files of
them in ``adaptid/_kernels/_aot`` with a ``MANIFEST.json``.

At run time a miss in the cache folder falls back to that folder
(:func:`load`, which :func:`register` hands to the tolerant cache of :mod:`._cache`
when :mod:`adaptid._kernels` is imported), when

* patch ``installed-kernels`` is on: neither ``ADAPTID_AOT`` nor
  ``ADAPTID_NUMBA_PATCHES`` is ``0`` (``ADAPTID_AOT_DIR`` names another folder);
* the folder is trusted as a cache folder is (owned by the user or root,
  not writable by group or others: numba's cache files are pickles);
* its manifest names this numba version and the kernels' source stamp
  (:data:`adaptid._kernels.toolchain._cache.SOURCE_STAMP`): an edit to any kernel
  file, or another numba, makes every entry stale (and each entry carries its
  kernel's own stamp, :func:`._cache.module_stamp`);
* and the entry's key matches, which numba builds from the signature, the
  target CPU (name and features) and the function's bytecode: code compiled
  on another kind of machine is never used.

Anything else is a miss, and numba compiles as it would without this
folder. What the folder holds is exactly what numba compiled from the same
source for the same signatures; nothing is changed on the way.
"""

from __future__ import annotations

import json
import os

__all__ = ["AOT_DIR", "MANIFEST", "enabled", "folder", "load", "merge", "register", "status"]

#: Where the installed kernels are (inside the package: as trusted as its code).
AOT_DIR = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "_aot")
#: The folder's description: numba version, source stamp, entries, build time.
MANIFEST = "MANIFEST.json"


def folder() -> str:
    """:data:`AOT_DIR`, or ``ADAPTID_AOT_DIR`` when set (read at each call)."""
    return os.environ.get("ADAPTID_AOT_DIR") or AOT_DIR


def enabled() -> bool:
    """False when ``ADAPTID_AOT=0`` or ``ADAPTID_NUMBA_PATCHES=0`` (read at each call:
    tests switch it)."""
    from ._patches import enabled as on
    return on("installed-kernels")


#: folder -> its manifest if usable, else None (the folder is checked once)
_READY = {}


def _manifest(where=None):
    try:
        with open(os.path.join(where or folder(), MANIFEST), encoding="utf-8") as fh:
            return json.load(fh)
    except (OSError, ValueError):
        return None


def _ready():
    """The manifest if the folder can be used by this process, else None (memoised)."""
    where = folder()
    if where in _READY:
        return _READY[where]
    import numba

    from ..._config import _untrusted
    from ._cache import SOURCE_STAMP

    man = _manifest(where)
    ok = (man is not None and _untrusted(where) is None
          and man.get("numba") == numba.__version__ and man.get("stamp") == SOURCE_STAMP)
    _READY[where] = man if ok else None
    return _READY[where]


def load(cache, sig, target_context):
    """The installed compile result of ``cache``'s function for ``sig``, or None.

    ``cache`` is numba's ``FunctionCache`` of a kernel (its locator one of
    :mod:`adaptid._kernels.toolchain._cache`'s); the entry is read as numba reads its own
    cache (``IndexDataCacheFile``) and rebuilt by the cache's own ``rebuild``.
    """
    if not enabled() or _ready() is None:
        return None
    from numba.core.caching import IndexDataCacheFile

    from ._cache import _KernelsLocator

    impl = cache._impl
    if not isinstance(impl.locator, _KernelsLocator):
        return None
    store = IndexDataCacheFile(cache_path=folder(), filename_base=impl.filename_base,
                               source_stamp=impl.locator.get_source_stamp())
    data = store.load(cache._index_key(sig, target_context.codegen()))
    return None if data is None else impl.rebuild(target_context, data)


def register() -> None:
    """Let a miss of a kernel's cache (:mod:`._cache`) fall back to :func:`load`."""
    from . import _cache

    _cache.INSTALLED = load


def status() -> dict:
    """What ``adaptid info`` shows: the folder, whether it is used, and why not."""
    import numba

    from ._cache import SOURCE_STAMP

    man = _manifest()
    out = {"folder": folder(), "enabled": enabled(), "kernels": 0, "used": False}
    if man is None:
        out["why_not"] = "not built (pip install builds it; ADAPTID_AOT_BUILD=0 skips it)"
        return out
    out["kernels"] = int(man.get("entries", 0))
    out["seconds_to_build"] = man.get("seconds")
    if man.get("numba") != numba.__version__:
        out["why_not"] = f"built with numba {man.get('numba')}, this is numba {numba.__version__}"
    elif man.get("stamp") != SOURCE_STAMP:
        out["why_not"] = "built from other kernel sources (edited since the install)"
    elif not out["enabled"]:
        out["why_not"] = ("ADAPTID_AOT=0" if os.environ.get("ADAPTID_AOT") == "0"
                          else "ADAPTID_NUMBA_PATCHES=0")
    elif _ready() is None:
        out["why_not"] = "the folder is writable by others or belongs to another user"
    else:
        out["used"] = True
    return out


def merge(folders, out):
    """Copy every adaptid kernel's entries of numba's cache ``folders`` into ``out``,
    renumbering the data files, with numba's own index format. Returns the count."""
    import pickle

    import numba
    from numba.core.caching import IndexDataCacheFile

    merged, stamps = {}, {}  # filename base -> {key: data bytes}, its source stamp
    for folder in folders:
        for root, _, files in os.walk(folder):
            for fn in files:
                if not fn.endswith(".nbi"):
                    continue
                with open(os.path.join(root, fn), "rb") as fh:
                    version = pickle.load(fh)
                    if version != numba.__version__:
                        continue
                    got, overloads = pickle.loads(fh.read())
                if not (isinstance(got, tuple) and got[:1] == ("adaptid-kernels",)):
                    continue  # not one of the kernels
                stamps[fn[:-4]] = got  # the kernel's own stamp (._cache.module_stamp)
                entries = merged.setdefault(fn[:-4], {})
                for key, data_name in overloads.items():
                    with open(os.path.join(root, data_name), "rb") as fh:
                        entries[key] = fh.read()
    count = 0
    for base, entries in merged.items():
        store = IndexDataCacheFile(cache_path=out, filename_base=base, source_stamp=stamps[base])
        index = {}
        for i, (key, blob) in enumerate(entries.items(), 1):
            name = f"{base}.{i}.nbc"
            with open(os.path.join(out, name), "wb") as fh:
                fh.write(blob)
            index[key] = name
            count += 1
        store._save_index(index)
    return count
