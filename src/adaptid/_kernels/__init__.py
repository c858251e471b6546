"""Compiled kernels, specialised per number of parameters.

``get(n)`` returns a module with the kernels of :mod:`._ud`. For
``n <= MAX_SPECIALISED_N`` it is a copy of ``_ud.py`` in which every line
``NP = <shape>  # @np`` reads ``NP = n``: with the trip counts known at
compile time LLVM unrolls the small loops and keeps the factor in registers
(measured 1.11-1.16 × the updates/s of the generic kernel for n = 4..16, see BENCHMARKS.md).
The copies are written once to a cache folder (``ADAPTID_KERNEL_DIR``, else
``~/.cache/adaptid``, else a temporary folder), so that numba's on-disk cache
(``cache=True``) works for them as for any module; each is compiled on first
use of a kernel.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import re
import sys
import tempfile
import threading
from pathlib import Path

from .. import _config
from . import _ud

__all__ = ["get", "generic"]

generic = _ud
_lock = threading.Lock()
_modules: dict[int, object] = {}
_NP_LINE = re.compile(r"^(\s*)NP = .*# @np$", re.MULTILINE)


def _source() -> str:
    return Path(_ud.__file__).read_text(encoding="utf-8")


def _cache_root() -> Path:
    env = os.environ.get("ADAPTID_KERNEL_DIR")
    candidates = [Path(env)] if env else []
    candidates.append(Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "adaptid")
    candidates.append(Path(tempfile.gettempdir()) / f"adaptid-{os.getuid() if hasattr(os, 'getuid') else 'u'}")
    for root in candidates:
        try:
            root.mkdir(parents=True, exist_ok=True)
            probe = root / f".probe-{os.getpid()}"
            probe.write_text("")
            probe.unlink()
            return root
        except OSError:
            continue
    raise OSError("adaptid: no writable folder for compiled kernels; set ADAPTID_KERNEL_DIR")


def _specialised_source(n: int) -> str:
    src = _source()
    # the copy lives outside the package: make the relative import absolute
    src = src.replace("from .._config import", "from adaptid._config import")
    src = src.replace("from ._scratch import", "from adaptid._kernels._scratch import")
    # numba's cache does not see changes to imported helpers: name them in the copy
    helper = hashlib.sha256((Path(__file__).parent / "_scratch.py").read_bytes()).hexdigest()[:16]
    src += f"\n# _scratch.py: {helper}\n"
    out, count = _NP_LINE.subn(lambda m: f"{m.group(1)}NP = {n}", src)
    if count == 0:  # pragma: no cover - guards the template's contract
        raise RuntimeError("kernel template has no '# @np' lines")
    return out


def _load(n: int):
    src = _specialised_source(n)
    digest = hashlib.sha256(src.encode()).hexdigest()[:16]
    name = f"adaptid_kernels_n{n}_{digest}"
    if name in sys.modules:
        return sys.modules[name]
    folder = _cache_root() / "kernels"
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.py"
    if not path.exists() or path.read_text(encoding="utf-8") != src:
        tmp = folder / f".{name}.{os.getpid()}.{threading.get_ident()}.tmp"
        tmp.write_text(src, encoding="utf-8")
        os.replace(tmp, path)  # atomic: concurrent processes see old or new, never half
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        sys.modules.pop(name, None)
        raise
    return module


def get(n: int):
    """Kernels for ``n`` parameters (specialised when small enough)."""
    if n > _config.MAX_SPECIALISED_N or os.environ.get("NUMBA_DISABLE_JIT") == "1":
        return _ud
    mod = _modules.get(n)
    if mod is None:
        with _lock:
            mod = _modules.get(n)
            if mod is None:
                try:
                    mod = _load(n)
                except OSError:
                    mod = _ud  # no writable folder: the generic kernels still work
                _modules[n] = mod
    return mod
