"""Layer 1: every numba-compiled function of adaptid, in four rooms by concern.

* :mod:`.recursions` — the recursive algorithms (RLS in U-D, square-root and
  covariance form, forgetting strategies, Kalman, sliding window, LMS, the
  exact diffuse start, the windowed statistics), each module with the
  entry points of one common signature (``run``, ``run_batched``,
  ``run_segments``; ``update`` is a run of length 1, or for RLS's fast forms
  a step through the narrow entry ``step``) declared in its ``ENTRIES``
  table;
* :mod:`.lanes` — the structure-of-arrays (SIMD) kernels over many streams;
* :mod:`.layers` — the compiled loops of the later layers (diagnostics,
  models, datasets, fleet);
* :mod:`.toolchain` — everything that touches numba's internals (cache,
  install-time kernels, inliner, typing templates, LLVM IR, dispatcher), each
  patch switchable (:mod:`.toolchain._patches`).

The public names below (``RLS``, ``WINDOW``, ...) are the :class:`Entries` of
one algorithm, loaded on first use from the module and key of :data:`ENTRY_TABLE`.
Nothing here validates input or holds Python objects; the estimators
(:mod:`adaptid.estimators`) do that and call one entry point per call.
"""

from __future__ import annotations

import importlib

__all__ = ["Entries", "RLS", "STRATEGY", "KALMAN", "WINDOW", "LMS", "NLMS", "RLS_DIFFUSE",
           "WINDOW_DIFFUSE", "KALMAN_DIFFUSE", "POTTER", "COVARIANCE", "tags"]

from .toolchain._cache import install as _install_cache
from .toolchain._inline import install as _install_inline
from .toolchain._installed import register as _register_installed

_install_cache()  # before any kernel module is imported (they are submodules of this package)
_register_installed()  # a cache miss loads the kernel compiled at install, if it matches
_install_inline()  # numba's inliner copies an inlined IR once, not once per block

from .recursions._entries import Entries  # noqa: E402 - after the cache is in place
from .toolchain._dims import tags  # noqa: E402

#: public name -> (module of .recursions, key of its ``ENTRIES`` table)
ENTRY_TABLE = {
    "RLS": ("_rls", "RLS"),
    "STRATEGY": ("_strategy", "STRATEGY"),
    "KALMAN": ("_kalman", "KALMAN"),
    "WINDOW": ("_window", "WINDOW"),
    "LMS": ("_lms", "LMS"),
    "NLMS": ("_lms", "NLMS"),
    "RLS_DIFFUSE": ("_diffuse", "RLS_DIFFUSE"),
    "WINDOW_DIFFUSE": ("_diffuse", "WINDOW_DIFFUSE"),
    "KALMAN_DIFFUSE": ("_diffuse_kalman", "KALMAN_DIFFUSE"),
    "POTTER": ("_potter", "POTTER"),
    "COVARIANCE": ("_covariance", "COVARIANCE"),
}


def __getattr__(name):
    # loaded on first use, so that importing one algorithm does not load numba
    # dispatchers of the others
    if name in ENTRY_TABLE:
        module, key = ENTRY_TABLE[name]
        value = importlib.import_module(f"{__name__}.recursions.{module}").ENTRIES[key]
        globals()[name] = value
        return value
    raise AttributeError(f"module 'adaptid._kernels' has no attribute {name!r}")
