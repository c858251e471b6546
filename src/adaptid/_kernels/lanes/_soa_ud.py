r"""The U-D (Bierman) lane steps of the structure-of-arrays kernels (:mod:`._soa`).

Per lane, :func:`._rls._rls_body`'s update in the same operations and order
(Bierman stages two at a time, as :func:`._bierman._bierman_apply_pairs`), so
each stream's bits equal the scalar kernel's. A block's state, lane-major:
``U[i, j, l]`` (strict upper triangle), ``D[0, i, l]``, ``θ[0, i, l]``, the
first windup sample ``bad[0, 0, l]``.
"""

import numpy as np

from ..._config import njit
from ._soa_lanes import INL, LANES, blend, lane_sample, lane_scratch

_INL = INL


@njit(**_INL)
def _lane_pivot(D, f, v, a, il, ok, upd, j, l):
    """Column j's α = a + fⱼvⱼ and 1/α; the pivot Dⱼ ← (Dⱼ/λ)·(a/α) where ``upd``,
    Dⱼ/λ where only ``ok`` (a at column 0: r)."""
    an = a + f[0, j, l] * v[0, j, l]
    ian = 1.0 / an
    d0 = D[0, j, l]
    dd = d0 * il
    D[0, j, l] = blend(ok, blend(upd, dd * (a * ian), dd), d0)
    return an, ian


@njit(**_INL)
def _lane_bierman(U, D, f, v, b, r, il, ok, upd, l, NP):
    """:func:`._bierman._bierman_apply_pairs` for lane l on the pivots D/λ.

    U and D take the updated values where ``upd``, D the forgotten ones
    D/λ where only ``ok``, and keep theirs elsewhere. Returns α.
    """
    a, ia = _lane_pivot(D, f, v, r, il, ok, upd, 0, l)
    b[0, 0, l] = v[0, 0, l]
    for j in range(1, NP - 1, 2):
        an, ian = _lane_pivot(D, f, v, a, il, ok, upd, j, l)
        pj = -f[0, j, l] * ia
        vj = v[0, j, l]
        a2, ia2 = _lane_pivot(D, f, v, an, il, ok, upd, j + 1, l)
        pj2 = -f[0, j + 1, l] * ian
        vj2 = v[0, j + 1, l]
        for i in range(j):
            u = U[i, j, l]
            bi = b[0, i, l]
            U[i, j, l] = blend(upd, u + bi * pj, u)
            bi += u * vj
            u2 = U[i, j + 1, l]
            U[i, j + 1, l] = blend(upd, u2 + bi * pj2, u2)
            b[0, i, l] = bi + u2 * vj2
        u2 = U[j, j + 1, l]
        U[j, j + 1, l] = blend(upd, u2 + vj * pj2, u2)
        b[0, j, l] = vj + u2 * vj2
        b[0, j + 1, l] = vj2
        a = a2
        ia = ia2
    j = NP - 1
    if NP % 2 == 0 and NP > 1:  # the last column alone
        an, ian = _lane_pivot(D, f, v, a, il, ok, upd, j, l)
        pj = -f[0, j, l] * ia
        vj = v[0, j, l]
        for i in range(j):
            u = U[i, j, l]
            U[i, j, l] = blend(upd, u + b[0, i, l] * pj, u)
            b[0, i, l] += u * vj
        b[0, j, l] = vj
        a = an
    return a


@njit(**_INL)
def ud_lane_steps(A, B, th, bad, X, Yc, Lc, Wc, Rc, Ec, Sk, Thc, k0, t0, t1, dthr, NP):
    """Steps t0 ≤ t < t1 of every lane: the body of :func:`._rls._rls_body` per lane.

    Row t of X (Φ), Yc (y), Lc (1/λ), Wc (w), Rc (1/w) holds sample k0 + t,
    lane-major; Ec, Sk and Thc receive ε, the skipped flags and θ.
    """
    U, D = A, B  # the names of lane_steps (one signature for both forms)
    f = lane_scratch(1, NP)
    v = lane_scratch(1, NP)
    b = lane_scratch(1, NP)
    for t in range(t0, t1):
        for l in range(LANES):
            ok, upd, e = lane_sample(X, Yc, Wc, th, t, l, NP)
            il = Lc[0, t, l]
            for j in range(NP):  # _bierman_prep on D/λ
                s = X[t, j, l]
                for i in range(j):
                    s += U[i, j, l] * X[t, i, l]
                f[0, j, l] = s
                v[0, j, l] = (D[0, j, l] * il) * s
            a = _lane_bierman(U, D, f, v, b, Rc[0, t, l], il, ok, upd, l, NP)
            ia = 1.0 / a
            inside = True
            for i in range(NP):
                g = b[0, i, l] * ia
                tk = th[0, i, l]
                tk = blend(upd, tk + g * e, tk)
                th[0, i, l] = tk
                Thc[t, i, l] = tk
                d = D[0, i, l]
                inside &= (d > 0.0) & (d < dthr)
            inside |= not ok
            bk = bad[0, 0, l]
            bad[0, 0, l] = blend((bk < 0.0) & (not inside), float(k0 + t), bk)
            Ec[0, t, l] = blend(ok, e, np.nan)
            Sk[0, t, l] = blend(ok, 0.0, 1.0)


@njit(**_INL)
def ud_lane_load(Sv, U, D, th, bad, l, NP):
    """Lane l ← the flat state Sv = [θ | U by columns | D] (p = 1)."""
    for j in range(NP):
        th[0, j, l] = Sv[j]
        D[0, j, l] = Sv[NP + NP * NP + j]
        for i in range(j):
            U[i, j, l] = Sv[NP + j * NP + i]
    bad[0, 0, l] = -1.0


@njit(**_INL)
def ud_lane_store(Sv, U, D, th, l, NP):
    """The flat state Sv ← lane l (θ, the strict upper triangle of U, D)."""
    for j in range(NP):
        Sv[j] = th[0, j, l]
        Sv[NP + NP * NP + j] = D[0, j, l]
        for i in range(j):
            Sv[NP + j * NP + i] = U[i, j, l]
