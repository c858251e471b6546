r"""LMS and normalised LMS (stochastic gradient): the estimators without a covariance.

Entry points share one signature with every other algorithm (see
:mod:`adaptid._kernels._rls`)::

    update(S, phi, y, e, lam, w, lk, opt, mat, ntag, ptag) -> status bits
    run(S, Phi, Y, lam, w, Th, E, skipped, Lk, opt, mat, ntag, ptag) -> code
    run_batched(S, Phi, Y, lam, w, Th, E, skipped, Lk, opt, mat, codes, ntag, ptag)
    run_segments(S0, Sout, Phi, Y, offsets, lam, w, Th, E, skipped, Lk, opt, mat,
                 codes, ntag, ptag)

State ``S = [ theta (n·p, row-major (n, p)) ]``: no covariance.
``opt = [windup threshold (unused), normalised (0 or 1), step μ, bias ε]``;
``lam``, ``mat`` and ``Lk`` are unused (no forgetting). The code is the first
sample after which θ is no longer finite (the gradient diverged: step too
large), or −1. Per sample (MATLAB ``recursiveLS``, EstimationMethod
``Gradient`` / ``NormalizedGradient``; padasip ``FilterLMS`` / ``FilterNLMS``):

.. math::

    \varepsilon_k = y_k - \varphi_k^T\theta_{k-1},\qquad
    \theta_k = \theta_{k-1} + g_k\,\varphi_k\,\varepsilon_k^T,\qquad
    g_k = \mu w_k \;\text{(LMS)},\quad
    g_k = \frac{\mu w_k}{\epsilon + \varphi_k^T\varphi_k} \;\text{(NLMS)}.

The increment is formed as padasip forms it, ``(g φᵢ) εⱼ``. A sample with a
non-finite value is skipped (θ untouched, error NaN, ``skipped`` set).
"""

import numpy as np
from numba import njit, prange

from .._config import NJIT, NJIT_INLINE, NJIT_PARALLEL
from ._bierman import NONPOSITIVE, SKIPPED, _one_sample, _segment_start
from ._dims import dim
from ._scratch import small_scratch


@njit(**NJIT_INLINE)
def _lms_stream(S, Phi, Y, w, Th, E, skipped, opt, NP, p):
    theta = S[0:NP * p].reshape((NP, p))
    norm = opt[1] != 0.0
    mu = opt[2]
    bias = opt[3]
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
        if ok:
            for j in range(p):
                s = Y[k, j]
                for i in range(NP):
                    s -= phi[i] * theta[i, j]
                e[j] = s
                E[k, j] = s
            g = mu * w[k]
            if norm:
                q = bias
                for i in range(NP):
                    q += phi[i] * phi[i]
                g = g / q if q > 0.0 else 0.0  # φ = 0 with ε = 0: no step
            fin = True
            for i in range(NP):
                gi = g * phi[i]
                for j in range(p):
                    t = theta[i, j] + gi * e[j]
                    theta[i, j] = t
                    fin &= t - t == 0.0
            if bad < 0 and not fin:
                bad = k
        else:
            skipped[k] = True
            for j in range(p):
                E[k, j] = np.nan
        if store:
            for i in range(NP):
                for j in range(p):
                    Th[k, i, j] = theta[i, j]
    return bad


@njit(**NJIT)
def lms_update(S, phi, y, e, lam, w, lk, opt, mat, ntag, ptag):
    """One (N)LMS step through the same compiled code as :func:`lms_run`.

    Returns status bits; the state is untouched when SKIPPED.
    """
    NP = dim(ntag)
    Phi, Y, E, lam1, w1, Th, skipped = _one_sample(phi, y, e, lam, w, NP)
    bad = _lms_stream(S, Phi, Y, w1, Th, E, skipped, opt, NP, dim(ptag))
    if skipped[0]:
        return SKIPPED
    if bad >= 0:
        return NONPOSITIVE
    return 0


@njit(**NJIT)
def lms_run(S, Phi, Y, lam, w, Th, E, skipped, Lk, opt, mat, ntag, ptag):
    """N (N)LMS steps; returns the first sample after which θ is not finite, or -1."""
    return _lms_stream(S, Phi, Y, w, Th, E, skipped, opt, dim(ntag), dim(ptag))


@njit(**NJIT_PARALLEL)
def lms_run_batched(S, Phi, Y, lam, w, Th, E, skipped, Lk, opt, mat, codes, ntag, ptag):
    """B independent (N)LMS streams in parallel; ``codes[b]`` as :func:`lms_run` returns."""
    NP = dim(ntag)
    p = dim(ptag)
    for s in prange(Phi.shape[0]):
        codes[s] = _lms_stream(S[s], Phi[s], Y[s], w[s], Th[s], E[s], skipped[s], opt, NP, p)


@njit(**NJIT_PARALLEL)
def lms_run_segments(S0, Sout, Phi, Y, offsets, lam, w, Th, E, skipped, Lk, opt, mat, codes,
                     ntag, ptag):
    """G streams stored back to back (rows offsets[g]:offsets[g+1]), each from S0.

    Parallel over segments; segment g is bit for bit :func:`lms_run` from S0.
    """
    NP = dim(ntag)
    p = dim(ptag)
    for g in prange(offsets.shape[0] - 1):
        a, z, S = _segment_start(S0, Sout, offsets, g)
        codes[g] = _lms_stream(S, Phi[a:z], Y[a:z], w[a:z], Th[a:z], E[a:z], skipped[a:z],
                               opt, NP, p)
