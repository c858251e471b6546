r"""Passes over a record chunk by chunk, the state carried from one chunk to the next.

On Dask records (:func:`~adaptid.models.n4sid` of data larger than memory)
the steps after the LQ factor read the record ``rows`` samples at a time:
the one-step predictor's errors (AIC of an order range), the least-squares
initial states, the fit percentages of the summary and the sensitivities of
the parameter covariance. Each is the in-memory computation with its
recursion carried over the chunks and its sums and QR reductions taken chunk
by chunk: equal to rounding. The parameter covariance
(``StateSpaceModel.estimate_cov``) takes these passes on in-memory records
too, in chunks set by its ``max_memory``, so that its Jacobian is never
held whole.
"""

from __future__ import annotations

import numpy as np

from ..._kernels.layers._statespace import predictor_sensitivity
from ..._lazy import lazy
from ._signals import recurse

sla = lazy("scipy.linalg")

__all__ = ["ROWS", "one_step_errors", "predictor_x0", "simulation_x0", "fit_percent_chunked",
           "whitened_r"]

#: Samples read at a time (as ``CHUNK_ROWS`` of the in-memory n4sid).
ROWS = 65536


def _chunks(Y, U, rows):
    """(offset, Y rows, U rows) as float64 ndarrays (Dask slices computed together)."""
    for a in range(0, Y.shape[0], rows):
        y, u = Y[a:a + rows], U[a:a + rows]
        if hasattr(y, "dask"):
            import dask

            y, u = dask.compute(y, u)
        yield a, np.asarray(y, dtype=np.float64), np.asarray(u, dtype=np.float64)


def _predictor(model, Yc, Uc, x):
    r"""One-step errors of a chunk and the state after it: :math:`\hat x_{t+1|t} =
    \bar A\hat x_{t|t-1} + (B - KD)u_t + Ky_t`, :math:`\bar A = A - KC`."""
    A, B, C, D, K = model.A, model.B, model.C, model.D, model.K
    Abar = A - K @ C
    inj = Uc @ (B - K @ D).T + Yc @ K.T
    X = recurse(Abar, inj, x)
    return Yc - X @ C.T - Uc @ D.T, Abar @ X[-1] + inj[-1]


def _simulation(model, Yc, Uc, x):
    """Output errors of the simulation of a chunk and the state after it."""
    inj = Uc @ model.B.T
    X = recurse(model.A, inj, x)
    return Yc - X @ model.C.T - Uc @ model.D.T, model.A @ X[-1] + inj[-1]


def one_step_errors(model, ex, skip=0, rows=ROWS, x0s=None):
    r"""(Σ εₖεₖᵀ, count) of the one-step prediction errors of every experiment.

    The predictor of :meth:`StateSpaceModel.predict` (k = 1) from the initial
    states ``x0s`` (default zero), the first ``skip`` samples of each
    experiment left out of the sums.
    """
    p, n = model.n_outputs, model.order
    G, N = np.zeros((p, p)), 0
    for e, (Y, U) in enumerate(zip(ex.Y, ex.U)):
        x = np.zeros(n) if x0s is None else np.array(x0s[e], dtype=np.float64)
        for a, Yc, Uc in _chunks(Y, U, rows):
            E, x = _predictor(model, Yc, Uc, x)
            E = E[max(skip - a, 0):]
            G += E.T @ E
            N += E.shape[0]
    return G, N


def _x0_lstsq(model, M, run, Y, U, rows):
    r""":math:`\arg\min_{x_0}\sum_k\lVert r_k - CM^kx_0\rVert^2`, r the errors of ``run``
    from a zero state, from the R factor of [Φ r] reduced chunk by chunk."""
    n = model.order
    R = np.zeros((0, n + 1))
    x, P = np.zeros(n), np.eye(n)
    for _, Yc, Uc in _chunks(Y, U, rows):
        r, x = run(model, Yc, Uc, x)
        Pk = recurse(M, np.zeros((Yc.shape[0], n, n)), P)
        P = M @ Pk[-1]
        block = np.hstack([(model.C @ Pk).reshape(-1, n), r.reshape(-1, 1)])
        R = sla.qr(np.vstack([R, block]), mode="r", check_finite=False)[0][:n + 1]
    R = np.vstack([R, np.zeros((n + 1 - R.shape[0], n + 1))])
    return sla.lstsq(R[:n, :n], R[:n, n], check_finite=False)[0]


def predictor_x0(model, Y, U, rows=ROWS):
    """Least-squares initial state of the one-step predictor (``_uncertainty._predictor_x0``)."""
    return _x0_lstsq(model, model.A - model.K @ model.C, _predictor, Y, U, rows)


def simulation_x0(model, Y, U, rows=ROWS):
    """Least-squares initial state of the simulation (:meth:`StateSpaceModel.estimate_x0`)."""
    return _x0_lstsq(model, model.A, _simulation, Y, U, rows)


def fit_percent_chunked(model, Y, U, rows=ROWS):
    r"""(fit % of the simulation from the least-squares x₀, fit % of the one-step
    prediction from zero, range of y > 0) per output, MATLAB's
    :math:`100(1 - \lVert y - \hat y\rVert/\lVert y - \bar y\rVert)`.

    ‖y − ȳ‖² is merged over the chunks from their means and sums of squared
    deviations (Chan, Golub & LeVeque 1983), not from Σy².
    """
    p, n = model.n_outputs, model.order
    xs, xp = simulation_x0(model, Y, U, rows), np.zeros(n)
    cnt, mean, m2 = 0, np.zeros(p), np.zeros(p)
    sse_s, sse_p = np.zeros(p), np.zeros(p)
    lo, hi = np.full(p, np.inf), np.full(p, -np.inf)
    for _, Yc, Uc in _chunks(Y, U, rows):
        Es, xs = _simulation(model, Yc, Uc, xs)
        Ep, xp = _predictor(model, Yc, Uc, xp)
        sse_s += np.einsum("ij,ij->j", Es, Es)
        sse_p += np.einsum("ij,ij->j", Ep, Ep)
        k, mk = Yc.shape[0], Yc.mean(axis=0)
        dev = Yc - mk
        m2 += np.einsum("ij,ij->j", dev, dev) + (mk - mean) ** 2 * cnt * k / (cnt + k)
        mean += (mk - mean) * k / (cnt + k)
        cnt += k
        lo, hi = np.minimum(lo, Yc.min(axis=0)), np.maximum(hi, Yc.max(axis=0))
    with np.errstate(divide="ignore", invalid="ignore"):
        fit_s = 100.0 * (1.0 - np.sqrt(sse_s) / np.sqrt(m2))
        fit_p = 100.0 * (1.0 - np.sqrt(sse_p) / np.sqrt(m2))
    return fit_s, fit_p, hi - lo > 0


def _reduce(R, W):
    r"""R factor of :math:`[R; W]`, k × k (R k × k upper triangular, W Fortran-ordered
    with its first k rows free for R): one Householder QR (LAPACK ``dgeqrf``) in
    place, so that a chunk costs no copy of its rows."""
    k = R.shape[0]
    W[:k] = R
    qr, _, _, info = sla.lapack.dgeqrf(W, lwork=max(64 * k, 1), overwrite_a=True)
    if info != 0:                                       # pragma: no cover - LAPACK argument error
        raise RuntimeError(f"dgeqrf failed (info={info})")
    return np.triu(qr[:k])


def whitened_r(model, ex, x0s, free, Q, rows=ROWS):
    r"""(Λ̂, R) for the covariance of θ: R the triangular factor of :math:`\tilde J Q`.

    Two passes of ``rows`` samples at a time, on an in-memory record as on a
    Dask one: the prediction errors from ``x0s`` give
    :math:`\hat\Lambda = \frac1N\sum\varepsilon_k\varepsilon_k^\mathsf T`; then the
    compiled sensitivity recursion (its state x̂, S carried in place from one
    chunk to the next) gives the rows :math:`\psi_k` of a chunk, restricted to
    the ``free`` parameters, times Q and whitened by :math:`\hat\Lambda^{-1/2}`,
    and R is updated by a QR of :math:`[R; \tilde\psi Q]` (k × k, k the
    columns of Q). The whole Jacobian (N p rows) is never held: the memory is
    a few chunks of rows whatever N. R is None when Λ̂ is singular (no
    prediction error: no uncertainty).
    """
    A, B, C, D, K = model.A, model.B, model.C, model.D, model.K
    n, p = model.order, model.n_outputs
    G, N = one_step_errors(model, ex, 0, rows, x0s)
    Lam = G / N
    w, V = np.linalg.eigh((Lam + Lam.T) / 2)
    if w[-1] <= 0 or w[0] <= 1e-14 * w[-1]:
        return Lam, None
    T = (V / np.sqrt(w)).T
    d = free.size - n * len(ex.Y)
    k = Q.shape[1]
    Qf = np.zeros((free.size, k))
    Qf[free] = Q                                        # fixed parameters: zero rows
    c = np.ascontiguousarray
    Abar, Bbar = c(A - K @ C), c(B - K @ D)
    R = np.zeros((k, k))
    for e, (Y, U) in enumerate(zip(ex.Y, ex.U)):
        # ψ (θ and this experiment's x̂₀ columns) times the matching rows of Q
        Qe = c(np.vstack([Qf[:d], Qf[d + e * n: d + (e + 1) * n]]))
        x = np.array(x0s[e], dtype=np.float64)
        S = np.zeros((n, d + n))
        S[:, d:] = np.eye(n)
        for _, Yc, Uc in _chunks(Y, U, rows):
            r = Yc.shape[0]
            E = np.empty((r, p))
            Jb = np.empty((r, p, d + n))
            predictor_sensitivity(Abar, Bbar, c(K), c(C), c(D), c(Yc), c(Uc), x, S, E, Jb)
            JQ = (Jb.reshape(r * p, d + n) @ Qe).reshape(r, p, k)
            del Jb
            W = np.empty((k + r * p, k), order="F")
            np.matmul(T, JQ, out=W[k:].reshape(r, p, k))
            del JQ
            R = _reduce(R, W)
    return Lam, R
