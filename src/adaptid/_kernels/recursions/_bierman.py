r"""U-D (Bierman) building blocks shared by every recursive kernel.

The covariance is kept factorised, :math:`P = U \operatorname{diag}(D) U^T`
with ``U`` unit upper triangular and ``D > 0`` (Bierman 1977, ch. V), so that
P stays symmetric and positive definite by construction and a diffuse prior
(P0 = 1e10 … 1e12) costs no accuracy.

* measurement update ``P ← P − Pφφᵀ P/(r + φᵀPφ)``: Bierman's algorithm;
* removal of a sample from a window (``r < 0``): the same algorithm with a
  negative weight; every intermediate α stays negative, so the factor stays
  definite exactly when ``1 − c φᵀPφ > 0``, which is checked *before* the
  factor is touched;
* forgetting ``P ← P/λ``: ``D ← D/λ``;
* Kalman time update ``P ← P + R₁``: the sum is formed and re-factorised.

State layout
------------
Each estimator's whole state is one flat float64 vector ``S`` (``(B, L)``
when batched), so a call passes few arguments:
``[ theta (n·p) | U (n·n, by columns) | D (n) ]`` for RLS and KalmanRLS; the
sliding window appends its buffer (see :mod:`._window`).

Everything here is inlined into the streams of :mod:`._rls`,
:mod:`._strategy`, :mod:`._kalman` and :mod:`._window`; ``NP`` and ``p`` are
compile-time constants there when the entry point was called with tuple tags
(:mod:`._dims`). Nothing here validates input: the Python layer does that.

Keep the Bierman updates written flat: composing them of smaller inlined
helpers that return tuples (a refactor once tried) made the sliding window
several times slower while the RLS stream did not move (the window's row in
``benchmarks/bench_rls.py``).
"""

import numpy as np

from ..._config import NJIT, NJIT_INLINE, njit

# --------------------------------------------------------------------------
# building blocks
# --------------------------------------------------------------------------
@njit(**NJIT_INLINE)
def _finite_row(phi, y, NP, p):
    for i in range(NP):
        if not np.isfinite(phi[i]):
            return False
    for j in range(p):
        if not np.isfinite(y[j]):
            return False
    return True


@njit(**NJIT_INLINE)
def _prior_errors(theta, phi, y, e, NP, p):
    for j in range(p):
        s = y[j]
        for i in range(NP):
            s -= phi[i] * theta[i, j]
        e[j] = s


@njit(**NJIT_INLINE)
def _bierman_prep(U, D, phi, f, v, NP):
    """f = Uᵀφ, v = D f; returns φᵀPφ = Σ fⱼ vⱼ."""
    q = 0.0
    for j in range(NP):
        s = phi[j]
        for i in range(j):
            s += U[i, j] * phi[i]
        f[j] = s
        v[j] = D[j] * s
        q += s * v[j]
    return q




@njit(**NJIT_INLINE)
def _bierman_apply(U, D, r, f, v, b, NP):
    """Bierman update with weight r (r < 0: removal). b ← Pφ (old P).

    Returns α = r + φᵀPφ; the gain is b/α.

    Stage j (Bierman 1977, ch. V) is  αⱼ = αⱼ₋₁ + fⱼvⱼ,  Dⱼ ← Dⱼ αⱼ₋₁/αⱼ,
    U[i, j] ← U[i, j] − (fⱼ/αⱼ₋₁) bᵢ,  bᵢ ← bᵢ + U_old[i, j] vⱼ  (i < j),
    bⱼ = vⱼ; each αⱼ is inverted once. :func:`_bierman_apply_pairs` is the
    same update, faster and slower to compile.
    """
    a = r + f[0] * v[0]
    ia = 1.0 / a
    D[0] = D[0] * (r * ia)
    b[0] = v[0]
    for j in range(1, NP):
        an = a + f[j] * v[j]
        ian = 1.0 / an
        D[j] = D[j] * (a * ian)
        pj = -f[j] * ia
        vj = v[j]
        for i in range(j):
            u = U[i, j]
            U[i, j] = u + b[i] * pj
            b[i] += u * vj
        b[j] = vj
        a = an
        ia = ian
    return a


@njit(**NJIT_INLINE)
def _bierman_apply_pairs(U, D, r, f, v, b, NP):
    """:func:`_bierman_apply` with the stages taken two at a time.

    bᵢ is loaded and stored once per pair of columns: faster than one column
    at a time at n = 16 (``benchmarks/bench_rls.py``), for a longer compile
    than the plain RLS kernels. Used by the RLS stream, whose speed is the
    library's headline; the other streams keep :func:`_bierman_apply`.
    """
    a = r + f[0] * v[0]
    ia = 1.0 / a
    D[0] = D[0] * (r * ia)
    b[0] = v[0]
    j = 1
    while j + 1 < NP:
        an = a + f[j] * v[j]
        ian = 1.0 / an
        D[j] = D[j] * (a * ian)
        pj = -f[j] * ia
        vj = v[j]
        a2 = an + f[j + 1] * v[j + 1]
        ia2 = 1.0 / a2
        D[j + 1] = D[j + 1] * (an * ia2)
        pj2 = -f[j + 1] * ian
        vj2 = v[j + 1]
        for i in range(j):
            u = U[i, j]
            bi = b[i]
            U[i, j] = u + bi * pj
            bi += u * vj
            u2 = U[i, j + 1]
            U[i, j + 1] = u2 + bi * pj2
            b[i] = bi + u2 * vj2
        u2 = U[j, j + 1]  # row j of column j + 1, where bⱼ = vⱼ
        U[j, j + 1] = u2 + vj * pj2
        b[j] = vj + u2 * vj2
        b[j + 1] = vj2
        a = a2
        ia = ia2
        j += 2
    if j < NP:
        an = a + f[j] * v[j]
        ian = 1.0 / an
        D[j] = D[j] * (a * ian)
        pj = -f[j] * ia
        vj = v[j]
        for i in range(j):
            u = U[i, j]
            U[i, j] = u + b[i] * pj
            b[i] += u * vj
        b[j] = vj
        a = an
    return a


@njit(**NJIT_INLINE)
def _gain_step(theta, b, a, e, NP, p):
    ia = 1.0 / a
    for i in range(NP):
        g = b[i] * ia
        for j in range(p):
            theta[i, j] += g * e[j]


@njit(**NJIT_INLINE)
def _forget(D, lam, NP):
    if lam != 1.0:
        il = 1.0 / lam
        for i in range(NP):
            D[i] *= il


@njit(**NJIT_INLINE)
def _d_below(D, dthr, NP):
    for i in range(NP):
        if not (D[i] > 0.0 and D[i] < dthr):
            return False
    return True


@njit(**NJIT_INLINE)
def _store(Th, k, theta, NP, p):
    for i in range(NP):
        for j in range(p):
            Th[k, i, j] = theta[i, j]


@njit(**NJIT_INLINE)
def _segment_start(S0, Sout, offsets, g):
    """Rows a:z of segment g, and its state Sout[g] set to the prior S0."""
    S = Sout[g]
    S[:] = S0
    return offsets[g], offsets[g + 1], S


@njit(**NJIT_INLINE)
def _copy_factor(U, D, U2, D2, NP):
    """U2, D2 ← U, D (the strictly upper triangle of U)."""
    for j in range(NP):
        D2[j] = D[j]
        for i in range(j):
            U2[i, j] = U[i, j]


@njit(**NJIT_INLINE)
def _views(S, NP, p):
    theta = S[0:NP * p].reshape((NP, p))
    o = NP * p
    U = S[o:o + NP * NP].reshape((NP, NP)).T  # stored by columns: the inner loops run down them
    o += NP * NP
    D = S[o:o + NP]
    return theta, U, D



@njit(**NJIT_INLINE)
def _max_diag_P(U, D, NP):
    m = 0.0
    for i in range(NP):
        s = D[i]
        for j in range(i + 1, NP):
            s += U[i, j] * U[i, j] * D[j]
        if s > m:
            m = s
    return m


@njit(**NJIT_INLINE)
def _trace_P(U, D, NP):
    t = 0.0
    for j in range(NP):
        s = 1.0
        for i in range(j):
            s += U[i, j] * U[i, j]
        t += D[j] * s
    return t


@njit(**NJIT_INLINE)
def _form_P(U, D, P, NP):
    for i in range(NP):
        for j in range(i, NP):
            s = D[j] * U[i, j] if i < j else D[j]
            for k in range(j + 1, NP):
                s += U[i, k] * D[k] * U[j, k]
            P[i, j] = s
            P[j, i] = s



@njit(**NJIT_INLINE)
def _udu_factor(W, U, D, NP):
    """Upper U-D factorisation W = U diag(D) Uᵀ (only W's upper triangle is read).

    U's strict upper triangle and D are overwritten; its diagonal must be 1
    and its lower triangle 0 on entry. Returns False if W is not PD.
    """
    for j in range(NP - 1, -1, -1):
        d = W[j, j]
        for k in range(j + 1, NP):
            d -= D[k] * U[j, k] * U[j, k]
        if not (d > 0.0):
            return False
        D[j] = d
        for i in range(j):
            s = W[i, j]
            for k in range(j + 1, NP):
                s -= D[k] * U[i, k] * U[j, k]
            U[i, j] = s / d
    return True


@njit(**NJIT_INLINE)
def _time_update(U, D, Q, W, NP):
    """U D Uᵀ ← U D Uᵀ + Q, re-factorised (upper U-D). False if not PD."""
    for i in range(NP):
        for j in range(i, NP):
            s = Q[i, j] + D[j] * U[i, j] if i < j else Q[i, j] + D[j]
            for k in range(j + 1, NP):
                s += U[i, k] * D[k] * U[j, k]
            W[i, j] = s
    return _udu_factor(W, U, D, NP)



@njit(**NJIT_INLINE)
def _add(theta, U, D, phi, y, r, e, f, v, b, NP, p):
    """Add (r > 0) or remove (r < 0) one observation with error e = y − φᵀθ."""
    _bierman_prep(U, D, phi, f, v, NP)
    a = _bierman_apply(U, D, r, f, v, b, NP)
    _gain_step(theta, b, a, e, NP, p)



@njit(**NJIT_INLINE)
def _prep_row(U, D, A, r, f, v, NP):
    q = 0.0
    for j in range(NP):
        s = A[r, j]
        for i in range(j):
            s += U[i, j] * A[r, i]
        f[j] = s
        v[j] = D[j] * s
        q += s * v[j]
    return q



@njit(**NJIT)
def ud_factor(P, U, D):
    """Upper U-D factorisation P = U diag(D) Uᵀ. Returns False if P is not PD."""
    n = P.shape[0]
    for i in range(n):
        for j in range(n):
            U[i, j] = 1.0 if i == j else 0.0
    return _udu_factor(P, U, D, n)
