r"""Filter, likelihood and fixed-interval smoother of the random-walk Kalman filter.

The kernels of ``KalmanRLS.smooth``, ``KalmanRLS.loglike`` and
``KalmanRLS.fit_variances``: the state-space model

.. math::

    \theta_{k+1} = \theta_k + \nu_k,\ E\,\nu\nu^T = R_1,\qquad
    y_k = \varphi_k^T\theta_k + e_k,\ E\,e_k^2 = R_2/w_k,

run from the prior :math:`\theta_1 \sim (a_1, P_1)` (known) or from the
exact diffuse prior :math:`P_1 = \kappa P_\infty + P_*`, :math:`P_\infty = I`,
:math:`P_* = 0`, :math:`\kappa\to\infty`, in covariance form (not the U-D
factors of :mod:`._kalman`: the smoother needs the predicted covariances).

Forward pass, per sample (Durbin & Koopman 2012, §4.3, and the univariate
exact diffuse filter of §5.2, as statsmodels' ``_univariate_diffuse``
writes it): :math:`v = y - \varphi^Ta`, :math:`M = P\varphi`,
:math:`F = \varphi^TM + R_2/w`; while diffuse, :math:`M_\infty = P_\infty\varphi`,
:math:`F_\infty = \varphi^TM_\infty`, and a step with
:math:`F_\infty > \text{tol}\cdot\varphi^T\varphi` (a *rank step*, the
rule of ``KalmanRLS(P0="diffuse")``) updates with the diffuse gain and adds
:math:`-\tfrac12\log(2\pi F_\infty)` to the log-likelihood; any other step
adds :math:`-\tfrac12(\log 2\pi F + v^2/F)`. After n rank steps
:math:`P_\infty = 0`. Then :math:`P \mathrel{+}= R_1`.

Backward pass (Durbin & Koopman 2012, §4.4.3 and §5.3; with the identity
transition this is the Rauch–Tung–Striebel smoother of Rauch, Tung &
Striebel 1965, Särkkä 2013 §8.2, without the inverse of the predicted
covariance): with :math:`K = M/F`, :math:`L = I - K\varphi^T`,

.. math::

    r \leftarrow \varphi v/F + L^T r,\quad
    N \leftarrow \varphi\varphi^T/F + L^T N L,\quad
    \hat\theta_{k|N} = a_k + P_k r,\quad P_{k|N} = P_k - P_k N P_k,

and the diffuse recursions of :math:`r^{(1)}, N^{(1)}, N^{(2)}` in the
diffuse samples. Sample kinds stored in ``kind``: 0 missing (w = 0 or not
finite: time update only), 1 ordinary, 2 diffuse rank step, 3 diffuse step
with :math:`F_\infty = 0`. Nothing here validates its input.
"""

import math

import numpy as np

from ..._config import NJIT, njit

_LOG2PI = math.log(2.0 * math.pi)


@njit(**NJIT)
def _gemm(A, ta, B, tb, alpha, beta, out):
    """out ← β·out + α·op(A)·op(B) (n × n; op the transpose when ``ta``/``tb``).

    With β = 0 ``out`` is written, never read: the work arrays come from
    ``np.empty`` and 0·NaN would be NaN."""
    n = out.shape[0]
    for i in range(n):
        for j in range(n):
            s = 0.0
            for m in range(n):
                x = A[m, i] if ta else A[i, m]
                y = B[j, m] if tb else B[m, j]
                s += x * y
            if beta == 0.0:
                out[i, j] = alpha * s
            else:
                out[i, j] = beta * out[i, j] + alpha * s


@njit(**NJIT)
def _sandwich(L, Nm, R, alpha, out, tmp):
    """out ← out + α·Lᵀ Nm R."""
    _gemm(Nm, False, R, False, 1.0, 0.0, tmp)
    _gemm(L, True, tmp, False, alpha, 1.0, out)


@njit(**NJIT)
def _rank_step(a, P, Pi, M, Mi, v, f, fi):
    """Measurement update with F∞ > 0 (statsmodels' K0, K1, L0, L1 written out)."""
    n = a.shape[0]
    for i in range(n):
        a[i] += Mi[i] / fi * v
    c = f / (fi * fi)
    for i in range(n):
        for j in range(i, n):
            s = P[i, j] + c * Mi[i] * Mi[j] - (M[i] * Mi[j] + Mi[i] * M[j]) / fi
            P[i, j] = s
            P[j, i] = s
            s = Pi[i, j] - Mi[i] * Mi[j] / fi
            Pi[i, j] = s
            Pi[j, i] = s


@njit(**NJIT)
def _ordinary_step(a, P, M, v, f):
    n = a.shape[0]
    for i in range(n):
        a[i] += M[i] / f * v
    for i in range(n):
        for j in range(i, n):
            s = P[i, j] - M[i] * M[j] / f
            P[i, j] = s
            P[j, i] = s


@njit(**NJIT)
def _finite(phi, y):
    if not np.isfinite(y):
        return False
    for i in range(phi.shape[0]):
        if not np.isfinite(phi[i]):
            return False
    return True


@njit(**NJIT)
def _measure(a, P, Pi, phi, y, r2w, diffuse, tol, M, Mi, acc):
    """One measurement update in place; returns (kind, v, F, F∞) and adds to ``acc``.

    ``acc``: [Σ v²/F, Σ log F, count, Σ log F∞, rank steps] over the samples
    of each kind (the log-likelihood is −½[(count + rank steps)·log 2π + the rest]).
    """
    n = a.shape[0]
    v = y
    for i in range(n):
        v -= phi[i] * a[i]
    f = r2w
    fi = 0.0
    pp = 0.0
    for i in range(n):
        s = 0.0
        t = 0.0
        for j in range(n):
            s += P[i, j] * phi[j]
            t += Pi[i, j] * phi[j]
        M[i] = s
        Mi[i] = t
    for i in range(n):
        f += phi[i] * M[i]
        fi += phi[i] * Mi[i]
        pp += phi[i] * phi[i]
    if diffuse and fi > tol * pp:
        _rank_step(a, P, Pi, M, Mi, v, f, fi)
        acc[3] += math.log(fi)
        acc[4] += 1.0
        return 2, v, f, fi
    _ordinary_step(a, P, M, v, f)
    acc[0] += v * v / f
    acc[1] += math.log(f)
    acc[2] += 1.0
    return (3 if diffuse else 1), v, f, fi


@njit(**NJIT)
def _filter(Phi, y, w, a, P, Pi, Q, r2, diffuse, tol, A, PP, PI, Af, PF, V, F, FI, kind, acc):
    """Forward pass from (a, P, Pi) (updated in place); stores when ``A`` has N rows.

    Returns whether the filter is still diffuse after the last sample."""
    N, n = Phi.shape
    store = A.shape[0] == N
    M = np.empty(n)
    Mi = np.empty(n)
    for k in range(N):
        if store:
            A[k] = a
            PP[k] = P
            if PI.shape[0] == N:
                PI[k] = Pi
        kd, v, f, fi = 0, np.nan, np.nan, 0.0
        if w[k] > 0.0 and _finite(Phi[k], y[k]):
            kd, v, f, fi = _measure(a, P, Pi, Phi[k], y[k], r2 / w[k], diffuse, tol, M, Mi, acc)
            if kd == 2 and acc[4] >= n:
                diffuse = False
                Pi[:] = 0.0
        if store:
            Af[k] = a
            PF[k] = P
            V[k] = v
            F[k] = f
            FI[k] = fi
            kind[k] = kd
        for i in range(n):
            for j in range(n):
                P[i, j] += Q[i, j]
    return diffuse


@njit(**NJIT)
def kalman_loglike(Phi, y, w, a, P, Pi, Q, r2, diffuse, tol, acc):
    """The forward pass only, nothing stored: fills ``acc`` (see :func:`_measure`)."""
    e1 = np.empty((0, Phi.shape[1]))
    e2 = np.empty((0, Phi.shape[1], Phi.shape[1]))
    e0 = np.empty(0)
    k0 = np.empty(0, dtype=np.int8)
    acc[:] = 0.0
    return _filter(Phi, y, w, a, P, Pi, Q, r2, diffuse, tol, e1, e2, e2, e1, e2, e0, e0, e0,
                   k0, acc)


@njit(**NJIT)
def _diffuse_back(phi, v, f, fi, M, Mi, r0, r1, N0, N1, N2, L0, L1, K, T1, T2):
    """Backward step of a diffuse rank step (Durbin & Koopman 2012, §5.3;
    statsmodels' ``smoothed_estimators_measurement_univariate_diffuse``)."""
    n = phi.shape[0]
    f1 = 1.0 / fi
    f2 = -f / (fi * fi)
    for i in range(n):
        for j in range(n):
            L0[i, j] = (1.0 if i == j else 0.0) - Mi[i] * f1 * phi[j]
            L1[i, j] = -(M[i] * f1 + Mi[i] * f2) * phi[j]
    # r1 ← φ v F1 + L0ᵀ r1 + L1ᵀ r0 ;  r0 ← L0ᵀ r0
    for i in range(n):
        s = phi[i] * v * f1
        t = 0.0
        for m in range(n):
            s += L0[m, i] * r1[m] + L1[m, i] * r0[m]
            t += L0[m, i] * r0[m]
        K[i] = s
        T1[0, i] = t
    for i in range(n):
        r1[i] = K[i]
        r0[i] = T1[0, i]
    # N2 ← φφᵀF2 + L0ᵀN2L0 + L0ᵀN1L1 + L1ᵀN1ᵀL0 + L1ᵀN0L1
    for i in range(n):
        for j in range(n):
            T2[i, j] = phi[i] * phi[j] * f2
    _sandwich(L0, N2, L0, 1.0, T2, T1)
    _sandwich(L0, N1, L1, 1.0, T2, T1)
    _gemm(N1, True, L0, False, 1.0, 0.0, T1)
    _gemm(L1, True, T1, False, 1.0, 1.0, T2)
    _sandwich(L1, N0, L1, 1.0, T2, T1)
    N2[:] = T2
    # N1 ← φφᵀF1 + L0ᵀN1L0 + L1ᵀN0L0 ;  N0 ← L0ᵀN0L0
    for i in range(n):
        for j in range(n):
            T2[i, j] = phi[i] * phi[j] * f1
    _sandwich(L0, N1, L0, 1.0, T2, T1)
    _sandwich(L1, N0, L0, 1.0, T2, T1)
    N1[:] = T2
    T2[:] = 0.0
    _sandwich(L0, N0, L0, 1.0, T2, T1)
    N0[:] = T2


@njit(**NJIT)
def _ordinary_back(phi, v, f, M, r0, N0, N1, kd, L0, K, T1, T2):
    """Backward step of an ordinary sample (and of a diffuse one with F∞ = 0)."""
    n = phi.shape[0]
    for i in range(n):
        for j in range(n):
            L0[i, j] = (1.0 if i == j else 0.0) - M[i] / f * phi[j]
    for i in range(n):
        s = phi[i] * v / f
        for m in range(n):
            s += L0[m, i] * r0[m]
        K[i] = s
    r0[:] = K
    for i in range(n):
        for j in range(n):
            T2[i, j] = phi[i] * phi[j] / f
    _sandwich(L0, N0, L0, 1.0, T2, T1)
    N0[:] = T2
    if kd == 3:  # N1 ← N1 L0 (r1, N2 unchanged)
        _gemm(N1, False, L0, False, 1.0, 0.0, T2)
        N1[:] = T2


@njit(**NJIT)
def _smoothed(k, A, PP, PI, r0, r1, N0, N1, N2, As, Ps, T1, T2):
    """θ(k|N) = a + P r0 + P∞ r1,
    P(k|N) = P − P N0 P − P∞N1P − P N1ᵀP∞ − P∞N2P∞ (the P∞ terms while diffuse)."""
    n = r0.shape[0]
    P = PP[k]
    diffuse = False
    if PI.shape[0] > k:  # a diffuse start: the terms of P∞ until it vanishes
        for i in range(n):
            for j in range(n):
                if PI[k, i, j] != 0.0:
                    diffuse = True
    for i in range(n):
        s = A[k, i]
        for m in range(n):
            s += P[i, m] * r0[m]
            if diffuse:
                s += PI[k, i, m] * r1[m]
        As[k, i] = s
    Ps[k] = P
    _sandwich(P, N0, P, -1.0, Ps[k], T1)
    if diffuse:
        Pi = PI[k]
        _sandwich(Pi, N1, P, -1.0, Ps[k], T1)
        _gemm(N1, True, Pi, False, 1.0, 0.0, T1)
        _gemm(P, False, T1, False, -1.0, 1.0, Ps[k])
        _sandwich(Pi, N2, Pi, -1.0, Ps[k], T1)
    for i in range(n):
        for j in range(i + 1, n):
            s = 0.5 * (Ps[k, i, j] + Ps[k, j, i])
            Ps[k, i, j] = s
            Ps[k, j, i] = s


@njit(**NJIT)
def _backward(Phi, A, PP, PI, V, F, FI, kind, As, Ps):
    N, n = Phi.shape
    r0 = np.zeros(n)
    r1 = np.zeros(n)
    N0 = np.zeros((n, n))
    N1 = np.zeros((n, n))
    N2 = np.zeros((n, n))
    L0 = np.empty((n, n))
    L1 = np.empty((n, n))
    T1 = np.empty((n, n))
    T2 = np.empty((n, n))
    M = np.empty(n)
    Mi = np.empty(n)
    K = np.empty(n)
    for k in range(N - 1, -1, -1):
        kd = kind[k]
        if kd != 0:
            phi = Phi[k]
            for i in range(n):
                s = 0.0
                t = 0.0
                for j in range(n):
                    s += PP[k, i, j] * phi[j]
                    if kd == 2:
                        t += PI[k, i, j] * phi[j]
                M[i] = s
                Mi[i] = t
            if kd == 2:
                _diffuse_back(phi, V[k], F[k], FI[k], M, Mi, r0, r1, N0, N1, N2, L0, L1, K,
                              T1, T2)
            else:
                _ordinary_back(phi, V[k], F[k], M, r0, N0, N1, kd, L0, K, T1, T2)
        _smoothed(k, A, PP, PI, r0, r1, N0, N1, N2, As, Ps, T1, T2)


@njit(**NJIT)
def kalman_smooth(Phi, y, w, a, P, Pi, Q, r2, diffuse, tol, A, PP, PI, Af, PF, V, F, FI,
                  kind, acc, As, Ps):
    """Forward pass storing the predicted and filtered moments, then the backward
    pass into ``As`` (N, n), ``Ps`` (N, n, n). ``PI`` has N rows for a diffuse
    start (the predicted P∞ of every sample), 0 otherwise. Returns whether the
    filter was still diffuse after the last sample."""
    acc[:] = 0.0
    still = _filter(Phi, y, w, a, P, Pi, Q, r2, diffuse, tol, A, PP, PI, Af, PF, V, F, FI,
                    kind, acc)
    _backward(Phi, A, PP, PI, V, F, FI, kind, As, Ps)
    return still
