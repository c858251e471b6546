r"""Realisation from Markov parameters: ERA (Ho–Kalman) and OKID."""

from __future__ import annotations

import numpy as np

from ..._lazy import lazy
from ..._validation import as_float_array, check_int, check_scalar, param_error
from ._model import StateSpaceModel
from ._signals import experiments

sla = lazy("scipy.linalg")  # imported on first use, as scipy.signal elsewhere

__all__ = ["era", "okid"]


def _realise(markov, order, rows=None):
    """(A, B, C, Ob, singular values) of the ERA on markov (K, p, m)."""
    Kn, p, m = markov.shape
    r = (Kn - 1) // 2 if rows is None else rows
    s = Kn - 1 - r
    if order is not None and (r * p < order or s * m < order):
        raise param_error("markov", f"enough parameters for order {order} "
                          f"(block Hankel of {r}×{s} blocks has rank ≤ {min(r * p, s * m)})",
                          f"<{Kn} Markov parameters>")
    H0 = np.empty((r * p, s * m))
    H1 = np.empty((r * p, s * m))
    for a in range(r):
        for b in range(s):
            H0[a * p:(a + 1) * p, b * m:(b + 1) * m] = markov[1 + a + b]
            H1[a * p:(a + 1) * p, b * m:(b + 1) * m] = markov[2 + a + b]  # ≤ r + s = K − 1
    U, sv, Vt = sla.svd(H0, full_matrices=False, check_finite=False)
    if order is None:
        from ._subspace import _gap_order

        order = _gap_order(sv, min(sv.size - 1, r * p - 1))
    if order > sv.size or sv[order - 1] <= 0:
        raise param_error("order", f"at most the rank of the Hankel matrix ({int((sv > 0).sum())})",
                          order)
    sq = np.sqrt(sv[:order])
    Ob = U[:, :order] * sq                 # [C; CA; …]
    Co = (Vt[:order].T * sq).T             # [B, AB, …]
    A = (U[:, :order].T @ H1 @ Vt[:order].T) / np.outer(sq, sq)
    return A, Co[:, :m].copy(), Ob[:p].copy(), Ob, sv


def era(markov, order=None, *, dt=1.0):
    r"""State-space realisation of Markov parameters: the Eigensystem Realization Algorithm.

    With the block Hankel matrices of the Markov parameters
    :math:`Y_k = CA^{k-1}B` (k ≥ 1),

    .. math::

        H(0) = [Y_{1+a+b}]_{a<r,\,b<s},\qquad H(1) = [Y_{2+a+b}]_{a<r,\,b<s},

    and the truncated SVD :math:`H(0) \approx U_nS_nV_n^\mathsf T`:
    :math:`A = S_n^{-1/2}U_n^\mathsf TH(1)V_nS_n^{-1/2}`, B the first m
    columns of :math:`S_n^{1/2}V_n^\mathsf T`, C the first p rows of
    :math:`U_nS_n^{1/2}`, D = :math:`Y_0` (Ho & Kalman 1966; Juang & Pappa
    1985). r = ⌊(K − 1)/2⌋ block rows and the rest as block columns.

    Parameters
    ----------
    markov : array_like, shape (K, p, m)
        ``markov[0]`` = D, ``markov[k]`` = :math:`CA^{k-1}B`
        (e.g. :meth:`StateSpaceModel.markov`).
    order : int, optional
        n; None: the largest drop of the log singular values of H(0).
    dt : float
        Sample time of the model (default 1.0).

    Returns
    -------
    StateSpaceModel
        K = 0; ``singular_values`` of H(0).

    References
    ----------
    J.-N. Juang, R. S. Pappa (1985). An eigensystem realization algorithm for
    modal parameter identification and model reduction. *J. Guidance, Control,
    and Dynamics* 8(5), 620–627. :doi:`10.2514/3.20031`.

    Examples
    --------
    >>> import numpy as np
    >>> from adaptid.models import StateSpaceModel, era
    >>> true = StateSpaceModel([[0.8, 0.3], [-0.3, 0.8]], [[1.0], [0.0]], [[1.0, 0.5]])
    >>> model = era(true.markov(20), 2)
    >>> bool(np.allclose(model.markov(20), true.markov(20)))
    True
    """
    H = as_float_array(markov, "markov", ndim=(1, 3))
    H = H.reshape(-1, 1, 1) if H.ndim == 1 else H
    if H.shape[0] < 3:
        raise param_error("markov", "at least 3 Markov parameters (D, CB, CAB)",
                          f"<{H.shape[0]}>")
    if order is not None:
        order = check_int(order, "order", low=1)
    dt = check_scalar(dt, "dt", low=0.0, low_open=True)
    A, B, C, _, sv = _realise(H, order)
    return StateSpaceModel(A, B, C, H[0], dt=dt, singular_values=sv,
                           info={"method": "era", "markov parameters": H.shape[0]})


def _observer_markov(ex, q, feedthrough):
    r"""Least squares for the observer Markov parameters.

    :math:`y_k = Du_k + \sum_{j=1}^{q}(M^u_ju_{k-j} + M^y_jy_{k-j}) + \varepsilon_k`.
    """
    p, m = ex.p, ex.m
    rows, targets = [], []
    for Y, U in zip(ex.Y, ex.U):
        N = Y.shape[0]
        parts = [U[q:]] if feedthrough else []
        for j in range(1, q + 1):
            parts += [U[q - j:N - j], Y[q - j:N - j]]
        rows.append(np.hstack(parts))
        targets.append(Y[q:])
    Phi, T = np.vstack(rows), np.vstack(targets)
    if Phi.shape[0] <= Phi.shape[1]:
        raise param_error("data", f"more than {Phi.shape[1]} samples after the first n_markov",
                          f"<{Phi.shape[0]}>")
    Theta, *_ = sla.lstsq(Phi, T, check_finite=False)     # (cols, p)
    E = T - Phi @ Theta
    off = m if feedthrough else 0
    D = Theta[:off].T if feedthrough else np.zeros((p, m))
    Mu = np.stack([Theta[off + (j - 1) * (m + p): off + (j - 1) * (m + p) + m].T
                   for j in range(1, q + 1)])
    My = np.stack([Theta[off + (j - 1) * (m + p) + m: off + j * (m + p)].T
                   for j in range(1, q + 1)])
    return D, Mu, My, E


def _system_markov(D, Mu, My, count):
    r"""System and observer-gain Markov parameters from the observer's (Juang et al. 1993, eqs. 13–16).

    :math:`Y_0 = D`, :math:`Y_k = M^u_k + M^y_kD + \sum_{i=1}^{k-1}M^y_iY_{k-i}` and
    :math:`Y^o_k = M^y_k + \sum_{i=1}^{k-1}M^y_iY^o_{k-i}` (= :math:`CA^{k-1}K`),
    with :math:`M_k = 0` for k > q.
    """
    q, p, m = Mu.shape
    Ys = np.zeros((count, p, m))
    Yo = np.zeros((count, p, p))
    Ys[0] = D
    for k in range(1, count):
        if k <= q:
            Ys[k] = Mu[k - 1] + My[k - 1] @ D
            Yo[k] = My[k - 1]
        for i in range(1, min(k, q + 1)):
            Ys[k] += My[i - 1] @ Ys[k - i]
            Yo[k] += My[i - 1] @ Yo[k - i]
    return Ys, Yo


def okid(data, order, n_markov, *, feedthrough=False):
    r"""Observer/Kalman filter identification: observer Markov parameters, then ERA.

    1. Least squares for the Markov parameters of an observer (with noise:
       of the Kalman predictor) with q = ``n_markov`` lags,
       :math:`y_k = Du_k + \sum_{j=1}^{q}(M^u_ju_{k-j} + M^y_jy_{k-j}) + \varepsilon_k`,
       where :math:`M^u_j = C\bar A^{j-1}(B - KD)`, :math:`M^y_j = C\bar A^{j-1}K`,
       :math:`\bar A = A - KC`;
    2. the system Markov parameters :math:`Y_k = CA^{k-1}B` and the
       observer-gain ones :math:`Y^o_k = CA^{k-1}K` by the recursions of
       Juang, Phan, Horta & Longman (1993);
    3. A, B, C from :func:`era` on :math:`Y_0 \dots Y_{2r}`; K by least
       squares from :math:`[C; CA; \dots]K = [Y^o_1; Y^o_2; \dots]` in the
       ERA's basis; ``noise_cov`` the covariance of the residuals ε.

    The observer is exact (deadbeat) when q·p ≥ n on noise-free data; with
    noise q must be large enough for :math:`\bar A^q` to be negligible.

    Parameters
    ----------
    data : IDData, (y, u) tuple, or a list of them (experiments)
    order : int
        n.
    n_markov : int
        q, the number of observer Markov parameters (lags), ≥ 1.
    feedthrough : bool
        Estimate D (default False).

    Returns
    -------
    StateSpaceModel

    References
    ----------
    J.-N. Juang, M. Phan, L. G. Horta, R. W. Longman (1993). Identification
    of observer/Kalman filter Markov parameters: theory and experiments.
    *J. Guidance, Control, and Dynamics* 16(2), 320–329. :doi:`10.2514/3.21006`.
    """
    ex = experiments(data)
    order = check_int(order, "order", low=1)
    q = check_int(n_markov, "n_markov", low=1)
    p, m = ex.p, ex.m
    r = max(q, -(-order // p) + 1, -(-order // m) + 1)
    D, Mu, My, E = _observer_markov(ex, q, feedthrough)
    Ys, Yo = _system_markov(D, Mu, My, 2 * r + 2)
    A, B, C, Ob, sv = _realise(Ys, order, rows=r)
    K = sla.lstsq(Ob, Yo[1:r + 1].reshape(r * p, p), check_finite=False)[0]
    model = StateSpaceModel(A, B, C, D, K, noise_cov=E.T @ E / E.shape[0], dt=ex.dt,
                            y_names=ex.y_names, u_names=ex.u_names, singular_values=sv,
                            info={"method": "okid", "n_markov": q, "feedthrough": bool(feedthrough),
                                  "samples": sum(ex.lengths), "experiments": len(ex.Y)})
    model._fit_data = ex
    return model
