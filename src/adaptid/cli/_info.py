"""``adaptid info``: versions, numba's threading layer and target CPU, the kernels compiled
at install, the patches of numba internals in effect, installed extras."""

from __future__ import annotations

import os
import platform
import sys

__all__ = ["gather_info"]


def _version(dist: str):
    from importlib import metadata

    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return None


def _extras() -> dict:
    """extra → {"installed": bool, "missing": [requirement, ...]} from adaptid's metadata."""
    from importlib import metadata

    try:
        reqs = metadata.requires("adaptid") or []
    except metadata.PackageNotFoundError:
        return {}
    try:
        from packaging.requirements import Requirement
    except ImportError:  # pragma: no cover - packaging ships with pip/setuptools
        Requirement = None
    extras = {}
    for text in reqs:
        if "extra ==" not in text:
            continue
        spec, marker = text.split(";", 1)
        extra = marker.split("==", 1)[1].strip().strip("'\"")
        if Requirement is not None:
            req = Requirement(spec)
            name, specifier = req.name, req.specifier
        else:
            import re
            name = re.split(r"[<>=!~\[ ]", spec.strip(), maxsplit=1)[0]
            specifier = None
        if name == "adaptid":
            continue
        have = _version(name)
        ok = have is not None and (specifier is None or specifier.contains(have, prereleases=True))
        entry = extras.setdefault(extra, {"installed": True, "missing": []})
        if not ok:
            entry["installed"] = False
            entry["missing"].append(spec.strip() + ("" if have is None else f" (have {have})"))
    return extras


def gather_info() -> dict:
    import numba
    import numpy as np
    import scipy

    import adaptid
    from adaptid._kernels.toolchain import _installed, patch_status
    from adaptid._kernels.toolchain._vecir import target_cpu

    configured = numba.config.THREADING_LAYER
    # a tiny call of a parallel (prange) kernel makes numba choose its layer
    try:
        adaptid.RLS(1).run_batched(np.ones((2, 2, 1)), np.ones((2, 2)))
        layer = numba.threading_layer()
    except Exception as err:  # noqa: BLE001 - report, do not fail `info`
        layer = f"unavailable ({type(err).__name__}: {err})"
    return {
        "adaptid": adaptid.__version__,
        "python": platform.python_version(),
        "implementation": platform.python_implementation(),
        "platform": platform.platform(),
        "executable": sys.executable,
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "numba": numba.__version__,
        "numba_threading_layer_config": configured,
        "numba_threading_layer": layer,
        "numba_num_threads": int(numba.config.NUMBA_NUM_THREADS),
        # the CPU the kernels are compiled (and cached) for; some tuning follows it
        "numba_target_cpu": target_cpu(),
        # the kernels compiled when adaptid was installed (adaptid._kernels.toolchain._installed)
        "compiled_at_install": _installed.status(),
        # adaptid's patches of numba internals (adaptid._kernels.toolchain._patches):
        # name, switch, on, applied, what, fallback
        "numba_patches": patch_status(),
        "cpu_count": os.cpu_count(),
        "extras": _extras(),
    }
