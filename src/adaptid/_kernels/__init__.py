"""Layer 1: every numba-compiled function of adaptid, split by algorithm.

* :mod:`._bierman` — the U-D (Bierman) building blocks shared by all streams;
* :mod:`._rls`, :mod:`._strategy`, :mod:`._kalman`, :mod:`._window`,
  :mod:`._lms` — one
  module per recursive algorithm, each with the three entry points of one
  common signature (``run``, ``run_batched``, ``run_segments``; ``update`` is
  a run of length 1, or for RLS's fast forms a step through the narrow entry
  of :mod:`._step` when that is compiled);
* :mod:`._diffuse`, :mod:`._diffuse_kalman` — the exact diffuse start
  (``P0="diffuse"``) of RLS, the window and the Kalman filter, a prologue
  before the ordinary streams, with the same three entry points;
* :mod:`._rollstats` — the windowed statistics of ``run(..., stats=True)``,
  inlined into the RLS and window streams (output ``St`` of the common
  signature: an array of N + 1 rows when asked for, None when not, chosen at
  compile time);
* :mod:`._potter`, :mod:`._covariance` — RLS in square-root and covariance form
  (``RLS(form=...)``), same three entry points; their sweeps for a
  compile-time n are LLVM vector IR (:mod:`._covsweep`, helpers in
  :mod:`._vecir`);
* :mod:`._step` — the packed sample of ``update``'s narrow step entry
  (``rls_step``, ``potter_step``, ``cov_step``) and the look-up that takes it
  only when it costs no compilation;
* :mod:`._dims` — the tags that make n and p compile-time constants
  (specialisation per n without generating source), :mod:`._scratch` —
  stack-allocated work arrays.

Nothing here validates input or holds Python objects; the estimators
(:mod:`adaptid.estimators`) do that and call one entry point per call.
"""

from __future__ import annotations

from typing import NamedTuple

__all__ = ["Entries", "RLS", "STRATEGY", "KALMAN", "WINDOW", "LMS", "NLMS", "RLS_DIFFUSE",
           "WINDOW_DIFFUSE", "KALMAN_DIFFUSE", "POTTER", "COVARIANCE", "tags"]

from ._cache import install as _install_cache
from ._dims import tags
from ._inline import install as _install_inline
from ._installed import register as _register_installed

_install_cache()  # before any kernel module is imported (they are submodules of this package)
_register_installed()  # a cache miss loads the kernel compiled at install, if it matches
_install_inline()  # numba's inliner copies an inlined IR once, not once per block


class Entries(NamedTuple):
    """The compiled entry points of one algorithm (one signature for all).

    ``step`` (RLS's fast forms only, else None) takes one packed sample
    (:mod:`._step`); ``update`` calls it only when that costs no compilation
    (compiled at install, or already cached) and otherwise runs a run of length 1
    through ``run``, with arguments of the types ``run`` is given
    (:meth:`adaptid.estimators._engine.RecursiveEstimator.update`). Either way a
    step is bit for bit a step of ``run``.
    """

    run: object
    run_batched: object
    run_segments: object
    step: object = None


def _entries(module, prefix):
    import importlib
    mod = importlib.import_module(f"adaptid._kernels.{module}")
    return Entries(*(getattr(mod, f"{prefix}_{what}")
                     for what in ("run", "run_batched", "run_segments")),
                   step=getattr(mod, f"{prefix}_step", None))


def __getattr__(name):
    # loaded on first use, so that importing one algorithm does not load numba
    # dispatchers of the others
    table = {"RLS": ("_rls", "rls"), "STRATEGY": ("_strategy", "strategy"),
             "KALMAN": ("_kalman", "kalman"), "WINDOW": ("_window", "window"),
             "LMS": ("_lms", "lms"), "NLMS": ("_lms", "nlms"),
             "RLS_DIFFUSE": ("_diffuse", "rls_diffuse"),
             "WINDOW_DIFFUSE": ("_diffuse", "window_diffuse"),
             "KALMAN_DIFFUSE": ("_diffuse_kalman", "kalman_diffuse"),
             "POTTER": ("_potter", "potter"), "COVARIANCE": ("_covariance", "cov")}
    if name in table:
        value = _entries(*table[name])
        globals()[name] = value
        return value
    raise AttributeError(f"module 'adaptid._kernels' has no attribute {name!r}")
