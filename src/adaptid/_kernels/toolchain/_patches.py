"""The registry of adaptid's patches of numba internals: name, switch, fallback.

Each patch reaches into numba beyond its public API (its cache classes, its
inliner, its dispatcher, LLVM IR) and each has a plain fallback that CI runs
(``.ci/run``: the core tests with ``ADAPTID_NUMBA_PATCHES=0``). A patch is on
unless its own switch or the master switch ``ADAPTID_NUMBA_PATCHES`` is
``"0"`` in the environment. The switches are read when the patch is applied
(on import of :mod:`adaptid._kernels`, or when a kernel is compiled), except
``ADAPTID_AOT`` and ``ADAPTID_STEP_ENTRY``, read at each use.
``adaptid info`` prints :func:`status`.
"""

from __future__ import annotations

import os
from typing import NamedTuple

__all__ = ["MASTER", "PATCHES", "Patch", "enabled", "status", "codegen_key"]

#: the master switch: ``ADAPTID_NUMBA_PATCHES=0`` turns every patch off
MASTER = "ADAPTID_NUMBA_PATCHES"


class Patch(NamedTuple):
    """One patch of numba internals."""

    name: str
    switch: str
    what: str
    fallback: str
    codegen: bool = False  # whether it changes the compiled code (part of the cache key)


PATCHES = (
    Patch("cache-locators", "ADAPTID_CACHE_LOCATORS",
          "numba's cache locators replaced: one trusted cache folder for all kernels, "
          "keyed on each kernel module's source and what it imports (toolchain._cache)",
          "numba's own locators (each file's stamp, numba's folder choice)"),
    Patch("tolerant-cache", "ADAPTID_TOLERANT_CACHE",
          "a damaged cache file is a miss; loading starts numba's runtime only "
          "(toolchain._cache.tolerate)",
          "numba's FunctionCache as it is"),
    Patch("installed-kernels", "ADAPTID_AOT",
          "a cache miss loads the kernel compiled at install (toolchain._installed)",
          "numba compiles on a miss"),
    Patch("fast-inline", "ADAPTID_FAST_INLINE",
          "numba's inliner copies an inlined IR once, not once per block (toolchain._inline)",
          "numba's own inliner"),
    Patch("vector-ir", "ADAPTID_VECTOR_IR",
          "the sweeps of the square-root and covariance forms as hand-built LLVM vector IR "
          "for a compile-time n (toolchain._potter_ir, toolchain._covsweep)",
          "the same sweeps as plain loops (the run-time-n code)", codegen=True),
    Patch("stack-scratch", "ADAPTID_STACK_SCRATCH",
          "work arrays of a compile-time size as stack allocas (toolchain._scratch, "
          "toolchain._lanes_ir)",
          "np.empty", codegen=True),
    Patch("step-entry", "ADAPTID_STEP_ENTRY",
          "update takes the narrow step entry through numba's dispatcher privates "
          "(toolchain._dispatch)",
          "update is a run of length 1 through run's compiled code"),
)

_BY_NAME = {p.name: p for p in PATCHES}


def enabled(name: str) -> bool:
    """Whether patch ``name`` is switched on (neither its switch nor the master is "0")."""
    patch = _BY_NAME[name]
    return os.environ.get(MASTER, "1") != "0" and os.environ.get(patch.switch, "1") != "0"


def codegen_key() -> str:
    """The switches that change compiled code, as a string for the cache key."""
    return ",".join(f"{p.name}={int(enabled(p.name))}" for p in PATCHES if p.codegen)


def status(applied=None) -> list:
    """One dict per patch: name, switch, on (switched on), applied (in effect in this
    process: ``applied[name]`` where the caller could tell, else ``on``), what, fallback."""
    applied = applied or {}
    return [{"name": p.name, "switch": p.switch, "on": enabled(p.name),
             "applied": bool(applied.get(p.name, enabled(p.name))), "what": p.what,
             "fallback": p.fallback} for p in PATCHES]
