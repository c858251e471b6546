r"""Compiled kernels of :mod:`adaptid.fleet`: per-segment statistics, parallel over segments.

The caller validates and allocates; nothing here checks its input. A segment
g is rows ``offsets[g]:offsets[g+1]`` of the stacked arrays.
"""

import math

import numpy as np
from numba import prange

from ..._config import NJIT, NJIT_PARALLEL, njit
from ._residuals import recursive_residuals_kernel


@njit(**NJIT_PARALLEL)
def residual_ss_kernel(Phi, y, used, offsets, theta, window, lam, ss, wss, neff,
                       count):  # pragma: no cover
    """Sums of the a-posteriori residuals r_k = y_k − φ_kᵀθ_g of each segment.

    Walking back from the segment's last sample with c = 1 and c ← λc after
    every used sample (c_k = λ^(number of used samples after k), the factor
    of :func:`adaptid.estimators._stats.sample_factors`); only used samples count
    and, with ``window > 0``, only the last ``window`` of them. Fills
    ``ss`` = Σ r², ``wss`` = Σ c r², ``neff`` = Σ c and ``count`` (all (G,)).
    """
    G = offsets.size - 1
    n = Phi.shape[1]
    for g in prange(G):
        a = offsets[g]
        b = offsets[g + 1]
        s = 0.0
        sw = 0.0
        ce = 0.0
        c = 1.0
        m = 0
        k = b - 1
        while k >= a:
            if used[k]:
                r = y[k]
                for j in range(n):
                    r -= Phi[k, j] * theta[g, j]
                s += r * r
                sw += c * r * r
                ce += c
                c *= lam
                m += 1
                if window > 0 and m >= window:
                    break
            k -= 1
        ss[g] = s
        wss[g] = sw
        neff[g] = ce
        count[g] = m


@njit(**NJIT_PARALLEL)
def cusum_errors_kernel(e, used, offsets, burn_in, a, ratio, first):  # pragma: no cover
    """BDE CUSUM of each segment's used errors, after dropping ``burn_in[g]`` of them.

    With m the number of kept errors e_j (j = 1..m), σ̂² = Σ e_j²/m,
    W_j = Σ_{i≤j} e_i/σ̂ and the bound b_j = a√m + 2a j/√m: ``ratio[g]`` is
    max_j |W_j|/b_j (NaN if m < 2 or σ̂ = 0) and ``first[g]`` the row (an
    index into ``e``) of the first j with |W_j| > b_j, or −1.
    """
    G = offsets.size - 1
    for g in prange(G):
        lo = offsets[g]
        hi = offsets[g + 1]
        # skip the burn-in
        start = lo
        skipped = 0
        while start < hi and skipped < burn_in[g]:
            if used[start]:
                skipped += 1
            start += 1
        m = 0
        s2 = 0.0
        for k in range(start, hi):
            if used[k]:
                m += 1
                s2 += e[k] * e[k]
        first[g] = -1
        if m < 2 or not s2 > 0.0:
            ratio[g] = np.nan
            continue
        sigma = math.sqrt(s2 / m)
        rm = math.sqrt(m)
        cum = 0.0
        j = 0
        best = 0.0
        for k in range(start, hi):
            if used[k]:
                j += 1
                cum += e[k]
                r = abs(cum / sigma) / (a * rm + 2.0 * a * j / rm)
                if r > best:
                    best = r
                if r > 1.0 and first[g] < 0:
                    first[g] = k
        ratio[g] = best


@njit(**NJIT_PARALLEL)
def recursive_residuals_segments(Phi, y, offsets, w):  # pragma: no cover
    """Brown–Durbin–Evans recursive residuals of every segment (compact rows).

    ``w`` has the rows of ``Phi``; row k of segment g receives w_k for its
    position ≥ n in the segment with a full-rank start, NaN otherwise (the
    first n rows and a rank-deficient start). Same compiled step and rank
    rule as :func:`adaptid.diagnostics.recursive_residuals`.
    """
    G = offsets.size - 1
    n = Phi.shape[1]
    eps = np.finfo(np.float64).eps
    for g in prange(G):
        a = offsets[g]
        b = offsets[g + 1]
        N = b - a
        for k in range(a, min(b, a + n)):
            w[k] = np.nan
        if N <= n:
            continue
        tol = np.empty(n)
        for j in range(n):
            s = 0.0
            for k in range(a, b):
                s += Phi[k, j] * Phi[k, j]
            tol[j] = max(N, n) * eps * math.sqrt(s)
        R = np.zeros((n, n + 1))
        recursive_residuals_kernel(Phi[a:b], y[a:b], tol, R, w[a + n:b])


@njit(**NJIT)
def scan_runs(g, t, use_t, starts):  # pragma: no cover - compiled
    """Runs of equal group labels in ``g``, and whether the rows are already sorted.

    Fills ``starts[:m]`` with the first row of each run and returns
    ``(m, increasing, time_sorted, time_nan)``: ``increasing`` when each run's
    label is larger than the previous run's (so every group is one run, in
    ascending order), ``time_sorted`` when ``t`` is nondecreasing within every
    run, ``time_nan`` when ``t`` holds a NaN (first row in ``starts[m]``).
    """
    N = g.shape[0]
    m = 0
    increasing = True
    tsorted = True
    tnan = False
    if N > 0:
        starts[0] = 0
        m = 1
        if use_t and t[0] != t[0]:
            tnan = True
            starts[N] = 0
    for k in range(1, N):
        if use_t and not tnan and t[k] != t[k]:
            tnan = True
            starts[N] = k
        if g[k] != g[k - 1]:
            if not g[k] > g[k - 1]:
                increasing = False
            starts[m] = k
            m += 1
        elif use_t and t[k] < t[k - 1]:
            tsorted = False
    return m, increasing, tsorted, tnan


@njit(**NJIT_PARALLEL)
def gather_columns(cols, idx, use_idx, out):  # pragma: no cover - compiled
    """out[k, j] = cols[j][idx[k]] (or cols[j][k]): columns to C-ordered rows, in parallel."""
    N, n = out.shape
    for k in prange(N):
        r = np.int64(k)
        if use_idx:
            r = idx[k]
        for j in range(n):
            out[k, j] = cols[j][r]
