r"""Exact diffuse start (``P0="diffuse"``) of RLS, the sliding window and the Kalman filter.

A diffuse prior is the limit P₀ = κI, κ → ∞. Instead of a large finite κ
(which leaves a ridge term 1/κ in the estimate) the start is done exactly,
in a prologue before the ordinary U-D stream; the stream itself is not
changed (it runs from the sample at which the data determine θ on).

RLS and the sliding window: square-root information filter (SRIF, Bierman
1977, ch. V.3 and VI). An upper triangular ``R`` and ``z`` with
``RᵀR = Σ λ-weighted wₖφₖφₖᵀ`` and ``Rᵀz = Σ λ-weighted wₖφₖyₖ`` are kept:
each step scales them by √λₖ and rotates the row √wₖ[φₖᵀ, yₖ] in with Givens
rotations (no normal equations are formed). While R is numerically singular
(σ_min(R) ≤ ``rcond``·σ_max(R)) θ is the minimum-norm least-squares solution
(from the SVD of R) and the state is flagged *not identified*; at the first
sample with full rank θ = R⁻¹z (back substitution) and the U-D factors of
P = (RᵀR)⁻¹ = WWᵀ, W = R⁻¹ upper triangular, are read off W directly:
U = W diag(W)⁻¹, D = diag(W)² (no inverse of ΦᵀΦ). The sliding window
re-solves the window contents this way (no prior) during its diffuse phase
and whenever a removal would make it rank-deficient again.

Kalman filter for a random walk: the exact diffuse initialisation of
Koopman & Durbin, univariate treatment (Durbin & Koopman 2012, §5.2 and
§6.4): P = κP∞ + P*, P∞ = I, P* = 0 at the start; per sample with
F∞ = φᵀP∞φ, F* = φᵀP*φ + R₂/w, M∞ = P∞φ, M* = P*φ:

.. math::

    F_\infty > 0:&\quad \theta \mathrel{+}= \frac{M_\infty}{F_\infty}v,\;
      P_* \mathrel{+}= \frac{F_*}{F_\infty^2}M_\infty M_\infty^T
        - \frac{M_* M_\infty^T + M_\infty M_*^T}{F_\infty},\;
      P_\infty \mathrel{-}= \frac{M_\infty M_\infty^T}{F_\infty};\\
    F_\infty = 0:&\quad \theta \mathrel{+}= \frac{M_*}{F_*}v,\;
      P_* \mathrel{-}= \frac{M_* M_*^T}{F_*},

then P* += R₁. Each F∞ > 0 step lowers the rank of P∞ by one; after n of
them P∞ = 0 and the ordinary U-D filter continues from P*.

State tails (after the estimator's ordinary state): RLS ``[flag, R (n·n), z
(n·p)]``; window ``[flag, stop]``; Kalman ``[flag, rank steps, P∞ (n·n), P*
(n·n)]``; ``flag`` is 1.0 once identified. ``Lk`` receives the flag per
sample (``Trajectory.identified``). Entry points as in :mod:`._rls`, with
``opt`` extended by the rank tolerance.

Windowed statistics (``St`` an array, :mod:`._rollstats`): the RLS prologue
adds to the minimised cost J the square of what the rotations leave of each
row (exact, no prior term, from full rank on); the window's rows of the
diffuse phase and after each re-solve are computed directly from the buffer,
the window's prior slot (unused by a diffuse window) read as D₀ = ∞ meanwhile
(no prior term). Rows before identification are NaN-masked by the caller.

References: G. J. Bierman, *Factorization Methods for Discrete Sequential
Estimation*, 1977, ch. V–VI (SRIF); J. Durbin, S. J. Koopman, *Time Series
Analysis by State Space Methods*, 2nd ed., 2012, §5.2 (exact initial Kalman
filter), §6.4 (univariate treatment).
"""

import numpy as np

from ..._config import NJIT, NJIT_INLINE, njit
from ..toolchain._dims import dim, size_tag
from ._bierman import _finite_row, _prior_errors, _store, _views
from ._entries import Entries
from ._parallel import batched, segments
from ._rls import _rls_core
from ._rollstats import rows_from, srif_hook, window_direct_hook, window_end_hook
from ._window import _window_core, _window_views


# --------------------------------------------------------------- SRIF blocks
@njit(**NJIT_INLINE)
def _givens_row(R, z, r, ry, NP, p):
    """Rotate the row [r, ry] into the upper triangular [R | z] (r, ry are overwritten)."""
    for i in range(NP):
        b = r[i]
        if b != 0.0:
            h = np.hypot(R[i, i], b)
            c = R[i, i] / h
            s = b / h
            R[i, i] = h
            for j in range(i + 1, NP):
                t = R[i, j]
                R[i, j] = c * t + s * r[j]
                r[j] = c * r[j] - s * t
            for j in range(p):
                t = z[i, j]
                z[i, j] = c * t + s * ry[j]
                ry[j] = c * ry[j] - s * t


@njit(**NJIT_INLINE)
def _add_row(R, z, phi, y, wk, r, ry, NP, p):
    sw = np.sqrt(wk)
    for i in range(NP):
        r[i] = sw * phi[i]
    for j in range(p):
        ry[j] = sw * y[j]
    _givens_row(R, z, r, ry, NP, p)


@njit(**NJIT)
def _srif_solve(R, z, theta, rcond, NP, p):
    """θ from R θ = z: back substitution when σ_min(R) > rcond·σ_max(R), else the
    minimum-norm solution (singular values ≤ rcond·σ_max dropped). Returns True
    in the first case (θ identified)."""
    A = np.empty((NP, NP))
    for i in range(NP):
        for j in range(NP):
            A[i, j] = R[i, j]
    u, s, vt = np.linalg.svd(A)
    full = s[0] > 0.0 and s[NP - 1] > rcond * s[0]
    for j in range(p):
        if full:
            for i in range(NP - 1, -1, -1):
                t = z[i, j]
                for k in range(i + 1, NP):
                    t -= R[i, k] * theta[k, j]
                theta[i, j] = t / R[i, i]
        else:
            for i in range(NP):
                theta[i, j] = 0.0
            for m in range(NP):
                if s[m] > rcond * s[0] and s[m] > 0.0:
                    c = 0.0
                    for i in range(NP):
                        c += u[i, m] * z[i, j]
                    c /= s[m]
                    for i in range(NP):
                        theta[i, j] += c * vt[m, i]
    return full


@njit(**NJIT)
def _ud_from_srif(R, U, D, NP):
    """U-D factors of P = R⁻¹R⁻ᵀ: W = R⁻¹ (upper triangular), U = W diag(W)⁻¹, D = diag(W)²."""
    W = np.zeros((NP, NP))
    for j in range(NP):
        W[j, j] = 1.0 / R[j, j]
        for i in range(j - 1, -1, -1):
            t = 0.0
            for k in range(i + 1, j + 1):
                t -= R[i, k] * W[k, j]
            W[i, j] = t / R[i, i]
    for j in range(NP):
        D[j] = W[j, j] * W[j, j]
        U[j, j] = 1.0
        for i in range(j):
            U[i, j] = W[i, j] / W[j, j]
        for i in range(j + 1, NP):
            U[i, j] = 0.0


@njit(**NJIT_INLINE)
def _unidentified_factor(U, D, NP):
    """The placeholder factor of the diffuse phase (U = I, D = 1; P is reported as inf)."""
    for j in range(NP):
        D[j] = 1.0
        for i in range(NP):
            U[i, j] = 1.0 if i == j else 0.0


@njit(**NJIT_INLINE)
def _rest(Th, k, N):
    """Rows k: of the trajectory, or an empty slice when θ is not stored."""
    return Th[k:] if Th.shape[0] == N else Th[0:0]


# ---------------------------------------------------------------------- RLS
@njit(**NJIT)
def _rls_prologue(S, Phi, Y, lam, w, Th, E, skipped, Lk, St, rcond, NP, p):
    """The samples of the diffuse phase; returns the index of the first one after it."""
    o = NP * p + NP * NP + NP
    R = S[o + 1:o + 1 + NP * NP].reshape((NP, NP))
    z = S[o + 1 + NP * NP:o + 1 + NP * NP + NP * p].reshape((NP, p))
    theta, U, D = _views(S, NP, p)
    r = np.empty(NP)
    ry = np.empty(p)
    N = Phi.shape[0]
    store = Th.shape[0] == N
    k = 0
    while k < N and S[o] == 0.0:
        ok = _finite_row(Phi[k], Y[k], NP, p)
        if ok:
            _prior_errors(theta, Phi[k], Y[k], E[k], NP, p)
            for j in range(p):
                ry[j] = 0.0
            sl = np.sqrt(lam[k])
            if sl != 1.0:
                for i in range(NP):
                    for j in range(NP):
                        R[i, j] *= sl
                    for j in range(p):
                        z[i, j] *= sl
            if w[k] > 0.0:
                _add_row(R, z, Phi[k], Y[k], w[k], r, ry, NP, p)
            if _srif_solve(R, z, theta, rcond, NP, p):
                _ud_from_srif(R, U, D, NP)
                S[o] = 1.0
        else:
            skipped[k] = True
            for j in range(p):
                E[k, j] = np.nan
        srif_hook(St, k, ok, Y, lam, w[k], ry, U, D, NP, p)  # nothing when St is None
        Lk[k] = S[o]
        if store:
            _store(Th, k, theta, NP, p)
        k += 1
    return k


@njit(**NJIT_INLINE)
def _rls_diffuse_stream(S, Phi, Y, lam, w, Th, E, skipped, Lk, St, dthr, rcond, NP, p):
    N = Phi.shape[0]
    k = _rls_prologue(S, Phi, Y, lam, w, Th, E, skipped, Lk, St, rcond, NP, p)
    for i in range(k, N):
        Lk[i] = 1.0
    if k == N:
        return -1
    bad = _rls_core(S, Phi[k:], Y[k:], lam[k:], w[k:], _rest(Th, k, N), E[k:], skipped[k:],
                    rows_from(St, k), dthr, size_tag(NP), size_tag(p))
    return bad + k if bad >= 0 else -1


@njit(**NJIT)
def rls_diffuse_run(S, Phi, Y, lam, w, Th, E, skipped, Lk, St, opt, mat, ntag, ptag):
    """N steps of diffuse RLS; ``opt = [windup threshold, rcond]``; code as :func:`._rls.rls_run`."""
    return _rls_diffuse_stream(S, Phi, Y, lam, w, Th, E, skipped, Lk, St, opt[0], opt[1],
                               dim(ntag), dim(ptag))


rls_diffuse_run_batched = batched(rls_diffuse_run, "rls_diffuse_run_batched", stats=True)
rls_diffuse_run_segments = segments(rls_diffuse_run, "rls_diffuse_run_segments")


# ------------------------------------------------------------------- window
@njit(**NJIT)
def _window_push(S, phi, y, lk, wk, M, NP, p):
    """The buffer bookkeeping of one sample of the diffuse phase (no U-D factor)."""
    theta, U, D, meta, Bphi, By, Bw, BL, theta0, U0, D0 = _window_views(S, NP, p, M)
    L = meta[0] + np.log(lk)
    meta[0] = L
    pos = int(meta[1])
    for i in range(NP):
        Bphi[pos, i] = phi[i]
    for j in range(p):
        By[pos, j] = y[j]
    Bw[pos] = wk
    BL[pos] = L
    meta[1] = pos + 1 if pos + 1 < M else 0
    if meta[2] < M:
        meta[2] += 1


@njit(**NJIT)
def _window_resolve(S, M, rcond, NP, p):
    """Least squares over the window contents alone (no prior), by SRIF. Sets θ, and the
    U-D factor when the window has full rank; returns whether it has."""
    theta, U, D, meta, Bphi, By, Bw, BL, theta0, U0, D0 = _window_views(S, NP, p, M)
    R = np.zeros((NP, NP))
    z = np.zeros((NP, p))
    r = np.empty(NP)
    ry = np.empty(p)
    L = meta[0]
    count = int(meta[2])
    start = int(meta[1]) - count
    for t in range(count):
        s = (start + t) % M
        c = Bw[s] * np.exp(L - BL[s])
        if c > 0.0:
            _add_row(R, z, Bphi[s], By[s], c, r, ry, NP, p)
    if _srif_solve(R, z, theta, rcond, NP, p):
        _ud_from_srif(R, U, D, NP)
        return True
    _unidentified_factor(U, D, NP)
    return False


@njit(**NJIT_INLINE)
def _window_direct(St, r, S, M, NP, p):
    """Statistics row r of the window directly from its buffer (no prior: D₀ = ∞ meanwhile)."""
    theta, U, D, meta, Bphi, By, Bw, BL, theta0, U0, D0 = _window_views(S, NP, p, M)
    window_direct_hook(St, r, theta, Bphi, By, Bw, BL, meta, theta0, U0, D0, np.empty(NP), U,
                       D, M, NP, p)


@njit(**NJIT_INLINE)
def _window_diffuse_stream(S, Phi, Y, lam, w, Th, E, skipped, Lk, St, M, rtol, rcond, NP, p):
    N = Phi.shape[0]
    flag = S.shape[0] - 2
    store = Th.shape[0] == N
    theta, U, D, meta, Bphi, By, Bw, BL, theta0, U0, D0 = _window_views(S, NP, p, M)
    d0 = D0.copy()
    D0[:] = np.inf  # the prior slot, unused by a diffuse window: no prior term in J
    _window_direct(St, 0, S, M, NP, p)
    rebuilds = 0
    k = 0
    while k < N:
        if S[flag] == 0.0:
            if _finite_row(Phi[k], Y[k], NP, p):
                _prior_errors(theta, Phi[k], Y[k], E[k], NP, p)
                _window_push(S, Phi[k], Y[k], lam[k], w[k], M, NP, p)
                S[flag] = 1.0 if _window_resolve(S, M, rcond, NP, p) else 0.0
                _window_direct(St, k + 1, S, M, NP, p)
            else:
                skipped[k] = True
                for j in range(p):
                    E[k, j] = np.nan
                window_end_hook(St, k, False, U, D, NP)
            j = k
        else:
            S[flag + 1] = -1.0  # set by the stream if a removal needs a re-solve
            rebuilds += _window_core(S, Phi[k:], Y[k:], lam[k:], w[k:], _rest(Th, k, N), E[k:],
                                     skipped[k:], rows_from(St, k), M, rtol, size_tag(NP),
                                     size_tag(p), True)
            j = N - 1 if S[flag + 1] < 0.0 else k + int(S[flag + 1]) - 1
            for i in range(k, j):
                Lk[i] = 1.0
            if S[flag + 1] >= 0.0:
                S[flag] = 1.0 if _window_resolve(S, M, rcond, NP, p) else 0.0
                _window_direct(St, j + 1, S, M, NP, p)
        Lk[j] = S[flag]
        if store:
            _store(Th, j, theta, NP, p)
        k = j + 1
    for i in range(NP):  # (a loop: an array assignment compiles numba's shape-error message)
        D0[i] = d0[i]
    return rebuilds


@njit(**NJIT)
def window_diffuse_run(S, Phi, Y, lam, w, Th, E, skipped, Lk, St, opt, mat, ntag, ptag):
    """N steps of the diffuse window; ``opt = [windup, M, rtol, rcond]``; returns re-solves."""
    return _window_diffuse_stream(S, Phi, Y, lam, w, Th, E, skipped, Lk, St, int(opt[1]),
                                  opt[2], opt[3], dim(ntag), dim(ptag))


window_diffuse_run_batched = batched(window_diffuse_run, "window_diffuse_run_batched", stats=True)
window_diffuse_run_segments = segments(window_diffuse_run, "window_diffuse_run_segments")


#: this module's entry points, by the name adaptid._kernels gives them
ENTRIES = {"RLS_DIFFUSE": Entries(rls_diffuse_run, rls_diffuse_run_batched,
                                  rls_diffuse_run_segments),
           "WINDOW_DIFFUSE": Entries(window_diffuse_run, window_diffuse_run_batched,
                                     window_diffuse_run_segments)}
