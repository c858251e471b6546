r"""The covariance form over many streams in SIMD (``RLS(form="covariance")``).

The lane steps of :mod:`._soa` for the covariance form: per lane, the
operations of :func:`._covariance._cov_stream` in the same order, so each
stream's bits equal the scalar kernel's (tests/test_soa.py). A block keeps,
lane-major, the upper triangle of P (``P[i, j, l]``, i ≤ j: P stays exactly
symmetric, as in the scalar kernel, because ``cᵢcⱼ = cⱼcᵢ`` bit for bit), θ
and the first windup sample. Per step and lane (Ljung & Söderström 1983,
eq. 2.19; r = λ/w):

.. math::

    u = P\varphi,\quad q = \varphi^T u,\quad d = r + q,\quad
    \theta \leftarrow \theta + (u/d)\,\varepsilon,\quad
    P_{ij} \leftarrow (P_{ij} - c_i c_j s)/\lambda,

with c = u, s = 1/d for n ≤ ``SQRT_FREE_N`` and c = u/√d, s = 1 above
(:func:`._covariance._measure`). u is formed at the start of each step as
:func:`._covariance._matvec` forms it (the scalar kernel's fused sweep gives
the same bits). A lane whose sample is skipped or has weight 0 runs the same
instructions with c = 0, s = 0 (so P ← P·(1/λ) or P·1 exactly) and keeps θ
with a select.

The scalar kernel's repair of an indefinite P (:func:`._covariance.cov_repair`,
rare) is not done in the lanes: a lane that would need it (φᵀPφ ≤ 0 for φ ≠ 0,
or a diagonal entry not positive after the update), or whose P was not
exactly symmetric when loaded, is marked (its windup sample set to NaN), and
the block driver reruns that stream with the scalar kernel from its initial
state. n ≤ ``MAX_N``: from n = 8 on the scalar kernel sums φᵀu in vector code
whose products LLVM must not contract, which a lane loop cannot promise.
"""

import numpy as np

from ..._config import njit
from ..recursions._covariance import SQRT_FREE_N, cov_run
from ..toolchain._vecir import fma
from ._soa_lanes import INL, LANES, blend, lane_sample, lane_scratch

#: the largest n of these lane steps (see the module docstring)
MAX_N = 7

_INL = INL


@njit(**_INL)
def cov_lane_steps(A, B, th, bad, X, Yc, Lc, Wc, Rc, Ec, Sk, Thc, k0, t0, t1, dthr, NP):
    """Steps t0 ≤ t < t1 of every lane (module docstring); the arguments as
    :func:`._soa_ud.ud_lane_steps` takes them, with P's upper triangle in the place
    of U, u in that of D, and Rc = r = λ/w (λ where w = 1)."""
    P, u = A, B  # the names of lane_steps (one signature for both forms)
    c = lane_scratch(1, NP)
    for t in range(t0, t1):
        for l in range(LANES):
            ok, upd, e = lane_sample(X, Yc, Wc, th, t, l, NP)
            for i in range(NP):  # _matvec: u = Σⱼ φⱼ P[j, :]
                u[0, i, l] = 0.0
            for j in range(NP):
                pj = X[t, j, l]
                for i in range(NP):
                    u[0, i, l] += (P[j, i, l] if j <= i else P[i, j, l]) * pj
            q = 0.0  # _quad (n < 8)
            nz = False
            for i in range(NP):
                q += X[t, i, l] * u[0, i, l]
                nz |= X[t, i, l] != 0.0
            d = Rc[0, t, l] + q
            idd = 1.0 / d
            for i in range(NP):  # theta_step
                tk = th[0, i, l]
                tk = blend(upd, tk + (u[0, i, l] * idd) * e, tk)
                th[0, i, l] = tk
                Thc[t, i, l] = tk
            if NP <= SQRT_FREE_N:
                s = blend(upd, idd, 0.0)
                for i in range(NP):
                    c[0, i, l] = blend(upd, u[0, i, l], 0.0)
            else:
                s = 1.0
                sq = idd * np.sqrt(d)
                for i in range(NP):
                    c[0, i, l] = blend(upd, u[0, i, l] * sq, 0.0)
            il = blend(ok, Lc[0, t, l], 1.0)
            inside = True
            pos = True
            for j in range(NP):  # _sweep on the upper triangle
                cj = c[0, j, l]
                for i in range(j, NP):
                    if NP <= SQRT_FREE_N:
                        v = fma(cj * c[0, i, l], -s, P[j, i, l]) * il
                    else:
                        v = (P[j, i, l] - cj * c[0, i, l]) * il
                    P[j, i, l] = v
                dj = P[j, j, l]
                inside &= (dj > 0.0) & (dj < dthr)
                pos &= dj > 0.0
            inside |= not ok
            bk = bad[0, 0, l]
            # a lane that needs the scalar kernel's repair: NaN (then kept: NaN < 0 is False)
            bk = blend(upd & ((not pos) | ((not q > 0.0) & nz)), np.nan, bk)
            bad[0, 0, l] = blend((bk < 0.0) & (not inside), float(k0 + t), bk)
            Ec[0, t, l] = blend(ok, e, np.nan)
            Sk[0, t, l] = blend(ok, 0.0, 1.0)


@njit(**_INL)
def cov_lane_load(Sv, P, u, th, bad, l, NP):
    """Lane l ← the flat state Sv = [θ | P (n·n) | 0] (p = 1): θ and P's upper
    triangle; ``bad`` NaN (the scalar kernel reruns the stream) unless P is
    exactly symmetric (bit for bit)."""
    bits = Sv.view(np.int64)
    sym = True
    for j in range(NP):
        th[0, j, l] = Sv[j]
        for i in range(j + 1):
            P[i, j, l] = Sv[NP + j * NP + i]
            sym &= bits[NP + j * NP + i] == bits[NP + i * NP + j]
    bad[0, 0, l] = -1.0 if sym else np.nan


@njit(**_INL)
def cov_lane_store(Sv, P, u, th, l, NP):
    """The flat state Sv ← lane l (θ, P from its upper triangle)."""
    for j in range(NP):
        Sv[j] = th[0, j, l]
        for i in range(j + 1):
            Sv[NP + j * NP + i] = P[i, j, l]
            Sv[NP + i * NP + j] = P[i, j, l]


@njit(**_INL)
def cov_rerun(S, Phi, Y, lam, w, Th, E, skipped, Lk, opt, mat, ntag):
    """One stream by the scalar kernel (a lane that needs its repair); its code."""
    return cov_run(S, Phi, Y, lam, w, Th, E, skipped, Lk, None, opt, mat, ntag, (0,))
