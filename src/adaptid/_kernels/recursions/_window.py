r"""Sliding window (truncated least squares method, TLSM) on U-D factors.

Each step adds the new sample and removes the one leaving the window
(Yamamoto 1991, eqs. 62–65): R_k = λ_k R_{k−1} + w_k φ_kφ_kᵀ − c_k φ_{k−M}φ_{k−M}ᵀ.
The removal is a Bierman update with negative weight −1/c; when
``1 − c φᵀPφ < rtol`` it would lose definiteness and the window is re-solved
exactly from its buffer instead.

Entry points as in :mod:`._rls`, with ``opt = [windup threshold, M, rtol]``;
the code returned is the number of re-solves. With ``St`` an array the
statistics of the window (:mod:`._rollstats`) are computed directly from the
buffer before the first sample and after each re-solve, recursively in
between (``St[0]`` is overwritten). State layout after the U-D
part: ``[ L, pos, count | Φ buffer (M·n) | Y buffer (M·p) | weights (M) |
log-λ sums (M) | theta0 (n·p) | U0 (n·n) | D0 (n) ]``, and with ``P0="diffuse"``
a tail ``[flag, stop]`` (:mod:`._diffuse`): the stream is then called with
``diffuse=True`` and, instead of re-solving with the prior, stops after the
sample whose removal needs a re-solve (``stop`` = samples consumed) for
:mod:`._diffuse` to re-solve the window without a prior.
"""

import numpy as np
from numba import prange

from ..._config import NJIT, NJIT_INLINE, NJIT_PARALLEL, njit
from ..toolchain._dims import dim
from ._bierman import _add, _bierman_apply, _gain_step, _prep_row, _prior_errors, \
    _segment_start, _views
from ._entries import Entries
from ._rollstats import sub, window_direct_hook, window_end_hook, window_enter_hook, \
    window_remove_hook


@njit(**NJIT_INLINE)
def _window_views(S, NP, p, M):
    theta, U, D = _views(S, NP, p)
    o = NP * p + NP * NP + NP
    meta = S[o:o + 3]
    o += 3
    Bphi = S[o:o + M * NP].reshape((M, NP))
    o += M * NP
    By = S[o:o + M * p].reshape((M, p))
    o += M * p
    Bw = S[o:o + M]
    o += M
    BL = S[o:o + M]
    o += M
    theta0 = S[o:o + NP * p].reshape((NP, p))
    o += NP * p
    U0 = S[o:o + NP * NP].reshape((NP, NP)).T
    o += NP * NP
    D0 = S[o:o + NP]
    return theta, U, D, meta, Bphi, By, Bw, BL, theta0, U0, D0




@njit(**NJIT_INLINE)
def _window_rebuild(theta, U, D, meta, Bphi, By, Bw, BL, theta0, U0, D0,
                    e, f, v, b, NP, p, M):
    """Re-solve the window exactly from its buffer and the (decayed) prior."""
    L = meta[0]
    pos = int(meta[1])
    count = int(meta[2])
    scale = np.exp(min(-L, 600.0))  # prior P0/Πλ; floored at exp(-600) of its weight
    for i in range(NP):
        D[i] = D0[i] * scale
        for j in range(NP):
            U[i, j] = U0[i, j]
        for j in range(p):
            theta[i, j] = theta0[i, j]
    start = pos - count
    for t in range(count):
        s = (start + t) % M
        c = Bw[s] * np.exp(L - BL[s])
        if c > 0.0:
            _prior_errors(theta, Bphi[s], By[s], e, NP, p)
            _add(theta, U, D, Bphi[s], By[s], 1.0 / c, e, f, v, b, NP, p)



# The window's stream is written flat (no per-step array views, branches at
# the top of the loop body): faster than composing the helpers above (the
# window's rows in benchmarks/bench_rls.py and benchmarks/bench_update.py).
# Compiled once per types and tags and called by the entry points, not inlined
# into each (see _rls._rls_core); other kernels pass size_tag(n).
@njit(**NJIT)
def _window_core(S, Phi, Y, lam, w, Th, E, skipped, St, M, rtol, ntag, ptag, diffuse=False):
    NP = dim(ntag)
    p = dim(ptag)
    theta, U, D, meta, Bphi, By, Bw, BL, theta0, U0, D0 = _window_views(S, NP, p, M)
    f = np.empty(NP)
    v = np.empty(NP)
    b = np.empty(NP)
    e = np.empty(p)
    e2 = np.empty(p)
    store = Th.shape[0] == Phi.shape[0]
    # the statistics hooks (St an array) compile to nothing when St is None
    window_direct_hook(St, 0, theta, Bphi, By, Bw, BL, meta, theta0, U0, D0, f, U, D, M, NP, p)
    rebuilds = 0
    for k in range(Phi.shape[0]):
        ok = True
        rebuilt = False
        for i in range(NP):
            if not np.isfinite(Phi[k, i]):
                ok = False
        for j in range(p):
            if not np.isfinite(Y[k, j]):
                ok = False
        if ok:
            lk = lam[k]
            wk = w[k]
            for j in range(p):
                s = Y[k, j]
                for i in range(NP):
                    s -= Phi[k, i] * theta[i, j]
                e[j] = s
                E[k, j] = s
            if lk != 1.0:
                il = 1.0 / lk
                for i in range(NP):
                    D[i] *= il
            L = meta[0] + np.log(lk)
            meta[0] = L
            a = 1.0
            if wk > 0.0:
                _prep_row(U, D, Phi, k, f, v, NP)
                a = _bierman_apply(U, D, 1.0 / wk, f, v, b, NP)
                _gain_step(theta, b, a, e, NP, p)
            window_enter_hook(St, k, Y, lk, wk, e, a, NP, p)
            pos = int(meta[1])
            count = int(meta[2])
            if count == M:
                c = Bw[pos] * np.exp(L - BL[pos])
                if c > 0.0:
                    q = _prep_row(U, D, Bphi, pos, f, v, NP)
                    if 1.0 - c * q < rtol:
                        rebuilt = True
                    else:
                        for j in range(p):
                            s = By[pos, j]
                            for i in range(NP):
                                s -= Bphi[pos, i] * theta[i, j]
                            e2[j] = s
                        a = _bierman_apply(U, D, -1.0 / c, f, v, b, NP)
                        _gain_step(theta, b, a, e2, NP, p)
                window_remove_hook(St, k, rebuilt, By, Bw, BL, pos, L, c, e2, a, NP, p)
            _push(Bphi, By, Bw, BL, meta, Phi, Y, k, wk, L, pos, count, M, NP, p)
            if rebuilt:
                rebuilds += 1
                if diffuse:  # no prior: _diffuse re-solves (samples used so far in S[-1])
                    S[S.shape[0] - 1] = k + 1
                    return rebuilds
                _rebuild_noinline(S, M, NP, p)
                window_direct_hook(St, k + 1, theta, Bphi, By, Bw, BL, meta, theta0, U0, D0, f,
                                   U, D, M, NP, p)
        else:
            skipped[k] = True
            for j in range(p):
                E[k, j] = np.nan
        window_end_hook(St, k, ok, U, D, NP)
        if store:
            for i in range(NP):
                for j in range(p):
                    Th[k, i, j] = theta[i, j]
    return rebuilds


@njit(**NJIT_INLINE)
def _push(Bphi, By, Bw, BL, meta, Phi, Y, k, wk, L, pos, count, M, NP, p):
    """Sample k into the buffer at ``pos`` (over the sample that left)."""
    for i in range(NP):
        Bphi[pos, i] = Phi[k, i]
    for j in range(p):
        By[pos, j] = Y[k, j]
    Bw[pos] = wk
    BL[pos] = L
    pos += 1
    if pos == M:
        pos = 0
    meta[1] = pos
    if count < M:
        meta[2] = count + 1


@njit(**NJIT)
def _rebuild_noinline(S, M, NP, p):
    theta, U, D, meta, Bphi, By, Bw, BL, theta0, U0, D0 = _window_views(S, NP, p, M)
    e = np.empty(p)
    f = np.empty(NP)
    v = np.empty(NP)
    b = np.empty(NP)
    _window_rebuild(theta, U, D, meta, Bphi, By, Bw, BL, theta0, U0, D0, e, f, v, b, NP, p, M)



@njit(**NJIT)
def window_run(S, Phi, Y, lam, w, Th, E, skipped, Lk, St, opt, mat, ntag, ptag):
    """N TLSM steps; returns the number of removals replaced by a re-solve."""
    return _window_core(S, Phi, Y, lam, w, Th, E, skipped, St, int(opt[1]), opt[2], ntag, ptag)


# The parallel wrappers stay written out here instead of coming from
# _parallel.batched / segments (window_run through the factory's templates):
# bit for bit the same results, but the streams ran consistently slower at n = 8
# (not at n = 4) in same-process A/B runs of the two wrappers, presumably as LLVM
# then inlines _window_core differently into the prange loop.
@njit(**NJIT_PARALLEL)
def window_run_batched(S, Phi, Y, lam, w, Th, E, skipped, Lk, St, opt, mat, codes, ntag, ptag):
    M = int(opt[1])
    for s in prange(Phi.shape[0]):
        codes[s] = _window_core(S[s], Phi[s], Y[s], lam[s], w[s], Th[s], E[s], skipped[s],
                                sub(St, s), M, opt[2], ntag, ptag)


@njit(**NJIT_PARALLEL)
def window_run_segments(S0, Sout, Phi, Y, offsets, lam, w, Th, E, skipped, Lk, St, opt, mat,
                        codes, ntag, ptag):
    """G sliding-window streams back to back, each from S0 (see :func:`._rls.rls_run_segments`)."""
    M = int(opt[1])
    for g in prange(offsets.shape[0] - 1):
        a, z, S = _segment_start(S0, Sout, offsets, g)
        codes[g] = _window_core(S, Phi[a:z], Y[a:z], lam[a:z], w[a:z], Th[a:z], E[a:z],
                                skipped[a:z], None, M, opt[2], ntag, ptag)


#: this module's entry points, by the name adaptid._kernels gives them
ENTRIES = {"WINDOW": Entries(window_run, window_run_batched, window_run_segments)}
