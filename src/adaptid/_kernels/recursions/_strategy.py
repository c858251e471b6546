r"""RLS with a forgetting strategy of :mod:`adaptid.forgetting`, or ``P_max``.

Entry points as in :mod:`._rls`, with ``opt = [windup threshold, mode,
P_max]`` (mode: 0 exponential with λₖ given, 1 directional, 2 constant trace,
3 EFRA, 4 variable; P_max = inf: none), ``mat[0]`` the strategy's parameters
and ``Lk`` the λₖ applied at each sample (NaN where skipped); ``St`` is unused
(no windowed statistics under a strategy).
"""

import numpy as np

from ..._config import NJIT, NJIT_INLINE, njit
from ..toolchain._dims import dim
from ._bierman import _add, _bierman_apply, _bierman_prep, _finite_row, _forget, _form_P, \
    _gain_step, _max_diag_P, _prior_errors, _store, _trace_P, _udu_factor, _views
from ._entries import Entries
from ._parallel import batched, segments

@njit(**NJIT_INLINE)
def _strategy_step(theta, U, D, phi, y, e, wk, lamk, mode, fp, pmax, f, v, b, Pm, W, NP, p):
    """One sample of RLS with a forgetting strategy, given its a-priori errors e.

    Shared by the strategy stream and the ARMAX/OE recursions
    (:mod:`adaptid.models`); returns the λₖ applied. ``mode``, ``fp`` and
    ``pmax`` as in :func:`_rls_strategy_stream`.
    """
    e2 = 0.0
    for j in range(p):
        e2 += e[j] * e[j]
    e2 /= p
    lk = 1.0
    if mode == 0 or mode == 4:
        if mode == 0:
            lk = lamk
        else:
            # Fortescue, Kershenbaum & Ydstie (1981): keep the weighted
            # a-posteriori error sum constant: λ = 1 − w ε²/((1 + w r) Σ0)
            r = _bierman_prep(U, D, phi, f, v, NP)
            lk = 1.0 - wk * e2 / ((1.0 + wk * r) * fp[1])
            if not (lk >= fp[0]):
                lk = fp[0]
        if pmax < np.inf:
            # pivot-wise conditional forgetting: D_i/λ_i ≤ P_max, so the
            # saturated (unexcited) pivots stop growing while the others
            # keep forgetting at λ
            for i in range(NP):
                li = lk
                if D[i] > li * pmax:
                    li = min(1.0, max(lk, D[i] / pmax))
                D[i] /= li
        else:
            _forget(D, lk, NP)
        if wk > 0.0:
            _add(theta, U, D, phi, y, 1.0 / wk, e, f, v, b, NP, p)
    elif mode == 1:
        # Kulhavý (1987): forget only along φ. The information R = P⁻¹
        # loses (1 − λ) φφᵀ/(φᵀPφ) (a Bierman step of weight −r/(1−λ),
        # definite since 1 − c r = λ > 0), so φᵀPφ grows by 1/λ while
        # directions orthogonal to φ (in the R metric) keep their information.
        if wk > 0.0:
            lk = fp[0]
            r = _bierman_prep(U, D, phi, f, v, NP)
            if lk < 1.0 and pmax < np.inf:
                if _max_diag_P(U, D, NP) > lk * pmax:
                    lk = 1.0
            if lk < 1.0 and r > 0.0:
                _bierman_apply(U, D, -r / (1.0 - lk), f, v, b, NP)
            _add(theta, U, D, phi, y, 1.0 / wk, e, f, v, b, NP, p)
    elif mode == 2:
        # regularised constant trace (Goodwin & Sin 1984, §3.7):
        # P = g P̄ + c₂ I, g = min(c₁/tr P̄, 1/λ_min), so tr P ≤ c₁ + n c₂
        if wk > 0.0:
            _add(theta, U, D, phi, y, 1.0 / wk, e, f, v, b, NP, p)
        g = fp[2] / _trace_P(U, D, NP)
        if not (g <= 1.0 / fp[0]):
            g = 1.0 / fp[0]
        lk = 1.0 / g
        for i in range(NP):
            for j in range(i, NP):
                sij = D[j] * U[i, j] if i < j else D[j]
                for q in range(j + 1, NP):
                    sij += U[i, q] * D[q] * U[j, q]
                W[i, j] = g * sij + (fp[3] if i == j else 0.0)
        if not _udu_factor(W, U, D, NP):
            for i in range(NP):
                D[i] = np.nan
    else:
        # EFRA (Salgado, Goodwin & Middleton 1988):
        # θ ← θ + α Pφ ε/(1/w + r),
        # P ← (P − α PφφᵀP/(1/w + r))/λ + βI − δP²  (P the old P)
        alpha = fp[0]
        lk = fp[3]
        _form_P(U, D, Pm, NP)
        if wk > 0.0:
            r = _bierman_prep(U, D, phi, f, v, NP)
            a = _bierman_apply(U, D, (1.0 / wk + r) / alpha - r, f, v, b, NP)
            _gain_step(theta, b, a, e, NP, p)
        _forget(D, lk, NP)
        for i in range(NP):
            for j in range(i, NP):
                s = D[j] * U[i, j] if i < j else D[j]
                for q in range(j + 1, NP):
                    s += U[i, q] * D[q] * U[j, q]
                sq = 0.0
                for q in range(NP):
                    sq += Pm[i, q] * Pm[q, j]
                s -= fp[2] * sq
                if i == j:
                    s += fp[1]
                W[i, j] = s
        if not _udu_factor(W, U, D, NP):
            for i in range(NP):
                D[i] = np.nan
    return lk


@njit(**NJIT)
def _rls_strategy_stream(S, Phi, Y, lam, w, Th, E, skipped, Lk, opt, mat, ntag, ptag):
    # Not inlined: compiled once and shared by the four entry points (the
    # per-sample work of a strategy dwarfs one call per stream).
    NP = dim(ntag)
    p = dim(ptag)
    dthr = opt[0]
    mode = int(opt[1])
    pmax = opt[2]
    fp = mat[0]
    theta, U, D = _views(S, NP, p)
    f = np.empty(NP)
    v = np.empty(NP)
    b = np.empty(NP)
    e = np.empty(p)
    Pm = np.empty((NP, NP))
    W = np.empty((NP, NP))
    store = Th.shape[0] == Phi.shape[0]
    bad = -1
    for k in range(Phi.shape[0]):
        phi = Phi[k]
        if not _finite_row(phi, Y[k], NP, p):
            skipped[k] = True
            Lk[k] = np.nan
            for j in range(p):
                E[k, j] = np.nan
            if store:
                _store(Th, k, theta, NP, p)
            continue
        _prior_errors(theta, phi, Y[k], e, NP, p)
        for j in range(p):
            E[k, j] = e[j]
        lk = _strategy_step(theta, U, D, phi, Y[k], e, w[k], lam[k], mode, fp, pmax,
                            f, v, b, Pm, W, NP, p)
        Lk[k] = lk
        if bad < 0:
            inside = True
            for i in range(NP):
                inside &= (D[i] > 0.0) & (D[i] < dthr)
            if not inside:
                bad = k
        if store:
            _store(Th, k, theta, NP, p)
    return bad


@njit(**NJIT)
def strategy_run(S, Phi, Y, lam, w, Th, E, skipped, Lk, St, opt, mat, ntag, ptag):
    """N RLS steps with a forgetting strategy; returns as :func:`adaptid._kernels.recursions._rls.rls_run`."""
    return _rls_strategy_stream(S, Phi, Y, lam, w, Th, E, skipped, Lk, opt, mat, ntag, ptag)


strategy_run_batched = batched(strategy_run, "strategy_run_batched")
strategy_run_segments = segments(strategy_run, "strategy_run_segments")


#: this module's entry points, by the name adaptid._kernels gives them
ENTRIES = {"STRATEGY": Entries(strategy_run, strategy_run_batched, strategy_run_segments)}
