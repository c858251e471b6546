r"""Dense kernels of the equality-constrained least-squares solvers.

Everything here takes validated float64 arrays with two-dimensional
right-hand sides and raises :class:`RankProblem` (an internal exception) when
the problem has no unique solution; the public functions translate it into a
``ValueError`` that names *their* arguments.

Problem: minimise :math:`\|Ax - b\|^2` subject to :math:`Cx = d`. It has a
unique solution exactly when ``C`` has full row rank and ``[A; C]`` has full
column rank (Boyd & Vandenberghe (2018), §16.1).
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg as sla

from .._exceptions import IllConditionedWarning

EPS = np.finfo(np.float64).eps

#: ``method="kkt"`` warns when the estimated condition number of ``[A; C]``
#: exceeds this value: squared by the Gram matrix, it would leave fewer than
#: half of the ~16 significant digits (cond² · eps > √eps).
KKT_WARN_COND = EPS ** -0.25


class RankProblem(Exception):
    """Internal: the problem has no unique solution.

    ``kind`` is ``"stacked"`` ([A; C] lacks full column rank), ``"redundant"``
    (C lacks full row rank but Cx = d is consistent) or ``"inconsistent"``
    (Cx = d has no solution).
    """

    def __init__(self, kind: str, rank: int, full: int):
        super().__init__(kind, rank, full)
        self.kind = kind
        self.rank = rank
        self.full = full


def numerical_rank(R: np.ndarray, shape) -> int:
    """Rank read from the diagonal of a column-pivoted QR factor ``R``.

    The tolerance is NumPy's ``matrix_rank`` default, ``max(shape) · eps ·
    |R₁₁|``, with ``|R₁₁|`` standing in for the largest singular value.
    """
    diag = np.abs(np.diag(R))
    if diag.size == 0 or diag[0] == 0.0:
        return 0
    tol = max(shape) * EPS * diag[0]
    return int(np.count_nonzero(diag > tol))


def _diagnose_constraints(C: np.ndarray, d: np.ndarray) -> None:
    """Raise :class:`RankProblem` for a rank-deficient or inconsistent ``C``."""
    p = C.shape[0]
    s = sla.svdvals(C)
    tol = max(C.shape) * EPS * (s[0] if s.size else 0.0)
    rank = int(np.count_nonzero(s > tol))
    if rank == p:
        # Full rank by the SVD but not by the pivoted QR of Q₂ᵀ: numerically
        # dependent rows all the same.
        raise RankProblem("redundant", rank, p)
    sol, *_ = sla.lstsq(C, d, cond=tol / s[0] if s.size and s[0] > 0 else None)
    resid = np.abs(C @ sol - d)
    scale = np.abs(C) @ np.abs(sol) + np.abs(d)
    # The minimum-norm solution reproduces a consistent d to rounding level.
    if np.any(resid > 1e3 * max(C.shape) * EPS * np.maximum(scale, np.finfo(float).tiny)):
        raise RankProblem("inconsistent", rank, p)
    raise RankProblem("redundant", rank, p)


class EqualityFactors:
    """QR factors of ``[A; C]`` and of ``Q₂ᵀ`` (the ``cls_solve`` of the reference).

    ``[A/s; D⁻¹C] Π = Q R``, ``Q = [Q₁; Q₂]`` (m and p rows),
    ``Q₂ᵀ Π₂ = Q̃ R̃``. The objective is scaled by ``s = ‖A‖_F`` and each
    constraint row by its norm (``D``) first: the solution is unchanged, the
    multipliers are scaled back, and the reference's step ``z = w + 2d``
    then no longer cancels catastrophically when ``‖A‖²`` is small or large
    compared with ``‖C‖``. Construction checks that the solution is unique
    and raises :class:`RankProblem` otherwise.
    """

    def __init__(self, A: np.ndarray, C: np.ndarray, d: np.ndarray | None = None):
        m, n = A.shape
        p = C.shape[0]
        self.m, self.n, self.p = m, n, p
        if m + p < n:
            raise RankProblem("stacked", m + p, n)
        s = np.linalg.norm(A)
        self.s = s if s > 0 else 1.0
        rc = np.linalg.norm(C, axis=1)
        self.rc = np.where(rc > 0, rc, 1.0)
        M = np.vstack([A / self.s, C / self.rc[:, None]]) if p else A / self.s
        Q, R, piv = sla.qr(M, mode="economic", pivoting=True)
        rank = numerical_rank(R, M.shape)
        if p and (rank < n or p > n):
            # Report a constraint problem first: it is the more specific one.
            dd = np.zeros((p, 1)) if d is None else d
            if p > n:
                _diagnose_constraints(C, dd)
            sv = sla.svdvals(C)
            if int(np.count_nonzero(sv > max(C.shape) * EPS * sv[0])) < p:
                _diagnose_constraints(C, dd)
        if rank < n:
            raise RankProblem("stacked", rank, n)
        self.Q1 = Q[:m]
        self.R = R
        self.piv = piv
        diag = np.abs(np.diag(R))
        self.cond_estimate = float(diag[0] / diag[-1])
        if p:
            Q2 = Q[m:]
            Qt, Rt, piv2 = sla.qr(Q2.T, mode="economic", pivoting=True)
            if numerical_rank(Rt, Q2.shape) < p:
                _diagnose_constraints(C, np.zeros((p, 1)) if d is None else d)
            self.Qt, self.Rt, self.piv2 = Qt, Rt, piv2

    def solve(self, b: np.ndarray, d: np.ndarray):
        """Solution ``x`` (n, k) and multipliers ``z`` (p, k) for right-hand sides."""
        n, p = self.n, self.p
        Q1b = self.Q1.T @ (b / self.s)
        x = np.empty((n, b.shape[1]))
        if not p:
            x[self.piv] = sla.solve_triangular(self.R, Q1b)
            return x, np.zeros((0, b.shape[1]))
        Qt, Rt, piv2 = self.Qt, self.Rt, self.piv2
        ds = d / self.rc[:, None]
        dp = ds[piv2]
        # R̃ w = 2 Q̃ᵀ Q₁ᵀ b − 2 R̃⁻ᵀ d  (reference: cls_solve), in pivoted order
        w2 = sla.solve_triangular(
            Rt, 2.0 * (Qt.T @ Q1b) - 2.0 * sla.solve_triangular(Rt, dp, trans="T"))
        # R x = Q₁ᵀ b − Q₂ᵀ w / 2, with Q₂ᵀ w = Q̃ R̃ w₂
        x[self.piv] = sla.solve_triangular(self.R, Q1b - 0.5 * (Qt @ (Rt @ w2)))
        w = np.empty_like(w2)
        w[piv2] = w2
        # w = z − 2d (the reference adds 2CᵀCx = 2Cᵀd to the first KKT row);
        # undo the scaling: z = s² D⁻¹ z_scaled
        return x, (w + 2.0 * ds) * (self.s**2 / self.rc[:, None])


def cls_qr(A, b, C, d):
    """Equality-constrained least squares by QR (``b``, ``d`` two-dimensional)."""
    return EqualityFactors(A, C, d).solve(b, d)


def cls_kkt(A, b, C, d):
    """Equality-constrained least squares by the Gram KKT system of the reference.

    Solves ``[[2AᵀA, Cᵀ], [C, 0]] [x; z] = [2Aᵀb; d]`` with a symmetric
    indefinite (Bunch–Kaufman) factorisation. Forms ``AᵀA`` on purpose (it
    is the reference's method); the well-posedness checks are the QR ones.
    """
    factors = EqualityFactors(A, C, d)  # uniqueness checks only
    n, p = A.shape[1], C.shape[0]
    if factors.cond_estimate > KKT_WARN_COND:
        warnings.warn(
            f"method='kkt' forms AᵀA and squares the condition number of [A; C] "
            f"(about {factors.cond_estimate:.1e}); expect about "
            f"{min(factors.cond_estimate ** 2 * EPS, 1.0):.0e} relative error. "
            "Use method='qr'.", IllConditionedWarning, stacklevel=3)
    K = np.zeros((n + p, n + p))
    K[:n, :n] = 2.0 * (A.T @ A)
    K[:n, n:] = C.T
    K[n:, :n] = C
    rhs = np.vstack([2.0 * (A.T @ b), d])
    with warnings.catch_warnings():
        # Conditioning is reported above, under our own warning class.
        warnings.simplefilter("ignore", sla.LinAlgWarning)
        try:
            sol = sla.solve(K, rhs, assume_a="sym")
        except np.linalg.LinAlgError:
            raise RankProblem("stacked", n - 1, n) from None
    return sol[:n], sol[n:]
