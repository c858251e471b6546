r"""RLS with exponential forgetting, weights and prior (ridge): the headline stream.

Entry points share one signature with every other algorithm (see
:mod:`adaptid.estimators._engine`)::

    run(S, Phi, Y, lam, w, Th, E, skipped, Lk, St, opt, mat, ntag, ptag) -> code
    run_batched(S, Phi, Y, lam, w, Th, E, skipped, Lk, St, opt, mat, codes, ntag, ptag)
    run_segments(S0, Sout, Phi, Y, offsets, lam, w, Th, E, skipped, Lk, St, opt, mat,
                 codes, ntag, ptag)

``opt = [windup threshold]``; ``mat`` and ``Lk`` are unused; ``St`` receives
the windowed statistics when it is an array of N + 1 rows (:mod:`._rollstats`;
``None``: none, chosen at compile time); the code is the
first sample at which a pivot of D left (0, threshold), or −1. ``ntag`` and
``ptag`` give n and p (compile-time constants for tuple tags, :mod:`._dims`).
Per sample (Ljung & Söderström 1983, eqs. 2.19–2.20, on U-D factors):
ε = y − φᵀθ, D ← D/λ, Bierman update with weight 1/w, θ ← θ + Pφ ε/α.
"""

import numpy as np

from ..._config import NJIT, NJIT_INLINE, njit
from ..toolchain._dims import dim
from ..toolchain._scratch import scratch, scratch2, small_scratch
from ._bierman import _bierman_apply_pairs, _bierman_prep, _copy_factor, _views
from ._entries import Entries
from ._parallel import batched, segments
from ._rollstats import rls_hook
from ._step import views

@njit(**NJIT)
def _rls_core(S, Phi, Y, lam, w, Th, E, skipped, St, dthr, ntag, ptag):
    """:func:`_rls_body` compiled once per types and tags, called (not inlined) by
    other kernels (:mod:`._diffuse`): numba's inlining copies the body's IR (a fifth
    of a kernel's compile time). ``rls_run`` inlines the body instead: a call costs
    the array arguments' reference counts, a visible part of an ``update``
    (``benchmarks/bench_update.py``); the parallel entries call ``rls_run``."""
    return _rls_body(S, Phi, Y, lam, w, Th, E, skipped, St, dthr, ntag, ptag)


@njit(**NJIT_INLINE)
def _rls_body(S, Phi, Y, lam, w, Th, E, skipped, St, dthr, ntag, ptag):
    # Written flat, with every branch at the top of the loop body: a branch
    # around the unrolled update (e.g. `if w > 0`) made LLVM spill the state
    # and the loop ran several times slower (benchmarks/bench_rls.py). The factor is worked
    # on in a stack copy (see _scratch): LLVM then knows that the stores to
    # the trajectory cannot change it and stops reloading it after each one.
    NP = dim(ntag)
    p = dim(ptag)
    theta, Us, Ds = _views(S, NP, p)
    U = scratch2(NP).T  # by columns, as in S
    D = scratch(NP)
    _copy_factor(Us, Ds, U, D, NP)
    f = small_scratch(NP)
    v = small_scratch(NP)
    b = small_scratch(NP)
    e = small_scratch(p)
    store = Th.shape[0] == Phi.shape[0]
    bad = -1
    for k in range(Phi.shape[0]):
        phi = Phi[k]
        ok = True  # all of the row finite; tested without branches
        for i in range(NP):
            ok &= phi[i] - phi[i] == 0.0
        for j in range(p):
            ok &= Y[k, j] - Y[k, j] == 0.0
        wk = w[k]
        inside = True  # pivots in (0, dthr)
        a = 1.0
        if ok and wk > 0.0:
            for j in range(p):
                s = Y[k, j]
                for i in range(NP):
                    s -= phi[i] * theta[i, j]
                e[j] = s
                E[k, j] = s
            il = 1.0 / lam[k]
            for i in range(NP):
                D[i] *= il
            _bierman_prep(U, D, phi, f, v, NP)
            a = _bierman_apply_pairs(U, D, 1.0 / wk, f, v, b, NP)
            ia = 1.0 / a
            for i in range(NP):
                g = b[i] * ia
                for j in range(p):
                    theta[i, j] += g * e[j]
            for i in range(NP):
                inside &= (D[i] > 0.0) & (D[i] < dthr)
        elif ok:  # weight 0: the sample only advances the forgetting
            for j in range(p):
                s = Y[k, j]
                for i in range(NP):
                    s -= phi[i] * theta[i, j]
                E[k, j] = s
            il = 1.0 / lam[k]
            for i in range(NP):
                D[i] *= il
                inside &= (D[i] > 0.0) & (D[i] < dthr)
        else:
            skipped[k] = True
            for j in range(p):
                E[k, j] = np.nan
        if bad < 0 and not inside:
            bad = k
        if store:
            for i in range(NP):
                for j in range(p):
                    Th[k, i, j] = theta[i, j]
        rls_hook(St, k, ok, Y, lam, wk, e, a, U, D, NP, p)  # nothing when St is None
    _copy_factor(U, D, Us, Ds, NP)
    return bad


@njit(**NJIT)
def rls_run(S, Phi, Y, lam, w, Th, E, skipped, Lk, St, opt, mat, ntag, ptag):
    """N RLS steps; returns the first sample index where a pivot D_i lost
    positivity or passed the windup threshold ``opt[0]``, or -1."""
    return _rls_body(S, Phi, Y, lam, w, Th, E, skipped, St, opt[0], ntag, ptag)


@njit(**NJIT)
def rls_step(S, W, ntag, ptag):
    """One RLS step on the packed sample ``W`` (:mod:`._step`), bit for bit a step of
    :func:`rls_run`; returns its code."""
    Phi, Y, lam, w, Th, E, skipped, dthr = views(W, ntag, ptag)
    return _rls_body(S, Phi, Y, lam, w, Th, E, skipped, None, dthr, ntag, ptag)


rls_run_batched = batched(rls_run, "rls_run_batched", stats=True)
rls_run_segments = segments(rls_run, "rls_run_segments")


#: this module's entry points, by the name adaptid._kernels gives them
ENTRIES = {"RLS": Entries(rls_run, rls_run_batched, rls_run_segments, step=rls_step)}
