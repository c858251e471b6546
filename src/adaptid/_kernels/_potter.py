r"""RLS with exponential forgetting in square-root (Potter) form: ``RLS(form="sqrt")``.

Same entry points and signature as :mod:`._rls` (the U-D form); only the
covariance block of the state differs: ``[theta (n·p) | S (n·n, by columns) |
0 (n)]`` with :math:`P = S S^T`, S a full n × n matrix (Potter 1963; Bierman
1977, ch. V.2). Per sample, with :math:`f = S^T\varphi` and :math:`h = S f = P\varphi`
(both left over from the previous sample's sweep), r = λ/w:

.. math::

    d = r + f^T f,\quad \varepsilon = y - \varphi^T\theta,\quad
    \theta \leftarrow \theta + h\,\varepsilon/d,\quad
    \gamma = \frac{1}{1 + \sqrt{r/d}},\quad
    S \leftarrow \frac{1}{\sqrt\lambda}\Big(S - \frac{\gamma}{d}\,h f^T\Big),

which is :math:`P \leftarrow (P - P\varphi\varphi^T P/d)/\lambda` exactly
(Potter's update of :math:`S/\sqrt\lambda` with weight 1/w). P = S Sᵀ is
positive semi-definite whatever the rounding.

Speed: the U-D update is sequential across columns (a division per column on
the critical path) and does not vectorise; here one sweep over S per sample,
column by column, updates column j (a vector operation down the column),
forms the next sample's :math:`f_j = S_{:,j}^T\varphi_{k+1}` (a dot product
in eight fixed lanes, so the same bits whatever the vector width), and
accumulates :math:`h \mathrel{+}= S_{:,j} f_j` and the diagonal of P
(:math:`\sum_j S_{ij}^2`) as axpys. A sample that was skipped or had weight 0
makes the next one form f and h afresh, with the same lane arithmetic, so
``update`` equals ``run`` bit for bit.

Monitoring: the code is the first sample after which a diagonal entry of
P = S Sᵀ left (0, ``opt[0]``) (zero: S lost rank; NaN/inf: overflow), or −1.
"""

import numpy as np
from numba import prange

from .._config import NJIT, NJIT_INLINE, NJIT_PARALLEL, njit
from ._bierman import NONPOSITIVE, SKIPPED, _one_sample, _segment_start, _views
from ._dims import dim
from ._scratch import scratch, scratch2

LANES = 8  # the dot products' fixed lane count (part of the arithmetic: keep it)


@njit(**NJIT_INLINE)
def _coldot(F, j, x, NP):
    """Σᵢ F[i, j] x[i] in eight interleaved partial sums, summed pairwise."""
    a0 = a1 = a2 = a3 = a4 = a5 = a6 = a7 = 0.0
    i = 0
    while i + LANES <= NP:
        a0 += F[i, j] * x[i]
        a1 += F[i + 1, j] * x[i + 1]
        a2 += F[i + 2, j] * x[i + 2]
        a3 += F[i + 3, j] * x[i + 3]
        a4 += F[i + 4, j] * x[i + 4]
        a5 += F[i + 5, j] * x[i + 5]
        a6 += F[i + 6, j] * x[i + 6]
        a7 += F[i + 7, j] * x[i + 7]
        i += LANES
    while i < NP:
        a0 += F[i, j] * x[i]
        i += 1
    return ((a0 + a4) + (a2 + a6)) + ((a1 + a5) + (a3 + a7))


@njit(**NJIT_INLINE)
def _fresh(F, phi, f, h, NP):
    """f = Fᵀφ, h = F f: the arithmetic of the sweep, for a first or resumed sample."""
    for i in range(NP):
        h[i] = 0.0
    for j in range(NP):
        fj = _coldot(F, j, phi, NP)
        f[j] = fj
        for i in range(NP):
            h[i] += F[i, j] * fj


@njit(**NJIT_INLINE)
def _sweep(F, f, h, a, rn, s, nxt, NP):
    """F ← s F − a fᵀ column by column; f, h ← those of the next regressor; rn ← diag(F Fᵀ)."""
    for i in range(NP):
        h[i] = 0.0
        rn[i] = 0.0
    for j in range(NP):
        fj = f[j]
        for i in range(NP):
            F[i, j] = s * F[i, j] - a[i] * fj
        fn = _coldot(F, j, nxt, NP)
        f[j] = fn
        for i in range(NP):
            v = F[i, j]
            h[i] += v * fn
            rn[i] += v * v


@njit(**NJIT_INLINE)
def _diag_inside(F, rn, dthr, NP):
    """diag(F Fᵀ) into rn (by rows) and whether each entry is in (0, dthr)."""
    for i in range(NP):
        rn[i] = 0.0
    for j in range(NP):
        for i in range(NP):
            rn[i] += F[i, j] * F[i, j]
    inside = True
    for i in range(NP):
        inside &= (rn[i] > 0.0) & (rn[i] < dthr)
    return inside


@njit(**NJIT_INLINE)
def _errors(theta, phi, Y, k, e, E, NP, p):
    for j in range(p):
        s = Y[k, j]
        for i in range(NP):
            s -= phi[i] * theta[i, j]
        e[j] = s
        E[k, j] = s


@njit(**NJIT_INLINE)
def _potter_stream(S, Phi, Y, lam, w, Th, E, skipped, dthr, NP, p):
    theta, Fs, _ = _views(S, NP, p)
    F = scratch2(NP).T  # by columns, as in S
    for j in range(NP):
        for i in range(NP):
            F[i, j] = Fs[i, j]
    f = scratch(NP)
    h = scratch(NP)
    a = scratch(NP)
    rn = scratch(NP)
    e = scratch(p)
    N = Phi.shape[0]
    store = Th.shape[0] == N
    fresh = False  # f, h belong to Phi[k]
    bad = -1
    for k in range(N):
        phi = Phi[k]
        ok = True
        for i in range(NP):
            ok &= phi[i] - phi[i] == 0.0
        for j in range(p):
            ok &= Y[k, j] - Y[k, j] == 0.0
        wk = w[k]
        inside = True
        if ok and wk > 0.0:
            if not fresh:
                _fresh(F, phi, f, h, NP)
            _errors(theta, phi, Y, k, e, E, NP, p)
            r = lam[k] / wk
            q = 0.0
            for i in range(NP):
                q += f[i] * f[i]
            d = r + q
            idd = 1.0 / d
            s = 1.0 / np.sqrt(lam[k])
            beta = idd / (1.0 + np.sqrt(r * idd)) * s
            for i in range(NP):
                g = h[i] * idd
                for j in range(p):
                    theta[i, j] += g * e[j]
                a[i] = beta * h[i]
            _sweep(F, f, h, a, rn, s, Phi[k + 1] if k + 1 < N else phi, NP)
            fresh = True
            for i in range(NP):
                inside &= (rn[i] > 0.0) & (rn[i] < dthr)
        elif ok:  # weight 0: the sample only advances the forgetting
            _errors(theta, phi, Y, k, e, E, NP, p)
            s = 1.0 / np.sqrt(lam[k])
            for j in range(NP):
                for i in range(NP):
                    F[i, j] *= s
            inside = _diag_inside(F, rn, dthr, NP)
            fresh = False
        else:
            skipped[k] = True
            for j in range(p):
                E[k, j] = np.nan
            fresh = False
        if bad < 0 and not inside:
            bad = k
        if store:
            for i in range(NP):
                for j in range(p):
                    Th[k, i, j] = theta[i, j]
    for j in range(NP):
        for i in range(NP):
            Fs[i, j] = F[i, j]
    return bad


@njit(**NJIT)
def potter_update(S, phi, y, e, lam, w, lk, opt, mat, ntag, ptag):
    """One step through the same compiled code as :func:`potter_run` (status bits)."""
    NP = dim(ntag)
    Phi, Y, E, lam1, w1, Th, skipped = _one_sample(phi, y, e, lam, w, NP)
    bad = _potter_stream(S, Phi, Y, lam1, w1, Th, E, skipped, opt[0], NP, dim(ptag))
    if skipped[0]:
        return SKIPPED
    if bad >= 0:
        return NONPOSITIVE
    return 0


@njit(**NJIT)
def potter_run(S, Phi, Y, lam, w, Th, E, skipped, Lk, St, opt, mat, ntag, ptag):
    """N steps; returns the first sample after which a diagonal entry of P left
    (0, ``opt[0]``), or -1."""
    return _potter_stream(S, Phi, Y, lam, w, Th, E, skipped, opt[0], dim(ntag), dim(ptag))


@njit(**NJIT_PARALLEL)
def potter_run_batched(S, Phi, Y, lam, w, Th, E, skipped, Lk, St, opt, mat, codes, ntag,
                       ptag):
    """B independent streams in parallel; ``codes[b]`` as :func:`potter_run` returns."""
    NP = dim(ntag)
    p = dim(ptag)
    for s in prange(Phi.shape[0]):
        codes[s] = _potter_stream(S[s], Phi[s], Y[s], lam[s], w[s], Th[s], E[s], skipped[s],
                                  opt[0], NP, p)


@njit(**NJIT_PARALLEL)
def potter_run_segments(S0, Sout, Phi, Y, offsets, lam, w, Th, E, skipped, Lk, St, opt, mat,
                        codes, ntag, ptag):
    """G streams stored back to back, each from S0 (bit for bit :func:`potter_run`)."""
    NP = dim(ntag)
    p = dim(ptag)
    for g in prange(offsets.shape[0] - 1):
        a, z, S = _segment_start(S0, Sout, offsets, g)
        codes[g] = _potter_stream(S, Phi[a:z], Y[a:z], lam[a:z], w[a:z], Th[a:z], E[a:z],
                                  skipped[a:z], opt[0], NP, p)
