r"""Parameter covariance of a state-space model and its responses with standard deviations.

The parameters are the entries of the full parameterisation
θ = [A, B, C, D, K] (each matrix row by row; d = n² + nm + pn + pm + np).
It is over-parameterised: every similarity x → Tx gives the same predictor,
so the Jacobian of the prediction errors is singular along the n² directions
:math:`\delta A = EA - AE`, :math:`\delta B = EB`, :math:`\delta C = -CE`,
:math:`\delta K = EK`, :math:`\delta x_0 = Ex_0` (E any n × n matrix).
The covariance is the Moore–Penrose pseudo-inverse there (Ljung 1999, sec. 9.4
and its remark on over-parameterised models; McKelvey & Helmersson 1997 for
full parameterisations); the transfer function, the step response and the
poles are similarity invariant, so their first-order standard deviations do
not depend on the choice of generalised inverse.
"""

from __future__ import annotations

import numpy as np

from ..._lazy import lazy
from ..._kernels.layers._statespace import predictor_sensitivity
from ..frequency._response import polar_sd
from ..frequency._roots import Roots, roots_from_gradients
from . import _passes as passes

sla = lazy("scipy.linalg")

__all__ = ["n_params", "prediction_error_cov", "freqresp_sd", "step_sd", "poles_sd", "zeros_sd",
           "unpack"]

#: relative cut-off of the singular values of the whitened Jacobian (pseudo-inverse)
RCOND = 1e-10
#: bytes of Jacobian rows N_c × p × (d + n) formed at a time (``max_memory`` default)
MAX_MEMORY = 32 * 2**20


def n_params(n, m, p):
    """d = n² + nm + pn + pm + np, the length of θ = [A, B, C, D, K]."""
    return n * n + n * m + p * n + p * m + n * p


def _offsets(n, m, p):
    oB = n * n
    oC = oB + n * m
    oD = oC + p * n
    oK = oD + p * m
    return oB, oC, oD, oK


def pack(A, B, C, D, K):
    """θ = [A, B, C, D, K], each row by row."""
    return np.concatenate([M.reshape(-1) for M in (A, B, C, D, K)])


def unpack(theta, n, m, p):
    """(A, B, C, D, K) from θ."""
    oB, oC, oD, oK = _offsets(n, m, p)
    return (theta[:oB].reshape(n, n), theta[oB:oC].reshape(n, m), theta[oC:oD].reshape(p, n),
            theta[oD:oK].reshape(p, m), theta[oK:].reshape(n, p))


def _similarity(A, B, C, K, x0s):
    r"""(d + n·E, n²): the tangent directions of the similarity orbit at θ (and the x̂₀)."""
    n, m, p = A.shape[0], B.shape[1], C.shape[0]
    d = n_params(n, m, p)
    oB, oC, oD, oK = _offsets(n, m, p)
    V = np.zeros((d + n * len(x0s), n * n))
    for i in range(n):
        for j in range(n):
            E = np.zeros((n, n))
            E[i, j] = 1.0
            col = V[:, i * n + j]
            col[:oB] = (E @ A - A @ E).reshape(-1)
            col[oB:oC] = (E @ B).reshape(-1)
            col[oC:oD] = (-C @ E).reshape(-1)
            col[oK:d] = (E @ K).reshape(-1)
            for e, x0 in enumerate(x0s):
                col[d + e * n: d + (e + 1) * n] = E @ x0
    return V


def _sensitivities(model, Y, U, x0):
    """Prediction errors (N, p) and their Jacobian (N, p, d + n) from the compiled recursion,
    whole (for tests; :func:`prediction_error_cov` reduces it chunk by chunk)."""
    A, B, C, D, K = model.A, model.B, model.C, model.D, model.K
    n, m, p = A.shape[0], B.shape[1], C.shape[0]
    d = n_params(n, m, p)
    N = Y.shape[0]
    S = np.zeros((n, d + n))
    S[:, d:] = np.eye(n)
    E = np.empty((N, p))
    J = np.empty((N, p, d + n))
    c = np.ascontiguousarray
    predictor_sensitivity(c(A - K @ C), c(B - K @ D), c(K), c(C), c(D), c(Y), c(U),
                          np.array(x0, dtype=float), S, E, J)
    return E, J


def chunk_rows(max_memory, n, p, d):
    """Samples per chunk: the ψ of that many samples, rows × p × (d + n) float64, fit
    ``max_memory`` bytes (at least one sample)."""
    return max(1, int(max_memory) // (8 * p * (d + n)))


def prediction_error_cov(model, ex, *, x0="estimate", feedthrough=True, max_memory=MAX_MEMORY):
    r"""First-order covariance of θ = [A, B, C, D, K] from the one-step prediction errors.

    With :math:`\psi_k = \partial\varepsilon_k/\partial\theta` (p × d, the
    compiled sensitivity recursion of :mod:`adaptid._kernels.layers._statespace`),
    :math:`\hat\Lambda = \frac1N\sum\varepsilon_k\varepsilon_k^\mathsf T` and
    :math:`\tilde\psi_k = \hat\Lambda^{-1/2}\psi_k`:

    .. math::

        \operatorname{Cov}\hat\theta \approx
        \Bigl(\sum_k\tilde\psi_k^\mathsf T\tilde\psi_k\Bigr)^{+}
        \quad(= \hat\lambda\,(J^\mathsf TJ)^{+}\text{ for one output})

    (Ljung 1999, eq. 9.17 and sec. 9.4), the pseudo-inverse computed as
    :math:`Q(\tilde JQ)^{+}(\tilde JQ)^{+\mathsf T}Q^\mathsf T` with Q an
    orthonormal basis of the complement of the similarity directions (the
    known null space) and the SVD of the R factor of :math:`\tilde JQ`
    (singular values below ``RCOND``·σ₁ dropped), never a product JᵀJ.
    J is never held whole: the record is read in chunks of
    ``chunk_rows`` samples (in memory as on Dask, ``_passes``): a
    pass for Λ̂ and x̂₀, then one in which each chunk's rows of
    :math:`\tilde JQ` update R by a QR of :math:`[R; \tilde J_cQ]`.

    Parameters
    ----------
    model : StateSpaceModel
    ex : Experiments
    x0 : {"estimate", "zero"}
        The predictor's initial state per experiment: least squares (and its
        parameters then enter θ as nuisance parameters) or zero.
    feedthrough : bool
        Whether D is a free parameter (else its rows and columns are zero).
    max_memory : int
        Bytes of Jacobian rows formed at a time (default ``MAX_MEMORY``).

    Returns
    -------
    (ndarray (d, d), ndarray (p, p))
        The covariance of θ and :math:`\hat\Lambda`.
    """
    n, m, p = model.order, model.n_inputs, model.n_outputs
    d = n_params(n, m, p)
    oB, oC, oD, oK = _offsets(n, m, p)
    nE = len(ex.Y)
    est = x0 == "estimate"
    free = np.ones(d + n * nE, dtype=bool)
    if not feedthrough:
        free[oD:oK] = False
    if not est:
        free[d:] = False
    rows = chunk_rows(max_memory, n, p, d)              # in memory or on Dask alike
    x0s = [passes.predictor_x0(model, Y, U, rows) if est else np.zeros(n)
           for Y, U in zip(ex.Y, ex.U)]
    V = _similarity(model.A, model.B, model.C, model.K, x0s)[free]
    Uv, sv, _ = np.linalg.svd(V, full_matrices=True)
    r = int(np.sum(sv > 1e-12 * max(sv[0], 1.0))) if sv.size else 0
    Q = Uv[:, r:]                                     # complement of the similarity directions
    cov = np.zeros((d, d))
    Lam, R = passes.whitened_r(model, ex, x0s, free, Q, rows)
    if R is None:                                     # no prediction error: no uncertainty
        return cov, Lam
    _, s, Vt = sla.svd(R, full_matrices=False, check_finite=False)
    keep = s > RCOND * s[0] if s.size else s > 0
    half = Q @ (Vt[keep].T / s[keep])                 # cov = half halfᵀ
    full = half @ half.T
    idx = np.flatnonzero(free[:d])
    cov[np.ix_(idx, idx)] = full[: idx.size, : idx.size]
    # The system block of a pseudo-inverse over [θ, x̂₀] is not orthogonal to the
    # similarity directions of θ alone (they move x̂₀ too): project them out, so that
    # cov is the Moore–Penrose covariance of θ (rsample then draws no useless, and
    # through the curvature of the orbit harmful, motion along them). The bands are
    # unchanged: G, the step response and the poles have zero derivative there.
    Vs = _similarity(model.A, model.B, model.C, model.K, [])
    Us, ss, _ = np.linalg.svd(Vs, full_matrices=False)
    Us = Us[:, ss > 1e-12 * max(ss[0], 1.0)] if ss.size else Us
    P = np.eye(d) - Us @ Us.T
    cov = P @ cov @ P
    return (cov + cov.T) / 2, Lam


# ----------------------------------------------------------------- responses
def _reim_sd(G, Jc, cov):
    """(|G| sd, arg G sd) from complex Jacobians Jc (..., d) of G (...)."""
    c_rr = np.einsum("...a,ab,...b->...", Jc.real, cov, Jc.real)
    c_ri = np.einsum("...a,ab,...b->...", Jc.real, cov, Jc.imag)
    c_ii = np.einsum("...a,ab,...b->...", Jc.imag, cov, Jc.imag)
    return polar_sd(G, c_rr, c_ri, c_ii)


def freqresp_sd(model, w, cov):
    r"""G (nw, p, m) and, with ``cov``, the sd of |G| and arg G (same shape).

    :math:`R = (zI - A)^{-1}`, :math:`z = e^{i\omega dt}`, :math:`G = CRB + D`;
    :math:`\partial G_{rc}/\partial A_{ij} = (CR)_{ri}(RB)_{jc}`,
    :math:`\partial G_{rc}/\partial B_{ij} = (CR)_{ri}\delta_{jc}`,
    :math:`\partial G_{rc}/\partial C_{ij} = \delta_{ri}(RB)_{jc}`,
    :math:`\partial G_{rc}/\partial D_{ij} = \delta_{ri}\delta_{jc}`, none on K.
    """
    A, B, C, D = model.A, model.B, model.C, model.D
    n, m, p = A.shape[0], B.shape[1], C.shape[0]
    z = np.exp(1j * w * model.dt)
    M = z[:, None, None] * np.eye(n) - A
    Rb = np.linalg.solve(M, np.broadcast_to(B.astype(complex), (w.size, n, m)))
    G = C @ Rb + D
    if cov is None:
        return G, None, None
    L = np.swapaxes(np.linalg.solve(np.swapaxes(M, 1, 2),
                                    np.broadcast_to(C.T.astype(complex), (w.size, n, p))), 1, 2)
    oB, oC, oD, oK = _offsets(n, m, p)
    Jc = np.zeros((w.size, p, m, n_params(n, m, p)), dtype=complex)
    Jc[..., :oB] = np.einsum("wri,wjc->wrcij", L, Rb).reshape(w.size, p, m, n * n)
    eye_m, eye_p = np.eye(m), np.eye(p)
    Jc[..., oB:oC] = np.einsum("wri,jc->wrcij", L, eye_m).reshape(w.size, p, m, n * m)
    Jc[..., oC:oD] = np.einsum("ri,wjc->wrcij", eye_p, Rb).reshape(w.size, p, m, p * n)
    Jc[..., oD:oK] = np.einsum("ri,jc->rcij", eye_p, eye_m).reshape(p, m, p * m)
    msd, psd = _reim_sd(G, Jc, cov)
    return G, msd, psd


def step_sd(model, T, cov):
    r"""Step responses (T, p, m) and, with ``cov``, their sd (T, p, m).

    The step response of input c is the simulation :math:`x_{k+1} = Ax_k + Be_c`,
    :math:`s_k = Cx_k + De_c` from zero; its derivatives come from the same
    sensitivity recursion as the predictor's, with K = 0 and y = 0.
    """
    A, B, C, D = model.A, model.B, model.C, model.D
    n, m, p = A.shape[0], B.shape[1], C.shape[0]
    d = n_params(n, m, p)
    s = np.empty((T, p, m))
    sd = None if cov is None else np.empty((T, p, m))
    c = np.ascontiguousarray
    for j in range(m):
        U = np.zeros((T, m))
        U[:, j] = 1.0
        E = np.empty((T, p))
        J = np.empty((T, p, d))
        predictor_sensitivity(c(A), c(B), np.zeros((n, p)), c(C), c(D), np.zeros((T, p)), U,
                              np.zeros(n), np.zeros((n, d)), E, J)
        s[:, :, j] = 0.0 - E                   # ŷ = −ε (y = 0), without a −0
        if cov is not None:
            J[:, :, _offsets(n, m, p)[3]:] = 0.0   # the simulation does not depend on K
            # (the recursion's K columns are those of a predictor fed y = 0)
            var = np.einsum("tra,ab,trb->tr", J, cov, J)
            sd[:, :, j] = np.sqrt(np.maximum(var, 0.0))
    return s, sd


def poles_sd(model, cov):
    r"""Eigenvalues of A with their first-order standard deviations.

    :math:`\partial\lambda/\partial A_{ij} = \bar w_iv_j/(w^\mathsf Hv)`, v and w
    the right and left eigenvectors of the (simple) eigenvalue λ.
    """
    A = model.A
    n = A.shape[0]
    if cov is None:
        return Roots(np.linalg.eigvals(A))
    lam, vl, vr = sla.eig(A, left=True, right=True)
    G = np.zeros((n, cov.shape[0]), dtype=complex)
    with np.errstate(divide="ignore", invalid="ignore"):
        for k in range(n):
            den = np.vdot(vl[:, k], vr[:, k])
            G[k, : n * n] = np.outer(vl[:, k].conj(), vr[:, k]).reshape(-1) / den
    return roots_from_gradients(lam, G, cov)


def _channel_zeros(A, B, C, D, cov_idx, cov):
    r"""Invariant zeros of (A, B, C, D) (square) with sd (generalised eigenvalue perturbation).

    The zeros are the finite eigenvalues of the pencil
    :math:`F - zE`, :math:`F = [[A, B], [-C, -D]]`, :math:`E = \operatorname{diag}(I, 0)`;
    for a simple one with right and left eigenvectors v, w:
    :math:`\partial z = w^\mathsf H(\partial F)v / (w^\mathsf HEv)`.
    """
    n, m = B.shape
    F = np.block([[A, B], [-C, -D]])
    Em = np.zeros_like(F)
    Em[:n, :n] = np.eye(n)
    ab, vl, vr = sla.eig(F, Em, left=True, right=True, homogeneous_eigvals=True)
    alpha, beta = ab
    fin = np.abs(beta) > 1e-9 * np.maximum(np.abs(alpha), 1.0)
    z = alpha[fin] / beta[fin]
    if cov is None:
        return Roots(z)
    G = np.zeros((z.size, cov.shape[0]), dtype=complex)
    with np.errstate(divide="ignore", invalid="ignore"):
        for k, col in enumerate(np.flatnonzero(fin)):
            w_, v_ = vl[:, col], vr[:, col]
            dF = np.outer(w_.conj(), v_) / np.vdot(w_, Em @ v_)
            G[k, cov_idx] = np.concatenate([dF[:n, :n].reshape(-1), dF[:n, n:].reshape(-1),
                                            -dF[n:, :n].reshape(-1), -dF[n:, n:].reshape(-1)])
    return roots_from_gradients(z, G, cov)


def zeros_sd(model, cov):
    """Invariant zeros of a square system, else a list per output of per-input Roots."""
    A, B, C, D = model.A, model.B, model.C, model.D
    n, m, p = A.shape[0], B.shape[1], C.shape[0]
    oB, oC, oD, oK = _offsets(n, m, p)
    ar = np.arange(n_params(n, m, p))
    iA, iB, iC, iD = ar[:oB], ar[oB:oC].reshape(n, m), ar[oC:oD].reshape(p, n), \
        ar[oD:oK].reshape(p, m)
    if p == m:
        idx = np.concatenate([iA, iB.reshape(-1), iC.reshape(-1), iD.reshape(-1)])
        return _channel_zeros(A, B, C, D, idx, cov)
    out = []
    for r in range(p):
        row = []
        for c in range(m):
            idx = np.concatenate([iA, iB[:, c], iC[r], iD[r, c:c + 1]])
            row.append(_channel_zeros(A, B[:, c:c + 1], C[r:r + 1], D[r:r + 1, c:c + 1],
                                      idx, cov))
        out.append(row)
    return out
