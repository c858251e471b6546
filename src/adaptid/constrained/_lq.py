r"""Finite-horizon linear quadratic control and state estimation.

Both are solved as one structured constrained least-squares problem in the
stacked variable ``z = (x_1, …, x_T, u_1, …, u_{T−1})`` (Boyd &
Vandenberghe (2018), §17.2–17.3), with the exact QR method of
:mod:`._linalg`. The matrices are assembled with Kronecker products (no loop
over time); the dense QR costs ``O(T³(n + m)³)`` and suits horizons of up to
a few hundred steps.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validation import as_float_array, check_int, check_scalar, param_error
from ._linalg import RankProblem, cls_qr

__all__ = [
    "LQControlResult", "LQEstimateResult", "LQCVResult", "OpenLoopResult",
    "lq_control", "lq_estimate", "lq_estimate_cv", "open_loop",
]


def _shape_str(a) -> str:
    return "x".join(str(s) for s in np.shape(a))


@dataclass(repr=False, eq=False)
class LQControlResult:
    """Result of :func:`lq_control`.

    Attributes
    ----------
    x : ndarray, shape (T, n) or (T, n, q)
        State trajectory (``q`` initial states solved at once).
    u : ndarray, shape (T − 1, m) or (T − 1, m, q)
        Inputs.
    y : ndarray, shape (T, p) or (T, p, q)
        Outputs ``C x_t``.
    cost : float or ndarray, shape (q,)
        ``J_out + ρ J_in``.
    j_out, j_in : float or ndarray, shape (q,)
        ``Σ‖C x_t‖²`` and ``Σ‖u_t‖²``.
    rho : float
    """

    x: np.ndarray
    u: np.ndarray
    y: np.ndarray
    cost: float | np.ndarray
    j_out: float | np.ndarray
    j_in: float | np.ndarray
    rho: float

    def __repr__(self) -> str:
        cost = f"{self.cost:.6g}" if np.ndim(self.cost) == 0 else f"<{self.cost.size} costs>"
        return (f"LQControlResult(T={self.x.shape[0]}, x: {_shape_str(self.x)}, "
                f"u: {_shape_str(self.u)}, rho={self.rho:g}, cost={cost})")


@dataclass(repr=False, eq=False)
class OpenLoopResult:
    """Result of :func:`open_loop`: ``.x`` (T, n[, q]) and ``.y`` (T, p[, q])."""

    x: np.ndarray
    y: np.ndarray

    def __repr__(self) -> str:
        return (f"OpenLoopResult(T={self.x.shape[0]}, x: {_shape_str(self.x)}, "
                f"y: {_shape_str(self.y)})")


@dataclass(repr=False, eq=False)
class LQEstimateResult:
    """Result of :func:`lq_estimate`.

    Attributes
    ----------
    x : ndarray, shape (T, n)
        Estimated states.
    u : ndarray, shape (T − 1, m)
        Estimated process inputs.
    y : ndarray, shape (T, p)
        Estimated outputs ``C x_t`` (also at missing samples).
    cost : float
        ``J_meas + λ J_proc``.
    j_meas, j_proc : float
        ``Σ‖y_t − C x_t‖²`` over the measured entries and ``Σ‖u_t‖²``.
    lam : float
    n_missing : int
        Number of missing (NaN) measurement entries.
    """

    x: np.ndarray
    u: np.ndarray
    y: np.ndarray
    cost: float
    j_meas: float
    j_proc: float
    lam: float
    n_missing: int

    def __repr__(self) -> str:
        return (f"LQEstimateResult(T={self.x.shape[0]}, n={self.x.shape[1]}, "
                f"lam={self.lam:g}, cost={self.cost:.6g}, n_missing={self.n_missing})")


@dataclass(repr=False, eq=False)
class LQCVResult:
    """Result of :func:`lq_estimate_cv`.

    Attributes
    ----------
    lam : float
        The λ with the smallest held-out RMS error.
    lams : ndarray, shape (L,)
        The candidates, as given.
    train_rms, test_rms : ndarray, shape (L,)
        RMS prediction error on the training and on the held-out
        measurements for each λ (the cross-validation curve).
    holdout : ndarray of bool, shape (T,)
        The held-out time steps.
    result : LQEstimateResult
        :func:`lq_estimate` on all the data with the chosen λ.
    """

    lam: float
    lams: np.ndarray
    train_rms: np.ndarray
    test_rms: np.ndarray
    holdout: np.ndarray
    result: LQEstimateResult

    def __repr__(self) -> str:
        return (f"LQCVResult(lam={self.lam:g}, n_lams={self.lams.size}, "
                f"test_rms={self.test_rms.min():.6g}, n_holdout={int(self.holdout.sum())})")


def _system(A, B, C):
    """Validate (A, B, C); 1-D B is one input column, 1-D C one output row."""
    A = as_float_array(A, "A", ndim=2)
    n = A.shape[0]
    if A.shape != (n, n) or n == 0:
        raise param_error("A", "a non-empty square matrix", f"<shape {A.shape}>")
    B = as_float_array(B, "B", ndim=(1, 2))
    if B.ndim == 1:
        B = B[:, None]
    if B.shape[0] != n or B.shape[1] == 0:
        raise param_error("B", f"of shape ({n}, m) or ({n},)", f"<shape {B.shape}>")
    C = as_float_array(C, "C", ndim=(1, 2))
    if C.ndim == 1:
        C = C[None, :]
    if C.shape[1] != n or C.shape[0] == 0:
        raise param_error("C", f"of shape (p, {n}) or ({n},)", f"<shape {C.shape}>")
    return A, B, C


def _dynamics_rows(A, B, T):
    """Rows of ``A x_t + B u_t − x_{t+1} = 0``, t = 1..T−1, on z = (x, u)."""
    n, m = B.shape
    nx, nu = n * T, m * (T - 1)
    D = np.zeros((n * (T - 1), nx + nu))
    D[:, :n * (T - 1)] = np.kron(np.eye(T - 1), A)
    D[:, n:nx] -= np.eye(n * (T - 1))
    D[:, nx:] = np.kron(np.eye(T - 1), B)
    return D


def open_loop(A, C, x_init, T) -> OpenLoopResult:
    r"""Free response ``x_{t+1} = A x_t`` (u = 0), ``y_t = C x_t``, t = 1..T.

    The comparison case of the reference's LQ control example.

    Parameters
    ----------
    A : array_like, shape (n, n)
    C : array_like, shape (p, n) or (n,)
    x_init : array_like, shape (n,) or (n, q)
    T : int
        Number of time steps (≥ 1).

    Returns
    -------
    OpenLoopResult
        ``.x`` (T, n[, q]) and ``.y`` (T, p[, q]).
    """
    A = as_float_array(A, "A", ndim=2)
    n = A.shape[0]
    if A.shape != (n, n) or n == 0:
        raise param_error("A", "a non-empty square matrix", f"<shape {A.shape}>")
    _, _, C = _system(A, np.zeros((n, 1)), C)
    x0 = as_float_array(x_init, "x_init", ndim=(1, 2))
    if x0.shape[0] != n:
        raise param_error("x_init", f"of shape ({n},) or ({n}, q)", f"<shape {x0.shape}>")
    T = check_int(T, "T", low=1)
    x = np.empty((T,) + x0.shape)
    x[0] = x0
    for t in range(T - 1):
        x[t + 1] = A @ x[t]
    y = np.einsum("pn,tn...->tp...", C, x)
    return OpenLoopResult(x=x, y=y)


def lq_control(A, B, C, x_init, x_des, T, rho) -> LQControlResult:
    r"""Finite-horizon linear quadratic control, as constrained least squares.

    .. math::

        \min \; \sum_{t=1}^{T} \|C x_t\|^2 + \rho \sum_{t=1}^{T-1} \|u_t\|^2
        \quad\text{s.t.}\quad x_{t+1} = A x_t + B u_t,\;
        x_1 = x^{\text{init}},\; x_T = x^{\text{des}} .

    In ``z = (x_1, …, x_T, u_1, …, u_{T−1})`` this is ``min ‖Ãz − b̃‖²``
    s.t. ``C̃z = d̃`` with ``Ã = blkdiag(I_T ⊗ C, √ρ I)``, ``b̃ = 0`` and
    ``C̃`` stacking ``[I_{T−1} ⊗ A, 0] − [0, I] | I_{T−1} ⊗ B`` and the two
    end-point rows, exactly as the reference builds them; solved by the QR
    method of :func:`constrained_lstsq`.

    Parameters
    ----------
    A : array_like, shape (n, n)
    B : array_like, shape (n, m) or (n,)
    C : array_like, shape (p, n) or (n,)
    x_init : array_like, shape (n,) or (n, q)
        Initial state(s); ``q`` columns solve ``q`` problems with one
        factorisation.
    x_des : array_like, shape (n,) or (n, q)
        Required final state(s).
    T : int
        Horizon (number of states, ≥ 2).
    rho : float
        Input weight ρ > 0.

    Returns
    -------
    LQControlResult
        ``.x`` (T, n[, q]), ``.u`` (T − 1, m[, q]), ``.y`` (T, p[, q]),
        ``.cost``, ``.j_out``, ``.j_in``.

    Raises
    ------
    ValueError
        On bad shapes or values; naming ``T`` when ``x_des`` cannot be
        reached from ``x_init`` in ``T − 1`` steps.

    Notes
    -----
    Source: Boyd & Vandenberghe (2018), §17.2 "Linear quadratic control"
    (the stacked matrices Ã, C̃, and its example: the 3-state system,
    ``T = 100``, ``ρ = 0.2``).

    References
    ----------
    S. Boyd and L. Vandenberghe, *Introduction to Applied Linear Algebra*,
    Cambridge University Press, 2018, §17.2. :doi:`10.1017/9781108583664`
    """
    A, B, C = _system(A, B, C)
    n, m = B.shape
    p = C.shape[0]
    x0 = as_float_array(x_init, "x_init", ndim=(1, 2))
    if x0.shape[0] != n or (x0.ndim == 2 and x0.shape[1] == 0):
        raise param_error("x_init", f"of shape ({n},) or ({n}, q)", f"<shape {x0.shape}>")
    xd = as_float_array(x_des, "x_des", ndim=(1, 2))
    q = x0.shape[1] if x0.ndim == 2 else (xd.shape[1] if xd.ndim == 2 else 1)
    if xd.shape[0] != n or (xd.ndim == 2 and xd.shape[1] != q):
        raise param_error("x_des", f"of shape ({n},) or ({n}, {q})", f"<shape {xd.shape}>")
    T = check_int(T, "T", low=2)
    rho = check_scalar(rho, "rho", low=0.0, low_open=True)
    vec = x0.ndim == 1 and xd.ndim == 1
    X0 = x0.reshape(n, -1) if x0.ndim == 2 else np.repeat(x0[:, None], q, axis=1)
    XD = xd.reshape(n, -1) if xd.ndim == 2 else np.repeat(xd[:, None], q, axis=1)

    nx, nu = n * T, m * (T - 1)
    At = np.zeros((p * T + nu, nx + nu))
    At[:p * T, :nx] = np.kron(np.eye(T), C)
    At[p * T:, nx:] = np.sqrt(rho) * np.eye(nu)
    bt = np.zeros((p * T + nu, q))
    Ct = np.zeros((n * (T + 1), nx + nu))
    Ct[:n * (T - 1)] = _dynamics_rows(A, B, T)
    Ct[n * (T - 1):n * T, :n] = np.eye(n)
    Ct[n * T:, nx - n:nx] = np.eye(n)
    dt = np.vstack([np.zeros((n * (T - 1), q)), X0, XD])
    try:
        z, _ = cls_qr(At, bt, Ct, dt)
    except RankProblem as err:
        raise param_error(
            "T", "large enough (and (A, B) controllable) for x_des to be reachable "
            "from x_init in T − 1 steps",
            f"<T = {T}: the dynamics and end-point constraints have rank "
            f"{err.rank} < {err.full}>") from None
    x = z[:nx].reshape(T, n, q)
    u = z[nx:].reshape(T - 1, m, q)
    y = np.einsum("pn,tnq->tpq", C, x)
    j_out = np.einsum("tpq,tpq->q", y, y)
    j_in = np.einsum("tmq,tmq->q", u, u)
    cost = j_out + rho * j_in
    if vec:
        x, u, y = x[..., 0], u[..., 0], y[..., 0]
        j_out, j_in, cost = float(j_out[0]), float(j_in[0]), float(cost[0])
    return LQControlResult(x=x, u=u, y=y, cost=cost, j_out=j_out, j_in=j_in, rho=rho)


def _estimate(A, B, C, y, lam) -> LQEstimateResult:
    """lq_estimate on validated input (y may hold NaN)."""
    n, m = B.shape
    p = C.shape[0]
    T = y.shape[0]
    obs = ~np.isnan(y)
    nx, nu = n * T, m * (T - 1)
    rows = np.flatnonzero(obs.ravel())
    At = np.zeros((rows.size + nu, nx + nu))
    At[:rows.size, :nx] = np.kron(np.eye(T), C)[rows]
    At[rows.size:, nx:] = np.sqrt(lam) * np.eye(nu)
    bt = np.concatenate([y.ravel()[rows], np.zeros(nu)])[:, None]
    Ct = _dynamics_rows(A, B, T)
    z, _ = cls_qr(At, bt, Ct, np.zeros((Ct.shape[0], 1)))
    x = z[:nx, 0].reshape(T, n)
    u = z[nx:, 0].reshape(T - 1, m)
    yhat = x @ C.T
    e = (y - yhat)[obs]
    j_meas = float(e @ e)
    j_proc = float(np.sum(u * u))
    return LQEstimateResult(x=x, u=u, y=yhat, cost=j_meas + lam * j_proc, j_meas=j_meas,
                            j_proc=j_proc, lam=lam, n_missing=int(y.size - rows.size))


def _validate_estimate_args(A, B, C, y):
    A, B, C = _system(A, B, C)
    p = C.shape[0]
    y = as_float_array(y, "y", ndim=(1, 2), allow_nan=True)
    if y.ndim == 1:
        if p != 1:
            raise param_error("y", f"of shape (T, {p})", f"<shape {y.shape}>")
        y = y[:, None]
    if y.shape[1] != p:
        raise param_error("y", f"of shape (T, {p}) (p = rows of C)", f"<shape {y.shape}>")
    if y.shape[0] < 2:
        raise param_error("y", "of at least 2 samples (rows)", f"<shape {y.shape}>")
    return A, B, C, y


def lq_estimate(A, B, C, y, lam) -> LQEstimateResult:
    r"""Linear quadratic state estimation (smoothing), as constrained least squares.

    .. math::

        \min \; \sum_{t \in \mathcal{M}} \|y_t - C x_t\|^2
        + \lambda \sum_{t=1}^{T-1} \|u_t\|^2
        \quad\text{s.t.}\quad x_{t+1} = A x_t + B u_t ,

    over the whole trajectory; :math:`\mathcal M` is the set of measured
    samples. In ``z = (x, u)``: ``Ã = blkdiag(I_T ⊗ C, √λ I)`` (rows of
    missing measurements removed), ``b̃ = (y, 0)``, ``C̃ = [I_{T−1} ⊗ A, 0] −
    [0, I] | I_{T−1} ⊗ B``, ``d̃ = 0``; solved by the QR method.

    Parameters
    ----------
    A : array_like, shape (n, n)
    B : array_like, shape (n, m) or (n,)
        Process input matrix.
    C : array_like, shape (p, n) or (n,)
    y : array_like, shape (T, p) (or (T,) when p = 1)
        Measurements. NaN marks a missing measurement (a row of NaN a
        missing sample); it is left out of the first sum.
    lam : float
        Weight λ > 0 of the process inputs (larger: smoother trajectory).

    Returns
    -------
    LQEstimateResult
        ``.x`` (T, n), ``.u`` (T − 1, m), ``.y`` (T, p) = ``C x̂_t``, ``.cost``.

    Raises
    ------
    ValueError
        On bad shapes or values (infinite y); naming ``y`` when the measured
        samples do not determine the trajectory.

    Notes
    -----
    Source: Boyd & Vandenberghe (2018), §17.3 "State estimation"
    (the stacked matrices Ã, C̃, and its example: a double integrator,
    ``T = 100``, ``λ = 10³``).

    References
    ----------
    S. Boyd and L. Vandenberghe, *Introduction to Applied Linear Algebra*,
    Cambridge University Press, 2018, §17.3. :doi:`10.1017/9781108583664`
    """
    A, B, C, y = _validate_estimate_args(A, B, C, y)
    lam = check_scalar(lam, "lam", low=0.0, low_open=True)
    try:
        return _estimate(A, B, C, y, lam)
    except RankProblem as err:
        raise param_error(
            "y", "measured often enough to determine the state trajectory "
            "(observability of (A, C) from the non-missing samples)",
            f"<a rank-deficient problem: rank {err.rank} < {err.full}>") from None


def lq_estimate_cv(A, B, C, y, lams, *, holdout=0.2, rng=None) -> LQCVResult:
    r"""Choose λ of :func:`lq_estimate` by validation on held-out samples.

    For each candidate λ the trajectory is estimated without the held-out
    time steps (treated as missing), and the RMS error ``y_t − C x̂_t`` is
    measured on the training samples and on the held-out ones. The λ with
    the smallest held-out error is chosen and the estimate recomputed from
    all the data.

    .. math::

        \lambda^\star = \arg\min_{\lambda} \sqrt{\frac{1}{|\mathcal H|}
        \sum_{t \in \mathcal H} \|y_t - C \hat x_t(\lambda)\|^2 / p}

    Parameters
    ----------
    A, B, C, y
        As for :func:`lq_estimate`.
    lams : array_like, shape (L,)
        Candidate weights, all > 0.
    holdout : float or array_like
        A fraction in (0, 1) of the measured time steps held out at random,
        or a boolean mask of shape (T,), or integer time indices.
    rng : None, int or numpy.random.Generator
        Randomness for a fractional ``holdout``.

    Returns
    -------
    LQCVResult
        ``.lam``, ``.lams``, ``.train_rms``, ``.test_rms`` (the curve),
        ``.holdout`` and ``.result`` (all data, chosen λ).

    Notes
    -----
    Source: Boyd & Vandenberghe (2018), §17.3 ("the parameter λ ... chosen
    by validation").
    """
    A, B, C, y = _validate_estimate_args(A, B, C, y)
    lams = as_float_array(lams, "lams", ndim=1)
    if lams.size == 0 or np.any(lams <= 0):
        raise param_error("lams", "a non-empty array of positive weights", lams)
    T = y.shape[0]
    measured = ~np.all(np.isnan(y), axis=1)
    if np.ndim(holdout) == 0 and not isinstance(holdout, (bool, np.bool_)) and \
            isinstance(holdout, (float, np.floating)):
        frac = check_scalar(holdout, "holdout", low=0.0, high=1.0, low_open=True,
                            high_open=True)
        try:
            gen = np.random.default_rng(rng)
        except (TypeError, ValueError):
            raise param_error("rng", "None, an int seed or a numpy Generator", rng,
                              exc=TypeError) from None
        cand = np.flatnonzero(measured)
        k = int(round(frac * cand.size))
        if k < 1 or k >= cand.size:
            raise param_error("holdout", "a fraction leaving at least one held-out and "
                              "one training sample", holdout)
        mask = np.zeros(T, dtype=bool)
        mask[gen.choice(cand, size=k, replace=False)] = True
    else:
        arr = np.asarray(holdout)
        if arr.dtype == bool:
            if arr.shape != (T,):
                raise param_error("holdout", f"a boolean mask of shape ({T},)",
                                  f"<shape {arr.shape}>")
            mask = arr.copy()
        elif arr.dtype.kind in "iu" and arr.ndim == 1:
            if arr.size and (arr.min() < -T or arr.max() >= T):
                raise param_error("holdout", f"time indices in [0, {T})", arr)
            mask = np.zeros(T, dtype=bool)
            mask[arr] = True
        else:
            raise param_error("holdout", "a fraction, a boolean mask or integer indices",
                              holdout, exc=TypeError)
        if not np.any(mask & measured) or not np.any(~mask & measured):
            raise param_error("holdout", "leaving at least one held-out and one training "
                              "measurement", "<an empty training or test set>")
    y_train = y.copy()
    y_train[mask] = np.nan
    test_obs = ~np.isnan(y) & mask[:, None]
    train_obs = ~np.isnan(y_train)
    train_rms = np.empty(lams.size)
    test_rms = np.empty(lams.size)
    for i, lam in enumerate(lams):
        try:
            res = _estimate(A, B, C, y_train, float(lam))
        except RankProblem as err:
            raise param_error(
                "holdout", "leaving enough training samples to determine the trajectory",
                f"<a rank-deficient problem: rank {err.rank} < {err.full}>") from None
        train_rms[i] = np.sqrt(np.mean((y - res.y)[train_obs] ** 2))
        test_rms[i] = np.sqrt(np.mean((y - res.y)[test_obs] ** 2))
    best = float(lams[int(np.argmin(test_rms))])
    result = lq_estimate(A, B, C, y, best)
    return LQCVResult(lam=best, lams=lams.copy(), train_rms=train_rms, test_rms=test_rms,
                      holdout=mask, result=result)
