r"""Compiled kernels of the structural-change statistics (strucchange parity).

The caller validates and allocates; nothing here checks its input.

Every kernel rotates rows into the upper triangular factor ``[R | z]``
(n × (n+1)) of the augmented data ``[Φ y]`` with Givens rotations (Björck
1996, §3.2). What is left in the last entry of a rotated row is, once ``R``
has full rank, the recursive residual :math:`w_k` of that row (Brown,
Durbin & Evans 1975), and the running sum of its squares is the residual
sum of squares of the least-squares fit on the rows rotated so far. Cost
:math:`O(n^2)` per row; no normal equations, no inverse.

* :func:`prefix_rss` — RSS of every prefix of the sample, one pass;
* :func:`breakpoints_dp` — Bai & Perron's (2003) dynamic programme for
  the optimal partition into m + 1 segments of at least ``h`` rows, for
  every m ≤ M at once. It visits the segments start by start (a column
  of strucchange's triangular RSS matrix at a time, computed with
  recursive residuals as strucchange does) and pushes each segment's RSS
  into the optimum of the segments ending where it ends: when start ``s``
  is visited, every partition of rows 0..s−1 is final, so memory is
  O(M N) instead of the O(N²) of the stored triangle;
* :func:`recursive_estimates` — least-squares estimates (and triangular
  factors) of every prefix;
* :func:`moving_estimates` — the same for every window of ``nh`` rows.
"""

import math

import numpy as np


from ..._config import NJIT, NJIT_INLINE, njit


@njit(**NJIT_INLINE)
def _rotate_in(R, row, n):  # pragma: no cover - compiled
    """Rotate ``row`` (n+1,) into ``[R | z]``; returns what is left of y."""
    for j in range(n):
        xj = row[j]
        if xj == 0.0:
            continue
        rjj = R[j, j]
        # sqrt(a² + b²) rather than hypot: no overflow guard needed for
        # data below 1e150, and twice as fast in this innermost loop
        r = math.sqrt(rjj * rjj + xj * xj)
        c = rjj / r
        s = xj / r
        R[j, j] = r
        row[j] = 0.0
        for i in range(j + 1, n + 1):
            t = R[j, i]
            R[j, i] = c * t + s * row[i]
            row[i] = c * row[i] - s * t
    return row[n]


@njit(**NJIT_INLINE)
def _back_substitute(R, n, theta):  # pragma: no cover - compiled
    """Solve R theta = z (z = R[:, n]) for upper triangular R (n, n)."""
    for i in range(n - 1, -1, -1):
        acc = R[i, n]
        for j in range(i + 1, n):
            acc -= R[i, j] * theta[j]
        theta[i] = acc / R[i, i]


@njit(**NJIT)
def prefix_rss(X, y, rss):  # pragma: no cover - compiled
    """``rss[t]`` = residual sum of squares of the fit on rows 0..t."""
    N, n = X.shape
    R = np.zeros((n, n + 1))
    row = np.empty(n + 1)
    acc = 0.0
    for t in range(N):
        for j in range(n):
            row[j] = X[t, j]
        row[n] = y[t]
        left = _rotate_in(R, row, n)
        acc += left * left
        rss[t] = acc


@njit(**NJIT)
def breakpoints_dp(X, y, h, F, B):  # pragma: no cover - compiled
    """Optimal partitions of rows 0..e into m + 1 segments of >= h rows.

    ``F`` (M+1, N) is filled with the minimal total RSS (``inf`` where no
    partition exists) and ``B`` (M+1, N) with the first row of the last
    segment of that optimum (-1 where none). Ties go to the earliest
    break, as strucchange's ``which.min``.
    """
    N, n = X.shape
    M = F.shape[0] - 1
    for m in range(M + 1):
        for e in range(N):
            F[m, e] = np.inf
            B[m, e] = -1
    R = np.empty((n, n + 1))
    row = np.empty(n + 1)
    for s in range(N - h + 1):
        if 0 < s < h:
            continue                      # no admissible partition of rows 0..s-1
        for i in range(n):
            for j in range(n + 1):
                R[i, j] = 0.0
        # layers that a segment starting at s can extend: m with F[m-1, s-1] finite
        m_lo = M + 1
        m_hi = 0
        if s > 0:
            for m in range(1, M + 1):
                if F[m - 1, s - 1] < np.inf:
                    m_lo = min(m_lo, m)
                    m_hi = m
        acc = 0.0
        for e in range(s, N):
            for j in range(n):
                row[j] = X[e, j]
            row[n] = y[e]
            left = _rotate_in(R, row, n)
            acc += left * left
            if e - s + 1 < h:
                continue
            if s == 0:
                F[0, e] = acc
                B[0, e] = 0
            else:
                for m in range(m_lo, m_hi + 1):
                    v = F[m - 1, s - 1] + acc
                    if v < F[m, e]:
                        F[m, e] = v
                        B[m, e] = s


@njit(**NJIT)
def recursive_estimates(X, y, first, theta, Rfac):  # pragma: no cover - compiled
    """Estimates on rows 0..L-1 for every prefix length L = first..N.

    ``theta`` (N-first+1, n) and ``Rfac`` (N-first+1, n, n) receive the
    estimate and the triangular factor R (RᵀR = XᵀX of the prefix).
    ``first`` must be >= n and the first ``first`` rows of full rank.
    """
    N, n = X.shape
    R = np.zeros((n, n + 1))
    row = np.empty(n + 1)
    for t in range(N):
        for j in range(n):
            row[j] = X[t, j]
        row[n] = y[t]
        _rotate_in(R, row, n)
        L = t + 1
        if L >= first:
            _back_substitute(R, n, theta[L - first])
            for i in range(n):
                for j in range(n):
                    Rfac[L - first, i, j] = R[i, j]


@njit(**NJIT)
def moving_estimates(X, y, nh, theta, Rfac):  # pragma: no cover - compiled
    """Estimates on rows i..i+nh-1 for every window start i = 0..N-nh.

    Each window is factorised afresh (O(nh n²) per window): downdating a
    QR factor is not backward stable, refactoring is.
    """
    N, n = X.shape
    R = np.empty((n, n + 1))
    row = np.empty(n + 1)
    for i in range(N - nh + 1):
        for a in range(n):
            for b in range(n + 1):
                R[a, b] = 0.0
        for t in range(i, i + nh):
            for j in range(n):
                row[j] = X[t, j]
            row[n] = y[t]
            _rotate_in(R, row, n)
        _back_substitute(R, n, theta[i])
        for a in range(n):
            for b in range(n):
                Rfac[i, a, b] = R[a, b]
