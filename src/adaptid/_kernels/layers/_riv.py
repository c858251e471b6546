r"""Compiled recursive instrumental variables with an auxiliary model (RIV).

One pass over a record of an ARX structure (na, nb, nk per input) as
:class:`adaptid.models.RecursiveIV` documents it. Per sample k:

* regressor :math:`\varphi_k = [-y_{k-1} … -y_{k-n_a}, u_{k-n_k} …]` and
  instrument :math:`\zeta_k = [-x_{k-1} … -x_{k-n_a}, u_{k-n_k} …]` (the
  same input lags; x the auxiliary model's noise-free output), or
  :math:`\zeta_k = \varphi_k` while the sample is in the warm-up;
* :math:`d_k = \lambda + \varphi_k^TP\zeta_k`; if
  :math:`|d_k| \le \text{rtol}\,(\lambda + \sum_i|\varphi_{k,i}(P\zeta_k)_i|)`
  the IV normal equations become singular: no update (status 2); a
  :math:`d_k \le 0` (status 1) flips the sign of
  :math:`\det R_k` (:math:`R_k = P_k^{-1}`; its sign relative to
  :math:`\det P_0^{-1}` is kept in ``acc[2]``);
* :math:`L_k = P\zeta_k/d_k`, :math:`\theta \mathrel{+}= L_k(y_k - \varphi_k^T\theta)`,
  :math:`P = (P - P\zeta_k\varphi_k^TP/d_k)/\lambda` (not symmetric);
* the sums of the covariance estimate, with forgetting:
  :math:`S_{\zeta\zeta}`, :math:`S_{\varphi\varphi}`, :math:`s_{\varphi y}`,
  :math:`s_{yy}` and the weight :math:`\sum\lambda^{k-j}`;
* :math:`x_k = \zeta^{x\,T}_k\theta_k` with the new estimate (the auxiliary
  model's instrument row, also during the warm-up), then the lag buffers shift.

Nothing here validates; the state arrays are updated in place.
"""

import numpy as np

from ..._config import NJIT, NJIT_INLINE, njit

__all__ = ["riv_run"]


@njit(**NJIT_INLINE)
def _rows(phi, zx, ybuf, xbuf, ubuf, uk, nb, nk, na):
    """φ and the auxiliary instrument row of one sample from the buffers and u(k)."""
    for j in range(na):
        phi[j] = -ybuf[j]
        zx[j] = -xbuf[j]
    c = na
    for i in range(nb.shape[0]):
        for j in range(nk[i], nk[i] + nb[i]):
            v = uk[i] if j == 0 else ubuf[i, j - 1]
            phi[c] = v
            zx[c] = v
            c += 1


@njit(**NJIT_INLINE)
def _shift(ybuf, xbuf, ubuf, yk, xk, uk):
    """Push y(k), x(k), u(k) to the front of their lag buffers."""
    for j in range(ybuf.shape[0] - 1, 0, -1):
        ybuf[j] = ybuf[j - 1]
        xbuf[j] = xbuf[j - 1]
    if ybuf.shape[0]:
        ybuf[0] = yk
        xbuf[0] = xk
    for i in range(ubuf.shape[0]):
        for j in range(ubuf.shape[1] - 1, 0, -1):
            ubuf[i, j] = ubuf[i, j - 1]
        if ubuf.shape[1]:
            ubuf[i, 0] = uk[i]


@njit(**NJIT_INLINE)
def _accumulate(S, Sff, sfy, acc, phi, zeta, yk, lam):
    """Forgetting sums of ζζᵀ, φφᵀ, φy, y² and of the weights."""
    n = phi.shape[0]
    for i in range(n):
        sfy[i] = lam * sfy[i] + phi[i] * yk
        for j in range(n):
            S[i, j] = lam * S[i, j] + zeta[i] * zeta[j]
            Sff[i, j] = lam * Sff[i, j] + phi[i] * phi[j]
    acc[0] = lam * acc[0] + yk * yk
    acc[1] = lam * acc[1] + 1.0


@njit(**NJIT_INLINE)
def _iv_update(theta, P, phi, zeta, yk, lam, rtol, Pz, fP):
    """One RIV update of θ and P; returns (a-priori prediction, status)."""
    n = phi.shape[0]
    yhat = 0.0
    for i in range(n):
        yhat += phi[i] * theta[i]
    den = lam
    scale = lam
    for i in range(n):
        s = 0.0
        r = 0.0
        for j in range(n):
            s += P[i, j] * zeta[j]
            r += phi[j] * P[j, i]
        Pz[i] = s
        fP[i] = r
    for i in range(n):
        den += phi[i] * Pz[i]
        scale += abs(phi[i] * Pz[i])
    if not abs(den) > rtol * scale:
        return yhat, 2
    g = (yk - yhat) / den
    for i in range(n):
        theta[i] += Pz[i] * g
    for i in range(n):
        c = Pz[i] / den
        for j in range(n):
            P[i, j] = (P[i, j] - c * fP[j]) / lam
    return yhat, 1 if den <= 0.0 else 0


@njit(**NJIT)
def riv_run(theta, P, S, Sff, sfy, acc, ybuf, xbuf, ubuf, y, U, nb, nk, lam, rtol, warm,
            Theta, Yhat, X, Z, status):
    """The recursion over samples k = 0 … N−1; ``warm`` of them (the first) use ζ = φ.

    In/out: θ (n), P (n, n), S, Sff (n, n), sfy (n), acc [s_yy, Σ weights,
    sign of det R_k relative to det P_0⁻¹],
    ybuf, xbuf (na), ubuf (m, Lu). Out: Theta (N, n), Yhat (N), X (N),
    Z (N, n) the instrument rows used, status (N) int64 (0, 1, 2 above).
    """
    n = theta.shape[0]
    na = ybuf.shape[0]
    phi = np.empty(n)
    zx = np.empty(n)
    Pz = np.empty(n)
    fP = np.empty(n)
    for k in range(y.shape[0]):
        _rows(phi, zx, ybuf, xbuf, ubuf, U[k], nb, nk, na)
        zeta = phi if k < warm else zx
        yhat, st = _iv_update(theta, P, phi, zeta, y[k], lam, rtol, Pz, fP)
        if st != 2:
            _accumulate(S, Sff, sfy, acc, phi, zeta, y[k], lam)
        if st == 1:
            acc[2] = -acc[2]
        xk = 0.0
        for i in range(n):
            xk += zx[i] * theta[i]
            Theta[k, i] = theta[i]
            Z[k, i] = zeta[i]
        Yhat[k] = yhat
        X[k] = xk
        status[k] = st
        _shift(ybuf, xbuf, ubuf, y[k], xk, U[k])
