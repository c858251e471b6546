r"""Subspace identification: N4SID, MOESP and CVA (Van Overschee & De Moor 1996)."""

from __future__ import annotations

import numpy as np

from ..._lazy import lazy
from ..._validation import check_choice, check_int, param_error
from ._model import StateSpaceModel
from ._dask import dask_experiments, is_dask, lq_factor_dask
from ._passes import one_step_errors
from ._signals import experiments, recurse

sla = lazy("scipy.linalg")  # imported on first use, as scipy.signal elsewhere

__all__ = ["n4sid"]

#: Relative cut-off of the pseudo-inverses of the L blocks (rank decisions: the
#: past data of a noise-free record span only m·i + n directions).
RCOND = 1e-10
#: Rows of the block-Hankel data matrix handed to one QR (the R factor is carried over).
CHUNK_ROWS = 65536


# ----------------------------------------------------------------- data matrix
def _hankel_chunk(Y, U, i, q0, rows, out):
    """Rows q0 … q0+rows−1 of the transposed data matrix [U_f | U_p | Y_p | Y_f] into ``out``."""
    m, p = U.shape[1], Y.shape[1]
    mi, li = m * i, p * i
    for r in range(i):
        out[:, r * m:(r + 1) * m] = U[q0 + i + r: q0 + i + r + rows]            # U_f
        out[:, mi + r * m: mi + (r + 1) * m] = U[q0 + r: q0 + r + rows]          # U_p
        out[:, 2 * mi + r * p: 2 * mi + (r + 1) * p] = Y[q0 + r: q0 + r + rows]  # Y_p
        out[:, 2 * mi + li + r * p: 2 * mi + li + (r + 1) * p] = Y[q0 + i + r: q0 + i + r + rows]


def _lq_factor(ex, i):
    r"""L of the LQ factorisation of the block-Hankel data matrix, from one (chunked) QR.

    The transposed data matrix Hᵀ (one row per Hankel column, experiments
    stacked, never across a boundary) is factorised in chunks of rows: the
    R of the rows so far is put on top of the next chunk, so that the result
    is the R of one QR of all of Hᵀ and at most one chunk of Hᵀ is in
    memory. ``mode="raw"`` keeps SciPy from copying the (rows × c) factor
    into a new triangular array. L = Rᵀ/√j.
    """
    m, p = ex.m, ex.p
    c = 2 * i * (m + p)
    R = None
    j_total = 0
    for Y, U in zip(ex.Y, ex.U):
        j = Y.shape[0] - 2 * i + 1
        for q0 in range(0, j, CHUNK_ROWS):
            rows = min(CHUNK_ROWS, j - q0)
            top = 0 if R is None else c
            block = np.empty((top + rows, c), order="F")
            if R is not None:
                block[:c] = R
            _hankel_chunk(Y, U, i, q0, rows, block[top:])
            (_, _), R = sla.qr(block, mode="raw", overwrite_a=True, check_finite=False)
            if R.shape[0] < c:  # fewer rows than columns so far
                R = np.vstack([R, np.zeros((c - R.shape[0], c))])
        j_total += j
    return R.T / np.sqrt(j_total), j_total


# ----------------------------------------------------------------- projections
def _blocks(L, m, p, i):
    mi, pw = m * i, (m + p) * i
    return {"L21": L[mi:mi + pw, :mi], "L22": L[mi:mi + pw, mi:mi + pw],
            "L32": L[mi + pw:, mi:mi + pw], "L33": L[mi + pw:, mi + pw:],
            "L3": L[mi + pw:, mi:]}


def _pinv_solve(M, rhs_t):
    """X with X·M ≈ rhs (minimum norm, singular values below RCOND·σ₁ cut)."""
    return sla.lstsq(M.T, rhs_t.T, cond=RCOND, check_finite=False)[0].T


def _weighted(Lb, method):
    r"""(W₁ O_i W₂ as a small matrix, W₁⁻¹, Z = L₃₂L₂₂^†) for one of the weightings.

    With the LQ blocks of [U_f; W_p; Y_f] (W_p = [U_p; Y_p]) the oblique
    projection is :math:`O_i = Y_f/_{U_f}W_p = L_{32}L_{22}^\dagger W_p`
    (Van Overschee & De Moor 1996, ch. 6). Multiplied by the orthogonal
    Q factors, whose rows are orthonormal (they do not change left singular
    vectors or singular values):

    * N4SID  (W₁ = I, W₂ = I): :math:`Z\,[L_{21}\;L_{22}]`;
    * MOESP  (W₁ = I, W₂ = Π⊥_{U_f}): :math:`Z L_{22}`;
    * CVA    (W₁ = (Y_fΠ⊥Y_fᵀ)^{-1/2}, W₂ = Π⊥_{U_f}): :math:`W_1 Z L_{22}`,
      with :math:`Y_fΠ⊥Y_f^\mathsf T = L_3L_3^\mathsf T`, :math:`L_3 = [L_{32}\;L_{33}]`.
    """
    Z = _pinv_solve(Lb["L22"], Lb["L32"])
    if method == "n4sid":
        return Z @ np.hstack([Lb["L21"], Lb["L22"]]), None, Z
    Ob = Z @ Lb["L22"]
    if method == "moesp":
        return Ob, None, Z
    Ug, sg, _ = sla.svd(Lb["L3"], full_matrices=False, check_finite=False)
    keep = sg > RCOND * sg[0]
    Ug, sg = Ug[:, keep], sg[keep]
    W1 = (Ug / sg) @ Ug.T        # pseudo-inverse square root (noise-free records are singular)
    W1inv = (Ug * sg) @ Ug.T
    return W1 @ Ob, W1inv, Z


# ------------------------------------------------------------------ the system
def _rows(X, a, b):
    """Rows a … b−1 of a signal as an ndarray (a dask array computes only those rows)."""
    return np.asarray(X[a:b], dtype=np.float64)


def _bd_x0(ex, A, C, feedthrough):
    r"""B, D and one initial state per experiment from one least-squares problem.

    Given A and C the outputs are linear in them:
    :math:`y_k = CA^kx_0 + \sum_{\tau<k}(u_\tau^\mathsf T\otimes CA^{k-1-\tau})\operatorname{vec}B
    + (u_k^\mathsf T\otimes I)\operatorname{vec}D`
    (the simulation formulation of SLICOT IB01BD / IB01CD; Verhaegen & Verdult 2007, ch. 9).
    The rows are formed ``CHUNK_ROWS`` samples at a time (the recursion's
    state carried from one chunk to the next) and reduced to the R factor
    of the augmented matrix [Φ y] by QR, so that the (N·p) × d matrix Φ
    never is in memory at once; θ solves R θ = z (the same least-squares
    solution, Q being orthonormal).
    """
    n, m, p = A.shape[0], ex.m, ex.p
    E = len(ex.Y)
    nd = p * m if feedthrough else 0
    d = n * m + nd + n * E
    R = np.zeros((0, d + 1))
    for e, (Y, U) in enumerate(zip(ex.Y, ex.U)):
        s0 = np.zeros((n, n * m + n))
        s0[:, n * m:] = np.eye(n)
        for a in range(0, Y.shape[0], CHUNK_ROWS):
            Uc, Yc = _rows(U, a, a + CHUNK_ROWS), _rows(Y, a, a + CHUNK_ROWS)
            N = Yc.shape[0]
            inj = np.zeros((N, n, n * m + n))
            for j in range(m):
                inj[:, np.arange(n), j * n + np.arange(n)] = Uc[:, j:j + 1]
            Sx = recurse(A, inj, s0)
            s0 = A @ Sx[-1] + inj[-1]                      # the state after this chunk
            S = C @ Sx                                     # (N, p, nm + n)
            Phi = np.zeros((N, p, d + 1))
            Phi[:, :, :n * m] = S[:, :, :n * m]
            for r in range(p if feedthrough else 0):
                Phi[:, r, n * m + r * m: n * m + (r + 1) * m] = Uc
            Phi[:, :, n * m + nd + e * n: n * m + nd + (e + 1) * n] = S[:, :, n * m:]
            Phi[:, :, d] = Yc
            R = sla.qr(np.vstack([R, Phi.reshape(N * p, d + 1)]), mode="r",
                       check_finite=False)[0][:d + 1]
    R = np.vstack([R, np.zeros((d + 1 - R.shape[0], d + 1))]) if R.shape[0] < d + 1 else R
    theta = sla.lstsq(R[:d, :d], R[:d, d], check_finite=False)[0]
    B = theta[:n * m].reshape(m, n).T
    D = theta[n * m:n * m + nd].reshape(p, m) if feedthrough else np.zeros((p, m))
    x0 = theta[n * m + nd:].reshape(E, n)
    return B, D, x0


def _states(Y, U, i, M, q0, q1):
    r"""States :math:`\hat x_{i+q} = M\,w_q` (w_q the past window) for q = q0 … q1 − 1."""
    m, p = U.shape[1], Y.shape[1]
    Yw, Uw = _rows(Y, q0, q1 + i - 1), _rows(U, q0, q1 + i - 1)
    j = q1 - q0
    X = np.zeros((j, M.shape[0]))
    for r in range(i):
        X += Uw[r:r + j] @ M[:, r * m:(r + 1) * m].T
        X += Yw[r:r + j] @ M[:, m * i + r * p: m * i + (r + 1) * p].T
    return X


def _kalman_gain(ex, i, M, A, B, C, D):
    r"""K and Σ_e from the residuals of the estimated state sequence and the Riccati equation.

    Successive columns of X̂_i are taken as successive states (exact as the
    horizon grows; Van Overschee & De Moor 1996, ch. 4; nfoursid does the same):
    :math:`\rho_w = \hat x_{k+1} - A\hat x_k - Bu_k`,
    :math:`\rho_v = y_k - C\hat x_k - Du_k`, with covariances Q, S, R
    (summed ``CHUNK_ROWS`` states at a time). The
    steady-state Kalman predictor then solves the filter Riccati equation
    (``scipy.linalg.solve_discrete_are``) :math:`P = APA^\mathsf T + Q -
    (APC^\mathsf T + S)(CPC^\mathsf T + R)^{-1}(APC^\mathsf T + S)^\mathsf T`,
    :math:`K = (APC^\mathsf T + S)(CPC^\mathsf T + R)^{-1}`,
    :math:`\Sigma_e = CPC^\mathsf T + R`. When R is numerically zero (a
    noise-free record) there is no innovation: K = 0, Σ_e = R.
    """
    n, p = A.shape[0], C.shape[0]
    G = np.zeros((n + p, n + p))         # [W V]ᵀ[W V]
    N, ssy = 0, 0.0
    for Y, U in zip(ex.Y, ex.U):
        j = Y.shape[0] - 2 * i + 1
        for q0 in range(0, j - 1, CHUNK_ROWS):
            q1 = min(q0 + CHUNK_ROWS, j - 1)
            X = _states(Y, U, i, M, q0, q1 + 1)          # one state more: x̂ at q1
            Uk, Yk = _rows(U, i + q0, i + q1), _rows(Y, i + q0, i + q1)
            WV = np.hstack([X[1:] - X[:-1] @ A.T - Uk @ B.T, Yk - X[:-1] @ C.T - Uk @ D.T])
            G += WV.T @ WV
            N += WV.shape[0]
        for a in range(0, Y.shape[0], CHUNK_ROWS):
            Yc = _rows(Y, a, a + CHUNK_ROWS)
            ssy += float(np.einsum("ij,ij->", Yc, Yc))
    Q, S, R = G[:n, :n] / N, G[:n, n:] / N, G[n:, n:] / N
    R = (R + R.T) / 2
    scale = max(ssy / sum(ex.lengths), 1e-300)
    if np.linalg.eigvalsh(R)[0] <= 1e-14 * scale:
        return np.zeros((A.shape[0], C.shape[0])), R
    try:
        P = sla.solve_discrete_are(A.T, C.T, (Q + Q.T) / 2, R, s=S)
    except (np.linalg.LinAlgError, ValueError):
        return np.zeros((A.shape[0], C.shape[0])), R
    Se = C @ P @ C.T + R
    K = np.linalg.solve(Se.T, (A @ P @ C.T + S).T).T
    return K, (Se + Se.T) / 2


def _finish(ex, i, order, Ob, W1inv, Z, sv_full, U1, feedthrough):
    """The model of one order from the SVD of the weighted projection."""
    p = ex.p
    n = order
    Gam = U1[:, :n] * np.sqrt(sv_full[:n])
    if W1inv is not None:
        Gam = W1inv @ Gam
    C = Gam[:p].copy()
    A = sla.lstsq(Gam[:-p], Gam[p:], check_finite=False)[0]
    B, D, x0 = _bd_x0(ex, A, C, feedthrough)
    M = sla.pinv(Gam) @ Z                 # x̂ = Γ^† Z w  (the oblique projection's states)
    K, Se = _kalman_gain(ex, i, M, A, B, C, D)
    return A, B, C, D, K, Se, x0


def _gap_order(sv, n_max):
    r"""The order at the largest drop of :math:`\log_{10}\sigma_k` (k = 1 … n_max).

    Singular values below σ₁·eps count as σ₁·eps (rounding level).
    """
    if n_max < 1 or sv.size < 2:
        return 1
    # values below rounding level (σ₁·eps) are all "zero": no drop among them
    s = np.maximum(sv[: n_max + 1], np.finfo(float).eps * sv[0] + np.finfo(float).tiny)
    return int(np.argmax(np.log10(s[:-1]) - np.log10(s[1:]))) + 1


def _aic(model, ex, i, feedthrough):
    """AIC of the one-step prediction errors (the first ``i`` samples of each experiment left out)."""
    if is_dask(ex.Y):            # a Dask record: the predictor run chunk by chunk
        G, N = one_step_errors(model, ex, i, CHUNK_ROWS)
    else:
        E = np.vstack([(Y - model.predict(Y, U, k=1))[i:] for Y, U in zip(ex.Y, ex.U)])
        G, N = E.T @ E, E.shape[0]
    n, m, p = model.order, ex.m, ex.p
    d = n * (2 * p + m) + (p * m if feedthrough else 0)
    sign, logdet = np.linalg.slogdet(G / N)
    return float(N * logdet + 2 * d) if sign > 0 else -np.inf


def _orders(order, n_max):
    vals = [order] if np.ndim(order) == 0 else list(order)
    if not vals:
        raise param_error("order", "an integer, a non-empty range or list of them, or None", order)
    vals = sorted({check_int(v, "order", low=1) for v in vals})
    if vals[-1] > n_max:
        raise param_error("order", f"at most (horizon - 1)·p = {n_max}", vals[-1])
    return vals


def n4sid(data, order=None, *, method="moesp", horizon=None, feedthrough=False):
    r"""State-space model from input–output data by subspace identification.

    The three methods of Van Overschee & De Moor's unifying theorem (1996,
    ch. 4): with i = ``horizon`` block rows of past and future,
    the block-Hankel matrices :math:`U_p, U_f, Y_p, Y_f` (i·m and i·p rows,
    j = N − 2i + 1 columns), :math:`W_p = [U_p; Y_p]` and the oblique
    projection :math:`O_i = Y_f/_{U_f}W_p`, the SVD

    .. math::

        W_1 O_i W_2 = U_1 S_1 V_1^\mathsf T + U_2S_2V_2^\mathsf T,\qquad
        \Gamma_i = W_1^{-1}U_1S_1^{1/2}

    gives the extended observability matrix
    :math:`\Gamma_i = [C; CA; \dots; CA^{i-1}]` of order n (the number of
    singular values kept), for the weightings

    ========== ==================================================== ==========================
    method     :math:`W_1`                                          :math:`W_2`
    ========== ==================================================== ==========================
    "n4sid"    I                                                    I
    "moesp"    I                                                    :math:`\Pi^\perp_{U_f}`
    "cva"      :math:`(Y_f\Pi^\perp_{U_f}Y_f^\mathsf T)^{-1/2}`     :math:`\Pi^\perp_{U_f}`
    ========== ==================================================== ==========================

    (N4SID: Van Overschee & De Moor 1994; MOESP in its past-output form:
    Verhaegen & Dewilde 1992, Verhaegen 1994; CVA: Larimore 1990.) Every
    projection comes from the blocks of the lower-triangular L of the LQ
    factorisation :math:`[U_f; W_p; Y_f] = LQ`, computed as the R factor of
    **one** QR of the transposed data matrix (LAPACK ``geqrf``, in chunks of
    rows with the R carried over; SLICOT IB01AD does the same); no product
    of Hankel matrices is formed. Then

    * C is the first block row of Γᵢ and A the least-squares solution of the
      shift equation :math:`\underline{\Gamma_i}A = \overline{\Gamma_i}`
      (Γ without its last / first block row);
    * B, D and the initial state of each experiment solve one linear least
      squares problem on the output equation given A and C (SLICOT IB01BD);
    * the state sequence :math:`\hat X_i = \Gamma_i^\dagger O_i` gives the
      noise covariances of the residuals and, through the filter Riccati
      equation, the innovation gain K and covariance ``noise_cov`` (see the
      model's :class:`~adaptid.models.StateSpaceModel`); a noise-free record
      gives K = 0.

    Parameters
    ----------
    data : IDData, (y, u) tuple of arrays (N, p), (N, m); or a list of them
        The record; a list holds several experiments with the same signals,
        whose Hankel columns are stacked (never across a boundary); each has
        its own initial state. A merged IDData (:meth:`IDData.merge`) is
        its experiments; NaN samples split a record into the runs of
        complete samples between them, each a separate experiment (runs
        shorter than 2·horizon are left out; MATLAB's ``misdata``, which
        fills the gaps from a model, is the alternative). At least one
        input (time series: not yet).

        Records larger than memory: Dask data, one experiment (a ``(y, u)``
        pair of Dask arrays, Series or DataFrames, or one Dask DataFrame
        whose first column is the output) or a list of them. The R factor
        of the stacked block-Hankel matrices of all experiments comes from
        one Dask tall-skinny QR over blocks formed per chunk inside each
        experiment (each chunk with the 2·horizon − 1 samples after it);
        NaN gaps split the records as in memory (found by a pass over the
        chunks); the rest (B, D, x0, K, the AIC of an order range, and on
        first use the covariance and the summary's fit %) from ordered
        passes over the chunks. ``dt`` comes from a Dask frame's time
        index (the rule of :class:`~adaptid.IDData`, which must find it
        regular), else 1; names from the frames' columns. The result equals
        the in-memory one on the same data to rounding.
    order : int, sequence of int, or None
        n. None: the index of the largest drop of the logarithm of the
        singular values among the first (horizon − 1)·p + 1 (a noise-free
        record of order n has a drop to rounding level after the n-th). A
        sequence (e.g. ``range(1, 9)``): the order of smallest AIC of the
        one-step prediction errors on the data,
        :math:`N\log\det\hat\Sigma_\varepsilon + 2d`,
        d = n(2p + m) (+ pm with feedthrough), N the number of predictions
        after the first ``horizon`` samples of each experiment.
    method : {"moesp", "n4sid", "cva"}
        The weighting (default "moesp").
    horizon : int, optional
        i, the number of block rows of the past and of the future (SLICOT's
        NOBR); default max(10, 2·n_max) with n_max the largest order asked
        for (10 for ``order=None``). Needs (i − 1)·p ≥ n and at least
        2i(m + p) Hankel columns.
    feedthrough : bool
        Estimate D (default False: D = 0, the output does not react to the
        input of the same sample).

    Returns
    -------
    StateSpaceModel
        With ``singular_values`` (of :math:`W_1O_iW_2`, scaled by 1/√j) and
        ``info`` (method, horizon, samples, experiments, the order rule, and
        per candidate order its AIC when a sequence was given, and
        ``x0``: one initial state per experiment).

    References
    ----------
    P. Van Overschee, B. De Moor (1996). *Subspace Identification for Linear
    Systems*. Kluwer. :doi:`10.1007/978-1-4613-0465-4`.
    M. Verhaegen, P. Dewilde (1992). Subspace model identification, part 1.
    *Int. J. Control* 56(5). :doi:`10.1080/00207179208934363`.
    W. E. Larimore (1990). Canonical variate analysis in identification,
    filtering and adaptive control. *Proc. 29th IEEE Conference on Decision
    and Control*, 596–604.
    P. Van Overschee, B. De Moor (1994). N4SID: subspace algorithms for the
    identification of combined deterministic-stochastic systems.
    *Automatica* 30(1), 75–93.
    M. Verhaegen (1994). Identification of the deterministic part of MIMO
    state space models given in innovations form from input-output data.
    *Automatica* 30(1), 61–74.
    M. Verhaegen, V. Verdult (2007). *Filtering and System Identification:
    a Least Squares Approach*. Cambridge University Press.
    SLICOT routines IB01AD, IB01BD (slicot.org).

    Examples
    --------
    >>> import numpy as np
    >>> from adaptid.models import StateSpaceModel, n4sid
    >>> true = StateSpaceModel([[0.9, 0.2], [0.0, 0.5]], [[1.0], [1.0]], [[1.0, 0.0]])
    >>> u = np.random.default_rng(0).standard_normal((1000, 1))
    >>> model = n4sid((true.simulate(u), u), 2)
    >>> bool(np.allclose(np.sort(model.poles().real), [0.5, 0.9]))
    True
    """
    method = check_choice(method, "method", ("moesp", "n4sid", "cva"))
    on_dask = is_dask(data)
    ex = dask_experiments(data) if on_dask else experiments(data)
    p, m = ex.p, ex.m
    guess = 10 if order is None else max(np.ravel(order).tolist() or [1])
    i = (max(10, 2 * int(guess)) if horizon is None
         else check_int(horizon, "horizon", low=2))
    ex = ex.without_short(2 * i)      # runs between NaN gaps too short for the Hankel blocks
    n_max = (i - 1) * p
    orders = None if order is None else _orders(order, n_max)
    cols = sum(max(N - 2 * i + 1, 0) for N in ex.lengths)
    if cols < 2 * i * (m + p) or min(ex.lengths) < 2 * i:
        raise param_error("data", f"at least 2·horizon = {2 * i} samples per experiment and "
                          f"{2 * i * (m + p)} Hankel columns in all", f"<{cols} columns>")
    L, _ = lq_factor_dask(ex, i, _hankel_chunk) if on_dask else _lq_factor(ex, i)
    Ob, W1inv, Z = _weighted(_blocks(L, m, p, i), method)
    U1, sv, _ = sla.svd(Ob, full_matrices=False, check_finite=False)
    info = {"method": method, "horizon": i, "samples": sum(ex.lengths),
            "experiments": len(ex.Y), "feedthrough": bool(feedthrough)}
    if orders is None:
        orders = [_gap_order(sv, n_max)]
        info["order rule"] = "largest drop of log singular values"
    models = []
    for n in orders:
        A, B, C, D, K, Se, x0 = _finish(ex, i, n, Ob, W1inv, Z, sv, U1, feedthrough)
        mdl = StateSpaceModel(A, B, C, D, K, noise_cov=Se, dt=ex.dt, y_names=ex.y_names,
                              u_names=ex.u_names, singular_values=sv,
                              info=dict(info, x0=x0))
        mdl._fit_data, mdl._fit_dask = (None, ex) if on_dask else (ex, None)
        models.append(mdl)
    if len(models) == 1:
        return models[0]
    aics = [_aic(mdl, ex, i, feedthrough) for mdl in models]
    best = models[int(np.argmin(aics))]
    best.info.update({"criterion": "AIC of one-step prediction errors",
                      "aic": dict(zip(orders, aics))})
    return best
