r"""Windowed statistics updated per sample: the arithmetic of ``run(..., stats=True)``.

Called from the streams of :mod:`._rls` and :mod:`._window` through the
hooks at the end of this module. The output ``St`` of the common signature
is an array of N + 1 rows when statistics are asked for (row 0: the
accumulators before the run, row k + 1: after sample k) and ``None`` when
not: the hooks are overloaded on its type, so without statistics they
compile to nothing and the streams run the code they ran before (a run-time
test of ``St`` slowed the n = 4 RLS stream, ``benchmarks/bench_rls.py``). A row is

``[ count, n_eff, W, Σ c log w, zeros | diag P (n) | J (p) | ȳ (p) | S_yy (p) ]``

with :math:`c_i = \prod_{l=i+1}^{k}\lambda_l` the forgetting factor of sample i
(0 outside the window), ``count`` the samples in the cost, ``n_eff`` = Σcᵢ,
``W`` = Σcᵢwᵢ, ``zeros`` the samples of weight 0 in the cost,
:math:`\bar y = \sum c_iw_iy_i/W` and :math:`S_{yy} = \sum c_iw_i(y_i-\bar y)^2`
(West 1979's weighted update, and its reverse for a removal), and
:math:`J = \min_\theta V_k(\theta)` the minimised cost (the weighted residual
sum of squares plus the decayed prior term).

J is updated with the errors the streams already have. Adding sample k
(the recursion of the minimised weighted cost, with a-priori error e and
a-posteriori error ε: Ljung & Söderström 1983, ch. 2; Haykin, *Adaptive
Filter Theory*, RLS chapter, "update recursion for the sum of weighted
error squares"), with weight w
and α = 1/w + φᵀ(P/λ)φ (the α of the Bierman update),

.. math:: J_k = \lambda_k J_{k-1} + w_k e_k \varepsilon_k
              = \lambda_k J_{k-1} + e_k^2/\alpha,

since the a-posteriori error is ε = e/(wα). Removing sample r of factor
:math:`c = c_r w_r` (the window's downdate, a Bierman update with weight
−1/c, so α = −1/c + φ_rᵀPφ_r < 0), with r_r its residual under the current θ,
minimising V − c(y_r − φ_rᵀθ)² instead of V (Sherman–Morrison; the
downdate of the sliding-window RLS, Yamamoto 1991, eqs. 62–65) gives

.. math:: J \leftarrow J - \frac{c\, r_r^2}{1 - c\,\varphi_r^T P\varphi_r} = J + r_r^2/\alpha .

When the window is re-solved from its buffer the row is recomputed directly
(:func:`_rs_direct`).
"""

import numpy as np

from ..._config import NJIT, NJIT_INLINE, njit
from ..toolchain._specialise import on_none

HEAD = 5  # count, n_eff, W, Σ c log w, zeros


def width(n, p):
    """Columns of a row of ``St`` for n parameters and p outputs."""
    return HEAD + n + 3 * p


@njit(**NJIT_INLINE)
def _rs_begin(St, k):
    """Row k + 1 starts as row k (a skipped sample changes nothing)."""
    for i in range(St.shape[1]):
        St[k + 1, i] = St[k, i]


@njit(**NJIT_INLINE)
def _rs_forget(St, k, lam, NP, p):
    """Every sum of row k + 1 times λ (the mean does not change)."""
    if lam != 1.0:
        St[k + 1, 1] *= lam
        St[k + 1, 2] *= lam
        St[k + 1, 3] *= lam
        o = HEAD + NP
        for j in range(p):
            St[k + 1, o + j] *= lam
            St[k + 1, o + 2 * p + j] *= lam


@njit(**NJIT_INLINE)
def _rs_add(St, k, y, wk, e, a, NP, p):
    """Sample k enters with weight wk (e its a-priori errors, a the Bierman α)."""
    St[k + 1, 0] += 1.0
    St[k + 1, 1] += 1.0
    if wk > 0.0:
        o = HEAD + NP
        ia = 1.0 / a
        W = St[k + 1, 2] + wk
        St[k + 1, 2] = W
        St[k + 1, 3] += np.log(wk)
        for j in range(p):
            St[k + 1, o + j] += e[j] * e[j] * ia
            m0 = St[k + 1, o + p + j]
            d = y[j] - m0
            m = m0 + wk * d / W
            St[k + 1, o + p + j] = m
            St[k + 1, o + 2 * p + j] += wk * d * (y[j] - m)
    else:
        St[k + 1, 4] += 1.0


@njit(**NJIT_INLINE)
def _rs_enter(St, k, y, lam, wk, e, a, NP, p):
    """Row k + 1 = row k forgotten by λ with sample k added."""
    _rs_begin(St, k)
    _rs_forget(St, k, lam, NP, p)
    _rs_add(St, k, y, wk, e, a, NP, p)


@njit(**NJIT_INLINE)
def _rs_remove(St, k, y, wr, cl, er, a, NP, p):
    """The oldest sample leaves: weight wr, forgetting factor cl, residual er, α = a < 0."""
    St[k + 1, 0] -= 1.0
    St[k + 1, 1] -= cl
    if wr > 0.0:
        o = HEAD + NP
        c = wr * cl
        W = St[k + 1, 2] - c
        St[k + 1, 2] = W
        St[k + 1, 3] -= cl * np.log(wr)
        ia = 1.0 / a
        for j in range(p):
            St[k + 1, o + j] += er[j] * er[j] * ia
            m0 = St[k + 1, o + p + j]
            d = y[j] - m0
            m = m0 - c * d / W if W > 0.0 else 0.0
            St[k + 1, o + p + j] = m
            s = St[k + 1, o + 2 * p + j] - c * d * (y[j] - m)
            St[k + 1, o + 2 * p + j] = s if s > 0.0 and W > 0.0 else 0.0
    else:
        St[k + 1, 4] -= 1.0


@njit(**NJIT_INLINE)
def _rs_diag(St, k, U, D, NP):
    """diag P = diag(U D Uᵀ) into row k + 1."""
    for i in range(NP):
        s = D[i]
        for j in range(i + 1, NP):
            s += U[i, j] * U[i, j] * D[j]
        St[k + 1, HEAD + i] = s


@njit(**NJIT_INLINE)
def _rs_direct(St, r, theta, Bphi, By, Bw, BL, L, pos, count, theta0, U0, D0, z, M, NP, p):
    """Row r of the window computed directly from its buffer and θ (no recursion)."""
    n_eff = 0.0
    W = 0.0
    lw = 0.0
    zeros = 0.0
    start = pos - count
    for t in range(count):
        s = (start + t) % M
        cl = np.exp(L - BL[s])
        n_eff += cl
        if Bw[s] > 0.0:
            W += Bw[s] * cl
            lw += cl * np.log(Bw[s])
        else:
            zeros += 1.0
    St[r, 0] = count
    St[r, 1] = n_eff
    St[r, 2] = W
    St[r, 3] = lw
    St[r, 4] = zeros
    o = HEAD + NP
    scale = np.exp(max(L, -600.0))  # the prior's weight, floored as in the re-solve
    for j in range(p):
        sy = 0.0
        for t in range(count):
            s = (start + t) % M
            sy += Bw[s] * np.exp(L - BL[s]) * By[s, j]
        m = sy / W if W > 0.0 else 0.0
        syy = 0.0
        J = 0.0
        for t in range(count):
            s = (start + t) % M
            c = Bw[s] * np.exp(L - BL[s])
            d = By[s, j] - m
            syy += c * d * d
            res = By[s, j]
            for i in range(NP):
                res -= Bphi[s, i] * theta[i, j]
            J += c * res * res
        # prior term: scale (θ−θ0)ᵀ P0⁻¹ (θ−θ0), with U0 z = θ − θ0 (U0 unit upper)
        for i in range(NP - 1, -1, -1):
            zi = theta[i, j] - theta0[i, j]
            for l in range(i + 1, NP):
                zi -= U0[i, l] * z[l]
            z[i] = zi
            J += scale * zi * zi / D0[i]
        St[r, o + j] = J
        St[r, o + p + j] = m
        St[r, o + 2 * p + j] = syy


@njit(**NJIT)
def _rs_direct_call(St, r, theta, Bphi, By, Bw, BL, meta, theta0, U0, D0, z, U, D, M, NP, p):
    _rs_direct(St, r, theta, Bphi, By, Bw, BL, meta[0], int(meta[1]), int(meta[2]), theta0,
               U0, D0, z, M, NP, p)
    _rs_diag(St, r - 1, U, D, NP)


# --------------------------------------------------------------------------
# hooks of the streams: the work when St is an array, nothing when it is None
# (chosen at compile time; the plain functions are what runs without numba)
# --------------------------------------------------------------------------
def rls_hook(St, k, ok, Y, lam, wk, e, a, U, D, NP, p):
    """RLS after sample k: forgotten, sample added (or unchanged when skipped), diag P."""
    if St is None:
        return
    if ok:
        _rs_enter(St, k, Y[k], lam[k], wk, e, a, NP, p)
        _rs_diag(St, k, U, D, NP)
    else:
        _rs_begin(St, k)


def window_enter_hook(St, k, Y, lk, wk, e, a, NP, p):
    """Window: row k + 1 = row k forgotten, sample k added."""
    if St is not None:
        _rs_enter(St, k, Y[k], lk, wk, e, a, NP, p)


def window_remove_hook(St, k, rebuilt, By, Bw, BL, pos, L, c, er, a, NP, p):
    """Window: the sample at ``pos`` left by a downdate (not by a re-solve)."""
    if St is not None and not rebuilt:
        _rs_remove(St, k, By[pos], Bw[pos] if c > 0.0 else 0.0, np.exp(L - BL[pos]), er, a,
                   NP, p)


def window_direct_hook(St, r, theta, Bphi, By, Bw, BL, meta, theta0, U0, D0, z, U, D, M, NP,
                       p):
    """Window: row r recomputed from the buffer (start of a run, after a re-solve)."""
    if St is not None:
        _rs_direct_call(St, r, theta, Bphi, By, Bw, BL, meta, theta0, U0, D0, z, U, D, M, NP, p)


def srif_hook(St, k, ok, Y, lam, wk, ry, U, D, NP, p):
    """Diffuse RLS prologue (:mod:`._diffuse`) after sample k: forgotten, sample added
    with the part ``ry`` of its row that the Givens rotations leave over (J += ry²:
    the rotations are orthogonal, so from full rank on J is the weighted residual sum
    of squares of the samples so far, Bierman 1977, ch. V.3); diag P."""
    if St is None:
        return
    if ok:
        _rs_enter(St, k, Y[k], lam[k], wk, ry, 1.0, NP, p)
        _rs_diag(St, k, U, D, NP)
    else:
        _rs_begin(St, k)


def rows_from(St, k):
    """Rows k, k + 1, … of ``St`` (the rows of a stream started at sample k), or None."""
    return None if St is None else St[k:]


def window_end_hook(St, k, ok, U, D, NP):
    """Window: row k + 1 unchanged when sample k was skipped; diag P."""
    if St is None:
        return
    if not ok:
        _rs_begin(St, k)
    _rs_diag(St, k, U, D, NP)


def sub(St, s):
    """Stream s of a batch: ``St[s]``, or None."""
    return None if St is None else St[s]


# in compiled code each hook is nothing when St is None (toolchain._specialise)
on_none(rls_hook, lambda St, k, ok, Y, lam, wk, e, a, U, D, NP, p: None)
on_none(window_enter_hook, lambda St, k, Y, lk, wk, e, a, NP, p: None)
on_none(window_remove_hook, lambda St, k, rebuilt, By, Bw, BL, pos, L, c, er, a, NP, p: None)
on_none(window_direct_hook, lambda St, r, theta, Bphi, By, Bw, BL, meta, theta0, U0, D0, z, U,
        D, M, NP, p: None)
on_none(window_end_hook, lambda St, k, ok, U, D, NP: None)
on_none(srif_hook, lambda St, k, ok, Y, lam, wk, ry, U, D, NP, p: None)
on_none(sub, lambda St, s: None, lambda St, s: St[s])
on_none(rows_from, lambda St, k: None, lambda St, k: St[k:])
