r"""Inequality-constrained least squares: Clarabel, then an exact polish.

Problem (validated arrays, one right-hand side):

.. math::

    \min_x \|Ax - b\|^2 \quad\text{s.t.}\quad Cx = d,\; Gx \le h

(bounds arrive here already as rows of ``G``). Steps:

1. If ``A`` is tall, replace it by the ``R`` of its thin QR and ``b`` by
   ``Q₁ᵀb`` (same minimiser, same multipliers, ``n`` rows instead of ``m``).
2. Clarabel solves the equivalent QP in ``(x, r)``: minimise ``‖r‖²``
   subject to ``Ax − r = b``, ``Cx = d``, ``Gx ≤ h``. The Hessian is
   ``diag(0, 2I)``: the Gram matrix ``AᵀA`` is never formed, so its squared
   condition number never reaches the solver. The objective is scaled to
   unit size and every constraint row to unit norm for the call (the
   multipliers are scaled back).
3. Polish: the active set read from the interior-point solution defines an
   equality-constrained problem, solved exactly by the QR method of
   :mod:`._linalg`; its solution is accepted when it is primal feasible and
   its inequality multipliers are non-negative (KKT conditions to rounding
   level). Otherwise the working set is corrected one constraint at a time
   (drop the most negative multiplier or add the most violated constraint)
   for a bounded number of rounds; if that fails the Clarabel solution is
   returned (``polished=False``).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from ._linalg import EPS, RankProblem, cls_qr

#: Tolerances handed to Clarabel (gap and feasibility). Its defaults are
#: 1e-8; 1e-10 is reached in a couple more iterations and leaves the active
#: set unambiguous for the polish.
CLARABEL_TOL = 1e-10
#: Relative tolerance of the polish's acceptance test (primal violation per
#: row scale, negative multiplier per stationarity scale).
POLISH_TOL = 1e-9


def _import_clarabel():
    try:
        import clarabel
    except ImportError as err:  # pragma: no cover - clarabel is installed in CI
        raise ImportError(
            "inequality constraints and bounds need the optional dependency "
            "'clarabel'; install it with: pip install 'adaptid[qp]'") from err
    return clarabel


class QPStatusError(Exception):
    """Internal: Clarabel ended with ``status`` (a string)."""

    def __init__(self, status: str):
        super().__init__(status)
        self.status = status


def _independent_rows(C: np.ndarray, Gw: np.ndarray) -> np.ndarray:
    """Indices of a maximal subset of rows of ``Gw`` independent of each other and of ``C``."""
    if Gw.shape[0] == 0:
        return np.zeros(0, dtype=np.intp)
    Gp = Gw
    if C.shape[0]:
        Qc, _ = sla.qr(C.T, mode="economic")
        Gp = Gw - (Gw @ Qc) @ Qc.T
    _, R, piv = sla.qr(Gp.T, mode="economic", pivoting=True)
    scale = np.max(np.linalg.norm(Gw, axis=1))
    diag = np.abs(np.diag(R))
    keep = diag > 1e3 * max(Gw.shape) * EPS * scale
    return np.sort(piv[: R.shape[0]][keep[: R.shape[0]]])


def _row_scale(M):
    r = np.linalg.norm(M, axis=1)
    return np.where(r > 0, r, 1.0)


def _clarabel_solve(A, b, C, d, G, h):
    """Clarabel on the scaled problem; multipliers returned in the original scaling.

    The objective is divided by ``s² = max(‖A‖_F, ‖b‖)²`` and every
    constraint row normalised to unit length before the call: Clarabel's
    own equilibration does not cope with, e.g., ``A`` of norm 1e6 against a
    box of width 1e-3 (it then reports a feasible problem infeasible).
    """
    clarabel = _import_clarabel()
    mr, n = A.shape
    p, k = C.shape[0], G.shape[0]
    s = max(np.linalg.norm(A), np.linalg.norm(b), np.finfo(float).tiny)
    rc, rg = _row_scale(C), _row_scale(G)
    A, b = A / s, b / s
    C, d = C / rc[:, None], d / rc
    G, h = G / rg[:, None], h / rg
    P = sp.block_diag([sp.csc_matrix((n, n)), 2.0 * sp.identity(mr)], format="csc")
    rows = [sp.hstack([sp.csc_matrix(A), -sp.identity(mr)])]
    if p:
        rows.append(sp.hstack([sp.csc_matrix(C), sp.csc_matrix((p, mr))]))
    if k:
        rows.append(sp.hstack([sp.csc_matrix(G), sp.csc_matrix((k, mr))]))
    Acon = sp.vstack(rows, format="csc")
    bcon = np.concatenate([b, d, h])
    cones = [clarabel.ZeroConeT(mr + p)]
    if k:
        cones.append(clarabel.NonnegativeConeT(k))
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.tol_gap_abs = settings.tol_gap_rel = CLARABEL_TOL
    settings.tol_feas = settings.tol_ktratio = CLARABEL_TOL
    settings.max_iter = 500
    sol = clarabel.DefaultSolver(sp.triu(P, format="csc"), np.zeros(n + mr),
                                 Acon, bcon, cones, settings).solve()
    status = str(sol.status).split(".")[-1]
    if status not in ("Solved", "AlmostSolved"):
        raise QPStatusError(status)
    zz = np.asarray(sol.z, dtype=float)
    x = np.asarray(sol.x, dtype=float)[:n]
    z = zz[mr:mr + p] * s**2 / rc
    mu = zz[mr + p:] * s**2 / rg
    return x, z, mu, status, int(sol.iterations)


def solve_qp(A, b, C, d, G, h):
    """Solve the inequality-constrained problem; return a dict of results.

    Keys: ``x`` (n,), ``z`` (p,), ``mu`` (k,) ≥ 0, ``active`` (k,) bool,
    ``polished`` bool, ``status`` str, ``iterations`` int. Raises
    :class:`QPStatusError` if Clarabel reports anything but (almost) solved,
    and :class:`RankProblem` if the minimiser is not unique.
    """
    m, n = A.shape
    p, k = C.shape[0], G.shape[0]
    # Uniqueness and consistency of the equality part (raises RankProblem).
    cls_qr(A, np.zeros((m, 1)), C, d[:, None])
    if m > n:
        Qa, Ra = sla.qr(A, mode="economic")
        Ac, bc = Ra, Qa.T @ b
    else:
        Ac, bc = A, b
    x0, z0, mu0, status, iters = _clarabel_solve(Ac, bc, C, d, G, h)
    mu0 = np.maximum(mu0, 0.0)

    row_norm = np.linalg.norm(G, axis=1)
    row_norm = np.where(row_norm > 0, row_norm, 1.0)
    a_norm = np.linalg.norm(Ac)

    def scales(x):
        # slack scale per row and stationarity scale (gradient of ‖Ax − b‖²)
        s_scale = row_norm * np.max(np.abs(x), initial=0.0) + np.abs(h)
        s_scale = np.maximum(s_scale, np.finfo(float).tiny)
        g_scale = 2.0 * a_norm * (a_norm * np.linalg.norm(x) + np.linalg.norm(bc))
        return s_scale, max(g_scale, np.finfo(float).tiny)

    s_scale, g_scale = scales(x0)
    # Scales are floored at the smallest normal number; with A = 0 (constant
    # objective) a ratio may overflow to inf, which still compares correctly.
    with np.errstate(over="ignore", divide="ignore"):
        working = mu0 * row_norm / g_scale > (h - G @ x0) / s_scale
        best = None
        for _ in range(2 * k + 5):
            Gw_idx = np.flatnonzero(working)
            keep = Gw_idx[_independent_rows(C, G[Gw_idx])]
            try:
                xs, zs = cls_qr(Ac, bc[:, None], np.vstack([C, G[keep]]),
                                np.concatenate([d, h[keep]])[:, None])
            except RankProblem:
                break
            x, zall = xs[:, 0], zs[:, 0]
            mu = np.zeros(k)
            mu[keep] = zall[p:]
            s_scale, g_scale = scales(x)
            viol = (G @ x - h) / s_scale
            viol[keep] = -np.inf
            neg = np.full(k, -np.inf)
            neg[keep] = -mu[keep] * row_norm[keep] / g_scale
            worst_v = np.max(viol, initial=-np.inf)
            worst_n = np.max(neg, initial=-np.inf)
            if worst_v <= POLISH_TOL and worst_n <= POLISH_TOL:
                best = (x, zall[:p], np.maximum(mu, 0.0), working.copy())
                break
            if worst_n >= worst_v:
                working[np.argmax(neg)] = False
            else:
                working[np.argmax(viol)] = True
    if best is not None:
        x, z, mu, active = best
        return dict(x=x, z=z, mu=mu, active=active, polished=True,
                    status=status, iterations=iters)
    s_scale, _ = scales(x0)
    active = (h - G @ x0) / s_scale <= 1e3 * CLARABEL_TOL
    return dict(x=x0, z=z0, mu=mu0, active=active, polished=False,
                status=status, iterations=iters)
