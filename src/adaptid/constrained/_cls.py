r"""Constrained and multi-objective least squares (public functions)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla

from .._exceptions import InfeasibleError
from .._validation import as_float_array, check_choice, param_error
from ._linalg import RankProblem, cls_kkt, cls_qr, numerical_rank
from ._qp import QPStatusError, solve_qp

__all__ = ["CLSResult", "constrained_lstsq", "MultiObjectiveResult",
           "multi_objective_lstsq"]


def _fmt(a) -> str:
    a = np.asarray(a)
    if a.size <= 6:
        return np.array2string(a, precision=6, separator=", ", suppress_small=False)
    return f"<array of shape {a.shape}>"


@dataclass(repr=False, eq=False)
class CLSResult:
    r"""Solution of a constrained least-squares problem.

    Attributes
    ----------
    x : ndarray, shape (n,) or (n, k)
        The minimiser (one column per right-hand side).
    multipliers : ndarray, shape (p,) or (p, k)
        Lagrange multipliers ``z`` of ``Cx = d`` with the sign of the KKT
        system ``[[2AᵀA, Cᵀ], [C, 0]] [x; z] = [2Aᵀb; d]``, i.e.
        ``2Aᵀ(Ax − b) + Cᵀz + Gᵀμ + ν_ub − ν_lb = 0``.
    objective : float or ndarray, shape (k,)
        ``‖Ax − b‖²`` at the solution.
    residuals : ndarray, shape (m,) or (m, k)
        ``Ax − b``.
    method : str
        ``"qr"``, ``"kkt"`` or ``"qp"`` (Clarabel, then the polish).
    ineq_multipliers : ndarray, shape (q,)
        μ ≥ 0 for ``Gx ≤ h`` (empty without ``G``).
    active : ndarray of bool, shape (q,)
        Rows of ``Gx ≤ h`` that hold with equality at the solution.
    lb_multipliers, ub_multipliers : ndarray, shape (n,)
        ν_lb, ν_ub ≥ 0 for the bounds (zero where a bound is absent).
    active_lb, active_ub : ndarray of bool, shape (n,)
        Bounds that hold with equality.
    polished : bool
        For ``method="qp"``: the active-set polish succeeded, so the KKT
        conditions hold to rounding level. Always True for the exact methods.
    status : str
        ``"optimal"`` for the exact methods, Clarabel's status otherwise.
    iterations : int
        Clarabel's interior-point iterations (0 for the exact methods).
    """

    x: np.ndarray
    multipliers: np.ndarray
    objective: float | np.ndarray
    residuals: np.ndarray
    method: str
    ineq_multipliers: np.ndarray
    active: np.ndarray
    lb_multipliers: np.ndarray
    ub_multipliers: np.ndarray
    active_lb: np.ndarray
    active_ub: np.ndarray
    polished: bool = True
    status: str = "optimal"
    iterations: int = field(default=0)

    def __repr__(self) -> str:
        n_act = int(self.active.sum() + self.active_lb.sum() + self.active_ub.sum())
        obj = self.objective
        obj_s = f"{obj:.6g}" if np.ndim(obj) == 0 else _fmt(obj)
        return (f"CLSResult(method={self.method!r}, objective={obj_s}, "
                f"x={_fmt(self.x)}, n_eq={self.multipliers.shape[0]}, "
                f"n_active_ineq={n_act}, polished={self.polished}, "
                f"status={self.status!r})")


def _pair(M, v, mname: str, vname: str, n: int, *, rhs_2d: bool):
    """Validate a (matrix, right-hand side) pair such as (C, d) or (G, h)."""
    if M is None and v is None:
        return np.zeros((0, n)), np.zeros(0)
    if M is None:
        raise param_error(mname, f"given together with {vname}", None)
    if v is None:
        raise param_error(vname, f"given together with {mname}", None)
    M = as_float_array(M, mname, ndim=2)
    if M.shape[1] != n:
        raise param_error(mname, f"of shape (*, {n}) (n = columns of A)",
                          f"<shape {M.shape}>")
    v = as_float_array(v, vname, ndim=(1, 2) if rhs_2d else 1)
    if v.shape[0] != M.shape[0]:
        raise param_error(vname, f"of length {M.shape[0]} (the rows of {mname})",
                          f"<shape {v.shape}>")
    return M, v


def _bound(x, name: str, n: int, impossible: float) -> np.ndarray | None:
    if x is None:
        return None
    arr = as_float_array(x, name, ndim=(0, 1), finite=False)
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    elif arr.shape != (n,):
        raise param_error(name, f"a scalar or of shape ({n},)", f"<shape {arr.shape}>")
    if np.isnan(arr).any():
        raise param_error(name, "free of NaN (use ±inf for no bound)", "<NaN entries>")
    if np.any(arr == impossible):
        raise param_error(name, f"{'< inf' if impossible > 0 else '> -inf'} everywhere",
                          "<an impossible infinite bound>", exc=InfeasibleError)
    return arr


def rank_error(err: RankProblem, *, stacked=("A", "[A; C]"), constraint=("C", "d")):
    """Translate an internal :class:`RankProblem` into a ``ValueError``."""
    if err.kind == "stacked":
        name, what = stacked
        return param_error(
            name, f"such that {what} has full column rank (a unique minimiser)",
            f"<rank {err.rank} < {err.full} columns>")
    cname, dname = constraint
    if err.kind == "inconsistent":
        return param_error(
            dname, f"in the range of {cname} (consistent equality constraints)",
            f"<an inconsistent system: {cname} has rank {err.rank} < {err.full} rows>",
            exc=InfeasibleError)
    return param_error(
        cname, "of full row rank (linearly independent constraints)",
        f"<rank {err.rank} < {err.full} rows; remove the redundant rows>")


def constrained_lstsq(A, b, C=None, d=None, *, G=None, h=None, lb=None, ub=None,
                      method="auto") -> CLSResult:
    r"""Least squares under linear equality and inequality constraints.

    .. math::

        \min_x \|Ax - b\|^2 \quad\text{s.t.}\quad Cx = d,\; Gx \le h,\;
        lb \le x \le ub .

    Parameters
    ----------
    A : array_like, shape (m, n)
        Objective matrix.
    b : array_like, shape (m,) or (m, k)
        Target; ``k`` columns are ``k`` problems sharing ``A`` and ``C``
        (equality constraints only).
    C : array_like, shape (p, n), optional
        Equality constraint matrix (given together with ``d``). Must have
        full row rank.
    d : array_like, shape (p,) or (p, k), optional
        Equality right-hand side.
    G : array_like, shape (q, n), optional
        Inequality constraint matrix (given together with ``h``).
    h : array_like, shape (q,), optional
        Inequality right-hand side.
    lb, ub : float or array_like, shape (n,), optional
        Bounds; ``-inf`` / ``inf`` entries mean no bound.
    method : {"auto", "qr", "kkt", "qp"}
        ``"qr"``: the QR method of the reference (``cls_solve``), exact;
        ``"kkt"``: the KKT system with the Gram matrix, as in the reference,
        which squares the condition number (for comparison; warns with
        :class:`IllConditionedWarning` when that costs more than half the
        digits); ``"qp"``: the QP solver Clarabel followed by an exact
        active-set polish. ``"auto"`` is ``"qr"`` without inequalities or
        bounds and ``"qp"`` with them.

    Returns
    -------
    CLSResult
        ``.x``, ``.multipliers``, ``.objective``, ``.active`` and the
        inequality and bound multipliers.

    Raises
    ------
    ValueError
        On wrong shapes or non-finite values (the message names the
        argument); when ``C`` lacks full row rank or ``[A; C]`` lacks full
        column rank (the minimiser would not be unique).
    InfeasibleError
        (a ``ValueError``) when the constraints have no feasible point.

    Notes
    -----
    The solution is unique iff ``C`` has full row rank and ``[A; C]`` full
    column rank (Boyd & Vandenberghe (2018), §16.1). It satisfies the KKT
    equations (ibid., §16.2, eq. 16.4)

    .. math::

        \begin{bmatrix} 2A^TA & C^T \\ C & 0 \end{bmatrix}
        \begin{bmatrix} \hat x \\ \hat z \end{bmatrix} =
        \begin{bmatrix} 2A^Tb \\ d \end{bmatrix},

    which ``method="kkt"`` solves directly. ``method="qr"`` is the
    algorithm of §16.3 (the reference's ``cls_solve``): with the QR
    factorisation ``[A; C] = [Q_1; Q_2] R`` and ``Q_2^T = \tilde Q \tilde R``,

    .. math::

        \tilde R w = 2\tilde Q^T Q_1^T b - 2\tilde R^{-T} d, \qquad
        R \hat x = Q_1^T b - Q_2^T w / 2, \qquad \hat z = w + 2d,

    never forming :math:`A^TA`. Two additions to the reference: column
    pivoting in both QR factorisations, to detect rank deficiency; and a
    scaling of ``A, b`` by ``‖A‖_F`` and of each constraint row by its norm
    before factorising (the solution is unchanged and the multipliers are
    scaled back), without which the step :math:`\hat z = w + 2d` cancels
    catastrophically when :math:`\|A\|^2` and :math:`\|C\|` differ by
    orders of magnitude. With inequalities the
    multipliers satisfy :math:`2A^T(A\hat x - b) + C^T\hat z + G^T\mu +
    \nu_{ub} - \nu_{lb} = 0`, :math:`\mu, \nu \ge 0` and complementary
    slackness. Source: Boyd and Vandenberghe (2018), §16.2 (the KKT
    equations, eq. 16.4) and §16.3 (the QR solution, their ``cls_solve``).

    References
    ----------
    S. Boyd and L. Vandenberghe, *Introduction to Applied Linear Algebra:
    Vectors, Matrices, and Least Squares*, Cambridge University Press,
    2018, ch. 16. :doi:`10.1017/9781108583664`

    Examples
    --------
    >>> import numpy as np
    >>> from adaptid.constrained import constrained_lstsq
    >>> A = np.eye(3); b = np.array([1.0, 2.0, 3.0])
    >>> res = constrained_lstsq(A, b, C=np.ones((1, 3)), d=np.array([3.0]))
    >>> np.allclose(res.x.sum(), 3.0)
    True
    """
    method = check_choice(method, "method", ("auto", "qr", "kkt", "qp"))
    A = as_float_array(A, "A", ndim=2)
    m, n = A.shape
    if n == 0:
        raise param_error("A", "a matrix with at least one column", A)
    b = as_float_array(b, "b", ndim=(1, 2))
    if b.shape[0] != m:
        raise param_error("b", f"of length {m} (the rows of A)", f"<shape {b.shape}>")
    C, d = _pair(C, d, "C", "d", n, rhs_2d=True)
    G, h = _pair(G, h, "G", "h", n, rhs_2d=False)
    lb = _bound(lb, "lb", n, np.inf)
    ub = _bound(ub, "ub", n, -np.inf)
    has_ineq = G.shape[0] > 0 or lb is not None or ub is not None
    if b.ndim == 2 and d.ndim == 2 and b.shape[1] != d.shape[1]:
        raise param_error("d", f"of shape ({d.shape[0]}, {b.shape[1]}) (the columns of b)",
                          f"<shape {d.shape}>")
    if has_ineq:
        if method in ("qr", "kkt"):
            raise param_error("method", "'auto' or 'qp' when G, h, lb or ub are given",
                              method)
        if b.ndim == 2 or d.ndim == 2:
            name = "b" if b.ndim == 2 else "d"
            raise param_error(name, "1-dimensional when G, h, lb or ub are given",
                              f"<shape {(b if name == 'b' else d).shape}>")
        method = "qp"
    elif method == "auto":
        method = "qr"
    if lb is not None and ub is not None and np.any(lb > ub):
        i = int(np.flatnonzero(lb > ub)[0])
        raise param_error("lb", "<= ub elementwise",
                          f"<lb[{i}] = {lb[i]!r} > ub[{i}] = {ub[i]!r}>", exc=InfeasibleError)

    if method == "qp":
        return _solve_with_qp(A, b, C, d, G, h, lb, ub)

    vec = b.ndim == 1 and d.ndim == 1
    k = b.shape[1] if b.ndim == 2 else (d.shape[1] if d.ndim == 2 else 1)
    b2 = b if b.ndim == 2 else np.repeat(b[:, None], k, axis=1)
    d2 = d if d.ndim == 2 else np.repeat(d[:, None], k, axis=1)
    solver = cls_qr if method == "qr" else cls_kkt
    try:
        x, z = solver(A, b2, C, d2)
    except RankProblem as err:
        raise rank_error(err) from None
    r = A @ x - b2
    obj = np.einsum("ij,ij->j", r, r)
    if vec:
        x, z, r, obj = x[:, 0], z[:, 0], r[:, 0], float(obj[0])
    return CLSResult(
        x=x, multipliers=z, objective=obj, residuals=r, method=method,
        ineq_multipliers=np.zeros(0), active=np.zeros(0, dtype=bool),
        lb_multipliers=np.zeros(n), ub_multipliers=np.zeros(n),
        active_lb=np.zeros(n, dtype=bool), active_ub=np.zeros(n, dtype=bool))


def _solve_with_qp(A, b, C, d, G, h, lb, ub) -> CLSResult:
    n = A.shape[1]
    q = G.shape[0]
    iu = np.flatnonzero(np.isfinite(ub)) if ub is not None else np.zeros(0, np.intp)
    il = np.flatnonzero(np.isfinite(lb)) if lb is not None else np.zeros(0, np.intp)
    eye = np.eye(n)
    Gall = np.vstack([G, eye[iu], -eye[il]])
    hall = np.concatenate([h, ub[iu] if ub is not None else [], -lb[il] if lb is not None else []])
    try:
        out = solve_qp(A, b, C, d, Gall, hall)
    except RankProblem as err:
        raise rank_error(err) from None
    except QPStatusError as err:
        if "PrimalInfeasible" in err.status:
            raise param_error(
                "constraints (C, d, G, h, lb, ub)", "feasible",
                f"<a set certified empty by the QP solver (status {err.status})>",
                exc=InfeasibleError) from None
        if "DualInfeasible" in err.status:  # cannot happen for ‖Ax − b‖² ≥ 0
            raise param_error("A", "such that the problem is bounded below",
                              f"<status {err.status}>") from None
        raise RuntimeError(
            f"the QP solver Clarabel failed with status {err.status}; "
            "check the scaling of A, b, G and h") from None
    mu = out["mu"]
    active = out["active"]
    lbm = np.zeros(n)
    ubm = np.zeros(n)
    act_lb = np.zeros(n, dtype=bool)
    act_ub = np.zeros(n, dtype=bool)
    ubm[iu] = mu[q:q + iu.size]
    act_ub[iu] = active[q:q + iu.size]
    lbm[il] = mu[q + iu.size:]
    act_lb[il] = active[q + iu.size:]
    x = out["x"]
    r = A @ x - b
    return CLSResult(
        x=x, multipliers=out["z"], objective=float(r @ r), residuals=r, method="qp",
        ineq_multipliers=mu[:q], active=active[:q], lb_multipliers=lbm,
        ub_multipliers=ubm, active_lb=act_lb, active_ub=act_ub,
        polished=out["polished"], status=out["status"], iterations=out["iterations"])


@dataclass(repr=False, eq=False)
class MultiObjectiveResult:
    """Solution of a weighted multi-objective least-squares problem.

    Attributes
    ----------
    x : ndarray, shape (n,)
        The minimiser.
    objectives : ndarray, shape (K,)
        ``‖A_i x − b_i‖²`` for each objective.
    weights : ndarray, shape (K,)
        The weights λ_i.
    objective : float
        ``Σ λ_i ‖A_i x − b_i‖²``.
    """

    x: np.ndarray
    objectives: np.ndarray
    weights: np.ndarray
    objective: float

    def __repr__(self) -> str:
        return (f"MultiObjectiveResult(objective={self.objective:.6g}, "
                f"objectives={_fmt(self.objectives)}, x={_fmt(self.x)})")


def multi_objective_lstsq(As, bs, weights) -> MultiObjectiveResult:
    r"""Weighted sum of least-squares objectives (stacked, solved by QR).

    .. math::

        \min_x \sum_{i=1}^{K} \lambda_i \|A_i x - b_i\|^2 =
        \left\| \begin{bmatrix} \sqrt{\lambda_1} A_1 \\ \vdots \\
        \sqrt{\lambda_K} A_K \end{bmatrix} x -
        \begin{bmatrix} \sqrt{\lambda_1} b_1 \\ \vdots \\
        \sqrt{\lambda_K} b_K \end{bmatrix} \right\|^2 .

    With the objectives ``(A, b)`` and ``(C, d)`` and a large weight on the
    second, this is the penalty view of the constrained problem in the
    reference: as λ → ∞ its solution tends to that of
    :func:`constrained_lstsq` (Boyd & Vandenberghe (2018), §15.1 and §16.1).

    Parameters
    ----------
    As : sequence of array_like, each of shape (m_i, n)
        Objective matrices (same number of columns).
    bs : sequence of array_like, each of shape (m_i,)
        Targets.
    weights : array_like, shape (K,)
        Non-negative weights λ_i (at least one positive).

    Returns
    -------
    MultiObjectiveResult
        ``.x``, ``.objectives`` (each ``‖A_i x − b_i‖²``), ``.objective``.

    Raises
    ------
    ValueError
        On mismatched lengths or shapes, negative or non-finite weights, or
        when the weighted stacked matrix lacks full column rank.
    """
    if isinstance(As, np.ndarray) and As.ndim == 2:
        raise param_error("As", "a sequence of 2-D arrays (one per objective)",
                          "<a single 2-D array; wrap it in a list>", exc=TypeError)
    try:
        As = list(As)
        bs = list(bs)
    except TypeError:
        raise param_error("As", "a sequence of 2-D arrays", As, exc=TypeError) from None
    w = as_float_array(weights, "weights", ndim=1)
    K = len(As)
    if K == 0:
        raise param_error("As", "a non-empty sequence", As)
    if len(bs) != K:
        raise param_error("bs", f"a sequence of {K} arrays (one per entry of As)",
                          f"<{len(bs)} arrays>")
    if w.shape[0] != K:
        raise param_error("weights", f"of shape ({K},) (one per entry of As)",
                          f"<shape {w.shape}>")
    if np.any(w < 0) or not np.any(w > 0):
        raise param_error("weights", "non-negative with at least one positive entry", w)
    mats, rhs, checked = [], [], []
    n = None
    for i, (Ai, bi) in enumerate(zip(As, bs)):
        Ai = as_float_array(Ai, f"As[{i}]", ndim=2)
        if n is None:
            n = Ai.shape[1]
            if n == 0:
                raise param_error(f"As[{i}]", "a matrix with at least one column", Ai)
        elif Ai.shape[1] != n:
            raise param_error(f"As[{i}]", f"of shape (*, {n}) (as As[0])", f"<shape {Ai.shape}>")
        bi = as_float_array(bi, f"bs[{i}]", shape=(Ai.shape[0],))
        checked.append((Ai, bi))
        mats.append(np.sqrt(w[i]) * Ai)
        rhs.append(np.sqrt(w[i]) * bi)
    M = np.vstack(mats)
    v = np.concatenate(rhs)
    if M.shape[0] < n:
        raise param_error("As", f"stacked to at least n = {n} rows", f"<{M.shape[0]} rows>")
    Q, R, piv = sla.qr(M, mode="economic", pivoting=True)
    rank = numerical_rank(R, M.shape)
    if rank < n:
        raise param_error("As", "such that the weighted stack has full column rank",
                          f"<rank {rank} < {n}>")
    x = np.empty(n)
    x[piv] = sla.solve_triangular(R, Q.T @ v)
    objs = np.empty(K)
    for i, (Ai, bi) in enumerate(checked):
        ri = Ai @ x - bi
        objs[i] = ri @ ri
    return MultiObjectiveResult(x=x, objectives=objs, weights=w.copy(),
                                objective=float(w @ objs))
