r"""Exact diffuse start of the random-walk Kalman filter (``KalmanRLS(P0="diffuse")``).

The univariate exact initial Kalman filter of Koopman & Durbin (Durbin &
Koopman 2012, §5.2, §6.4; equations in :mod:`._diffuse`): P = κP∞ + P*,
κ → ∞, with P∞ = I and P* = 0 before the first sample. A step whose
F∞ = φᵀP∞φ exceeds ``opt[3]``·φᵀφ (φ has a component the earlier samples
did not determine) uses the F∞ > 0 update and lowers the rank of P∞ by one;
after n such steps P∞ = 0, θ is identified and the ordinary U-D filter
(:mod:`._kalman`) continues from P*, factorised. The time update adds R₁ to
P* and leaves P∞ (identity transition). State tail after θ, U, D:
``[flag, rank steps, P∞ (n·n), P* (n·n)]``. Entry points as in :mod:`._kalman`
with ``opt = [windup threshold, R₂, skip, tol]``.
"""

import numpy as np

from ..._config import NJIT, NJIT_INLINE, njit
from ..toolchain._dims import dim, size_tag
from ._bierman import _finite_row, _prior_errors, _store, _udu_factor, _views
from ._diffuse import _rest
from ._entries import Entries
from ._kalman import _kalman_core
from ._parallel import batched, segments


@njit(**NJIT)
def _diffuse_measure(theta, Pinf, Pst, phi, e, r2w, tol, Mi, Ms, NP, p):
    """One univariate exact-diffuse measurement update; returns 1 if F∞ > 0 (rank step)."""
    fi = 0.0
    fs = r2w
    pp = 0.0
    for i in range(NP):
        a = 0.0
        b = 0.0
        for j in range(NP):
            a += Pinf[i, j] * phi[j]
            b += Pst[i, j] * phi[j]
        Mi[i] = a
        Ms[i] = b
    for i in range(NP):
        fi += phi[i] * Mi[i]
        fs += phi[i] * Ms[i]
        pp += phi[i] * phi[i]
    if fi > tol * pp:
        for i in range(NP):
            for j in range(p):
                theta[i, j] += Mi[i] / fi * e[j]
        c = fs / (fi * fi)
        for i in range(NP):
            for j in range(i, NP):
                s = Pst[i, j] + c * Mi[i] * Mi[j] - (Ms[i] * Mi[j] + Mi[i] * Ms[j]) / fi
                Pst[i, j] = s
                Pst[j, i] = s
                s = Pinf[i, j] - Mi[i] * Mi[j] / fi
                Pinf[i, j] = s
                Pinf[j, i] = s
        return 1
    if fs > 0.0:
        for i in range(NP):
            for j in range(p):
                theta[i, j] += Ms[i] / fs * e[j]
        for i in range(NP):
            for j in range(i, NP):
                s = Pst[i, j] - Ms[i] * Ms[j] / fs
                Pst[i, j] = s
                Pst[j, i] = s
    return 0


@njit(**NJIT)
def _kalman_prologue(S, Phi, Y, w, Th, E, skipped, Lk, opt, Q, NP, p):
    """The samples of the diffuse phase; returns (index after it, first bad sample or −1)."""
    o = NP * p + NP * NP + NP
    Pinf = S[o + 2:o + 2 + NP * NP].reshape((NP, NP))
    Pst = S[o + 2 + NP * NP:o + 2 + 2 * NP * NP].reshape((NP, NP))
    theta, U, D = _views(S, NP, p)
    Mi = np.empty(NP)
    Ms = np.empty(NP)
    N = Phi.shape[0]
    store = Th.shape[0] == N
    bad = -1
    k = 0
    while k < N and S[o] == 0.0:
        tu = True
        if _finite_row(Phi[k], Y[k], NP, p):
            _prior_errors(theta, Phi[k], Y[k], E[k], NP, p)
            if w[k] > 0.0:
                S[o + 1] += _diffuse_measure(theta, Pinf, Pst, Phi[k], E[k], opt[1] / w[k],
                                             opt[3], Mi, Ms, NP, p)
        else:
            skipped[k] = True
            for j in range(p):
                E[k, j] = np.nan
            tu = opt[2] != 0.0
        if tu:
            for i in range(NP):
                for j in range(NP):
                    Pst[i, j] += Q[i, j]
        if S[o + 1] >= NP:
            S[o] = 1.0
            W = Pst.copy()
            if not _udu_factor(W, U, D, NP) and bad < 0:
                bad = k
        Lk[k] = S[o]
        if store:
            _store(Th, k, theta, NP, p)
        k += 1
    return k, bad


@njit(**NJIT_INLINE)
def _kalman_diffuse_stream(S, Phi, Y, w, Th, E, skipped, Lk, opt, Q, NP, p):
    N = Phi.shape[0]
    k, bad = _kalman_prologue(S, Phi, Y, w, Th, E, skipped, Lk, opt, Q, NP, p)
    for i in range(k, N):
        Lk[i] = 1.0
    if k == N:
        return bad
    b2 = _kalman_core(S, Phi[k:], Y[k:], w[k:], _rest(Th, k, N), E[k:], skipped[k:], opt, Q,
                      size_tag(NP), size_tag(p))
    if bad < 0 and b2 >= 0:
        bad = b2 + k
    return bad


@njit(**NJIT)
def kalman_diffuse_run(S, Phi, Y, lam, w, Th, E, skipped, Lk, St, opt, mat, ntag, ptag):
    """N steps of the diffuse Kalman filter; code as :func:`._kalman.kalman_run`."""
    return _kalman_diffuse_stream(S, Phi, Y, w, Th, E, skipped, Lk, opt, mat, dim(ntag),
                                  dim(ptag))


kalman_diffuse_run_batched = batched(kalman_diffuse_run, "kalman_diffuse_run_batched")
kalman_diffuse_run_segments = segments(kalman_diffuse_run, "kalman_diffuse_run_segments")


#: this module's entry points, by the name adaptid._kernels gives them
ENTRIES = {"KALMAN_DIFFUSE": Entries(kalman_diffuse_run, kalman_diffuse_run_batched, kalman_diffuse_run_segments)}
