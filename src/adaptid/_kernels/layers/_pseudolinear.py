r"""Compiled recursive pseudo-linear regression (RELS for ARMAX, PLR for OE and BJ).

The regressor of sample k holds fixed columns (lagged measured signals,
precomputed) followed by ``nd`` lags of signals that the recursion itself
produces from the estimates (ARMAX: the a-posteriori residuals; OE: the
a-posteriori simulated output; BJ: both and the noise v = y − w), so the
loop cannot be split into "build Φ" then "run an estimator": it is one
compiled pass. No validation here.

Exact diffuse start (an estimator with ``P0="diffuse"``): while the data do
not determine θ the recursion runs the prologues of :mod:`._diffuse` (RLS:
the square-root information filter; window: least squares over the buffered
regressors, no prior) or :mod:`._diffuse_kalman` (the exact initial Kalman
filter) on the regressors it forms, with θ the minimum-norm solution; from
the first sample with full rank on, the ordinary U-D recursion continues
from the factors of the exact information (a window removal that would lose
definiteness re-solves the window without a prior). ``dif`` holds the
diffuse state (empty: a finite prior): RLS ``[flag, R (n·n), z (n)]``,
Kalman ``[flag, rank steps, P∞ (n·n), P* (n·n)]``, window ``[flag]``, as
the core estimators' tails (:mod:`._diffuse`).
"""

from __future__ import annotations

import numpy as np

from ..._config import NJIT, NJIT_INLINE, njit
from ..recursions._bierman import _bierman_apply, _bierman_prep, _time_update, _udu_factor
from ..recursions._diffuse import _add_row, _srif_solve, _ud_from_srif, _unidentified_factor
from ..recursions._diffuse_kalman import _diffuse_measure
from ..recursions._strategy import _strategy_step

__all__ = ["pseudolinear_run"]


@njit(**NJIT)
def _window_resolve(theta, U, D, theta_s, U_s, D_s, L, Bphi, By, k, M, lam, f, v, b, n):
    """Re-solve the window of samples k−M+1 … k exactly from the buffer.

    The prior is the starting state, decayed as in the recursion
    (P_s / λ^(k+1), floored at exp(−600) of its weight as the core
    estimator does); sample j enters with weight λ^(k−j)."""
    scale = np.exp(min(-L, 600.0))
    for i in range(n):
        theta[i] = theta_s[i]
        D[i] = D_s[i] * scale
        for j in range(n):
            U[i, j] = U_s[i, j]
    for t in range(M):
        j = k - M + 1 + t
        if j < 0:
            continue
        s = j % M
        c = lam ** (k - j)
        e = By[s]
        for i in range(n):
            e -= Bphi[s, i] * theta[i]
        _bierman_prep(U, D, Bphi[s], f, v, n)
        a = _bierman_apply(U, D, 1.0 / c, f, v, b, n)
        g = e / a
        for i in range(n):
            theta[i] += b[i] * g


@njit(**NJIT_INLINE)
def _window_step(theta, U, D, theta_s, U_s, D_s, phi, yk, Bphi, By, k, M, lam, cM, logl, rtol,
                 f, v, b, n, dif, dtol):
    """Remove sample k − M (weight c = λ^M) and buffer sample k; re-solve the
    window from the buffer instead when the removal would lose definiteness.
    With a diffuse start (``dif`` not empty) the re-solve has no prior
    (:func:`_window_srif`) and may leave θ not identified. Returns True for
    a re-solve."""
    slot = k % M
    resolve = False
    if k >= M:
        q = _bierman_prep(U, D, Bphi[slot], f, v, n)
        if 1.0 - cM * q < rtol:
            resolve = True
        else:
            eo = By[slot]
            for i in range(n):
                eo -= Bphi[slot, i] * theta[i]
            a = _bierman_apply(U, D, -1.0 / cM, f, v, b, n)
            g = eo / a
            for i in range(n):
                theta[i] += b[i] * g
    for j in range(n):
        Bphi[slot, j] = phi[j]
    By[slot] = yk
    if resolve and dif.shape[0] > 0:
        dif[0] = _window_srif(theta.reshape((n, 1)), U, D, Bphi, By, k, M, lam, dtol, n)
    elif resolve:
        _window_resolve(theta, U, D, theta_s, U_s, D_s, (k + 1) * logl, Bphi, By,
                        k, M, lam, f, v, b, n)
    return resolve


# ------------------------------------------------------------ diffuse start
@njit(**NJIT)
def _window_srif(theta2, U, D, Bphi, By, k, M, lam, rcond, n):
    """Least squares over the window k−M+1 … k alone (weights λ^(k−j), no prior), by
    the SRIF blocks of :mod:`._diffuse`; the U-D factor when it has full rank.
    Returns the identified flag (1.0 or 0.0)."""
    R = np.zeros((n, n))
    z = np.zeros((n, 1))
    r = np.empty(n)
    ry = np.empty(1)
    yj = np.empty(1)
    for t in range(M):
        j = k - M + 1 + t
        if j < 0:
            continue
        yj[0] = By[j % M]
        _add_row(R, z, Bphi[j % M], yj, lam ** (k - j), r, ry, n, 1)
    if _srif_solve(R, z, theta2, rcond, n, 1):
        _ud_from_srif(R, U, D, n)
        return 1.0
    _unidentified_factor(U, D, n)
    return 0.0


@njit(**NJIT)
def _srif_push(dif, theta2, U, D, phi, yk, lam, r2, rcond, n):
    """Diffuse RLS step (:mod:`._diffuse`): [R | z] scaled by √λ, the row
    [φ, y]/√r₂ rotated in, θ solved; at full rank the U-D factor of (RᵀR)⁻¹."""
    R = dif[1:1 + n * n].reshape((n, n))
    z = dif[1 + n * n:1 + n * n + n].reshape((n, 1))
    r = np.empty(n)
    ry = np.empty(1)
    sl = np.sqrt(lam)
    if sl != 1.0:
        for i in range(n):
            for j in range(n):
                R[i, j] *= sl
            z[i, 0] *= sl
    _add_row(R, z, phi, yk, 1.0 / r2, r, ry, n, 1)
    if _srif_solve(R, z, theta2, rcond, n, 1):
        _ud_from_srif(R, U, D, n)
        dif[0] = 1.0


@njit(**NJIT)
def _kalman_push(dif, theta2, U, D, phi, ek, r2, Q, tol, W, n):
    """Diffuse Kalman step (:mod:`._diffuse_kalman`): the exact initial measurement
    update, P* += R₁, and after n rank steps the U-D factor of P*. False if
    that factorisation fails."""
    Pinf = dif[2:2 + n * n].reshape((n, n))
    Pst = dif[2 + n * n:2 + 2 * n * n].reshape((n, n))
    Mi = np.empty(n)
    Ms = np.empty(n)
    dif[1] += _diffuse_measure(theta2, Pinf, Pst, phi, ek, r2, tol, Mi, Ms, n, 1)
    for i in range(n):
        for j in range(n):
            Pst[i, j] += Q[i, j]
    if dif[1] >= n:
        dif[0] = 1.0
        for i in range(n):
            for j in range(n):
                W[i, j] = Pst[i, j]
        return _udu_factor(W, U, D, n)
    return True


@njit(**NJIT)
def _diffuse_step(dif, theta2, U, D, phi, yk, ek, k, lam, r2, Q, kalman, M, Bphi, By, dtol,
                  W, n):
    """One sample of the diffuse phase (the window buffers it); False if the
    Kalman factorisation failed."""
    if kalman:
        return _kalman_push(dif, theta2, U, D, phi, ek, r2, Q, dtol, W, n)
    if M > 0:
        for j in range(n):
            Bphi[k % M, j] = phi[j]
        By[k % M] = yk[0]
        dif[0] = _window_srif(theta2, U, D, Bphi, By, k, M, lam, dtol, n)
    else:
        _srif_push(dif, theta2, U, D, phi, yk, lam, r2, dtol, n)
    return True


@njit(**NJIT_INLINE)
def _measure(theta, theta2, U, D, phi, yk, ek, e, lam, il, r2, mode, fp, pmax, f, v, b, Pm, W,
             n):
    """The ordinary measurement update (strategy or constant λ); returns λₖ."""
    if mode >= 0:
        return _strategy_step(theta2, U, D, phi, yk, ek, 1.0, lam, mode, fp, pmax,
                              f, v, b, Pm, W, n, 1)
    if lam != 1.0:
        for i in range(n):
            D[i] *= il
    _bierman_prep(U, D, phi, f, v, n)
    a = _bierman_apply(U, D, r2, f, v, b, n)
    g = e / a
    for i in range(n):
        theta[i] += b[i] * g
    return lam


@njit(**NJIT_INLINE)
def _signals_step(alpha, mix, phi, theta, yk, Vk, vh, n, L):
    """The signals v_g after the update of sample k, and their lag history."""
    for g in range(Vk.shape[0]):
        vk = alpha[g] * yk
        for j in range(n):
            vk += mix[g, j] * phi[j] * theta[j]
        Vk[g] = vk
        for lag in range(L - 1, 0, -1):
            vh[g, lag] = vh[g, lag - 1]
        vh[g, 0] = vk


@njit(**NJIT)
def pseudolinear_run(Phi_fix, Y, alpha, mix, dyn_group, dyn_lag, dyn_sgn, theta,
                     U, D, lam, Q, kalman, r2, M, rtol, mode, fp, pmax, Th, E, V, Lk, dif,
                     dtol, Ik, rb):
    r"""Recursive pseudo-linear regression on the U-D factors of P.

    The regressor of sample k is the fixed columns ``Phi_fix[k]`` followed
    by ``nd`` dynamic ones: column j is ``dyn_sgn[j] * v_g[k - l]`` with
    ``g = dyn_group[j]``, ``l = dyn_lag[j]``, where the G signals

    .. math::

        v_{g,k} = \alpha_g y_k + \sum_i \text{mix}_{g,i}\,\varphi_{k,i}\theta_i

    are formed after the update of sample k (ARMAX: one signal, α = 1,
    mix = −1, the a-posteriori residual; OE: one signal per input, α = 0,
    mix = 1 on that input's columns, its simulated output; BJ: the
    simulated output w, the noise v = y − w and the residual ε). Per sample:

    .. math::

        \varepsilon_k = y_k - \varphi_k^T\theta,\quad
        K = \frac{P\varphi_k}{\lambda r_2 + \varphi_k^T P\varphi_k},\quad
        \theta \leftarrow \theta + K\varepsilon_k,\quad
        P \leftarrow (P - K\varphi_k^T P)/\lambda + Q,

    done as the core estimators do it (:mod:`adaptid._kernels.recursions._bierman`):
    ``D ← D/λ``, a Bierman update with weight r₂, and for the Kalman
    recursion (``kalman``) the time update ``P + Q`` re-factorised. With a
    window M > 0 the regressor actually used is stored in a buffer and the
    sample k − M is then removed with weight :math:`c = \lambda^M` (Bierman
    with weight −1/c), unless :math:`1 - c\,\varphi^T P\varphi <` ``rtol``
    (the removal would make P indefinite or nearly so): then, as in
    :class:`adaptid.SlidingWindowRLS`, the window is re-solved exactly from
    the buffer (samples k − M + 1 … k with weights λ^(k−j)) and the starting
    θ, P taken as the prior, decayed by λ^(k+1). With ``mode >= 0`` the
    measurement update is instead the step of an :mod:`adaptid.forgetting`
    strategy (or of ``P_max``), exactly as in :class:`adaptid.RLS`
    (``_strategy_step``), and ``Lk[k]`` receives the λₖ it applied. Finally
    the signals :math:`v_{g,k}` are formed. ``theta``, ``U`` (unit upper
    triangular) and ``D`` are updated in place; ``Th[k]``, ``E[k]``,
    ``V[k, g]`` receive θ after sample k, ε_k and :math:`v_{g,k}`. With a
    diffuse start (``dif`` not empty, see the module docstring; ``dtol`` its
    rank tolerance) the samples before full rank go through the diffuse
    prologue and ``Ik[k]`` receives the identified flag (1.0 without one).

    Several experiments (or the runs between NaN gaps): ``rb`` (P + 1,) holds
    the first row of each of the P pieces and N (``[0, N]``: one piece). At
    the first row of each piece the signals' lag history restarts from zero
    (the dynamic columns of its first rows are 0, as the prediction-error
    filters of ``fit`` restart), while θ, the U-D factors, the window
    buffer, the diffuse state and the row count k run on across pieces.

    Returns the number of window re-solves, or −1 if the time update lost
    positive definiteness.
    """
    N, nfix = Phi_fix.shape
    nd = dyn_group.shape[0]
    n = nfix + nd
    L = 1
    for j in range(nd):
        L = max(L, dyn_lag[j])
    phi = np.empty(n)
    f = np.empty(n)
    v = np.empty(n)
    b = np.empty(n)
    W = np.empty((n, n))
    Pm = np.empty((n, n))
    theta2 = theta.reshape((n, 1))
    ek = np.empty(1)
    yk = np.empty(1)
    vh = np.zeros((V.shape[1], L))  # vh[g, l - 1] = v_g[k - l]
    Mb = max(M, 1)
    Bphi = np.zeros((Mb, n))
    By = np.zeros(Mb)
    theta_s = theta.copy()
    U_s = U.copy()
    D_s = D.copy()
    cM = lam ** M
    il = 1.0 / lam
    logl = np.log(lam)
    rebuilds = 0
    diffuse = dif.shape[0] > 0
    piece = 1
    for k in range(N):
        restart = False
        while piece < rb.shape[0] and rb[piece] <= k:   # k starts the next piece
            piece += 1
            restart = True
        if restart:
            vh[:, :] = 0.0
        for j in range(nfix):
            phi[j] = Phi_fix[k, j]
        for j in range(nd):
            phi[nfix + j] = dyn_sgn[j] * vh[dyn_group[j], dyn_lag[j] - 1]
        e = Y[k]
        for j in range(n):
            e -= phi[j] * theta[j]
        E[k] = e
        ek[0] = e
        yk[0] = Y[k]
        if diffuse and dif[0] == 0.0:
            if not _diffuse_step(dif, theta2, U, D, phi, yk, ek, k, lam, r2, Q, kalman, M,
                                 Bphi, By, dtol, W, n):
                return -1
            Lk[k] = lam
        else:
            Lk[k] = _measure(theta, theta2, U, D, phi, yk, ek, e, lam, il, r2, mode, fp, pmax,
                             f, v, b, Pm, W, n)
            if kalman and not _time_update(U, D, Q, W, n):
                return -1
            if M > 0 and _window_step(theta, U, D, theta_s, U_s, D_s, phi, Y[k], Bphi, By, k,
                                      M, lam, cM, logl, rtol, f, v, b, n, dif, dtol):
                rebuilds += 1
        Ik[k] = dif[0] if diffuse else 1.0
        for j in range(n):
            Th[k, j] = theta[j]
        _signals_step(alpha, mix, phi, theta, Y[k], V[k], vh, n, L)
    return rebuilds
