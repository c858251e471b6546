"""The one factory of the parallel (``prange``) wrappers over independent streams.

An algorithm's ``run`` (the common signature of :mod:`adaptid._kernels`) runs
one stream; :func:`batched` and :func:`segments` build, for a given ``run``,

* ``<name>_run_batched``: B streams of a batch, parallel over the streams,
  ``codes[b]`` as ``run`` returns (``St`` handed down per stream when the
  algorithm keeps statistics, else None);
* ``<name>_run_segments``: G streams stored back to back (rows
  ``offsets[g]:offsets[g+1]``), each from ``S0``, parallel over segments,
  segment g bit for bit ``run`` from ``S0`` (``St`` must be None).

The wrappers are the templates below with ``run`` as a global of their own
(no closure: numba's cache key would then hold a pickle of ``run``, different
in every process), compiled with the options of every parallel kernel. Their
cache stamp covers ``run``'s module too (``__adaptid_sources__``, read by
``toolchain/_cache.py``).
"""

import threading
import types
from contextlib import nullcontext

import numba
from numba import prange

from ..._config import NJIT_PARALLEL, njit
from ._bierman import _segment_start
from ._rollstats import sub

__all__ = ["batched", "segments", "parallel_guard"]

#: held around every call of a parallel kernel when numba's threading layer is
#: "workqueue": that layer is not thread-safe and aborts the whole process
#: ("Concurrent access has been detected") when two Python threads enter
#: parallel code at once (NUMBA_THREADING_LAYER=workqueue, or the default
#: choice when neither TBB nor OpenMP is available)
_SERIAL = threading.RLock()  # re-entrant: the fleet holds it around run_segments
_FREE = nullcontext()
#: the layer in use, once numba has chosen it (at the first parallel call)
_LAYER = []


def parallel_guard():
    """The context around a call of a parallel kernel (``run_batched``,
    ``run_segments``): the module lock ``_SERIAL`` under the workqueue layer
    (calls from several threads wait for each other instead of aborting the
    process), no lock under the thread-safe layers (TBB, OpenMP). Until the
    first parallel call has fixed the layer, calls are serialised too."""
    if _LAYER:
        return _SERIAL if _LAYER[0] == "workqueue" else _FREE
    if str(numba.config.THREADING_LAYER).lower() == "workqueue":
        return _SERIAL
    try:
        _LAYER.append(numba.threading_layer())
    except ValueError:  # no parallel kernel has run yet: the layer is not chosen
        return _SERIAL
    return parallel_guard()


def _batched_stats(S, Phi, Y, lam, w, Th, E, skipped, Lk, St, opt, mat, codes, ntag, ptag):
    for s in prange(Phi.shape[0]):
        codes[s] = _run(S[s], Phi[s], Y[s], lam[s], w[s], Th[s], E[s], skipped[s],  # noqa: F821
                        Lk[s], sub(St, s), opt, mat, ntag, ptag)


def _batched(S, Phi, Y, lam, w, Th, E, skipped, Lk, St, opt, mat, codes, ntag, ptag):
    for s in prange(Phi.shape[0]):
        codes[s] = _run(S[s], Phi[s], Y[s], lam[s], w[s], Th[s], E[s], skipped[s],  # noqa: F821
                        Lk[s], None, opt, mat, ntag, ptag)


def _segments(S0, Sout, Phi, Y, offsets, lam, w, Th, E, skipped, Lk, St, opt, mat, codes,
              ntag, ptag):
    for g in prange(offsets.shape[0] - 1):
        a, z, S = _segment_start(S0, Sout, offsets, g)
        codes[g] = _run(S, Phi[a:z], Y[a:z], lam[a:z], w[a:z], Th[a:z], E[a:z],  # noqa: F821
                        skipped[a:z], Lk[a:z], None, opt, mat, ntag, ptag)


def _build(template, run, name, doc):
    fn = types.FunctionType(template.__code__, {**template.__globals__, "_run": run}, name)
    fn.__qualname__ = name  # numba names the cache files after it: one per algorithm
    fn.__doc__ = doc
    fn.__adaptid_sources__ = (getattr(run, "py_func", run).__code__.co_filename,)
    return njit(**NJIT_PARALLEL)(fn)


def batched(run, name, *, stats=False):
    """``name`` (``<algorithm>_run_batched``): ``run`` over B independent streams in
    parallel; with ``stats`` each stream gets its row block of ``St``."""
    return _build(_batched_stats if stats else _batched, run, name,
                  f"B independent streams of :func:`{run.__name__}` in parallel; "
                  f"``codes[b]`` as it returns.")


def segments(run, name):
    """``name`` (``<algorithm>_run_segments``): G streams stored back to back, each
    from S0, in parallel; segment g bit for bit ``run`` from S0."""
    return _build(_segments, run, name,
                  f"G streams stored back to back, each from S0, parallel over segments; "
                  f"segment g bit for bit :func:`{run.__name__}` from S0.")
