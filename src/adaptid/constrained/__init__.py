r"""Constrained least squares and its control applications.

Boyd & Vandenberghe (2018), *Introduction to Applied Linear Algebra*,
ch. 16 (the problem and its piecewise-polynomial example, the KKT
equations, eq. 16.4, and their solution by QR, §16.3) and ch. 17 (linear
quadratic control and state estimation):

* :func:`constrained_lstsq` — ``min ‖Ax − b‖²`` s.t. ``Cx = d`` (exact, by
  QR or by the KKT system), plus ``Gx ≤ h`` and bounds (QP solver Clarabel
  with an exact active-set polish);
* :func:`multi_objective_lstsq` — weighted sum of objectives (the penalty
  view of a constraint);
* :func:`piecewise_polyfit` — piecewise polynomials with continuity of the
  derivatives 0..c at the knots;
* :func:`lq_control`, :func:`open_loop` — finite-horizon linear quadratic
  control;
* :func:`lq_estimate`, :func:`lq_estimate_cv` — linear quadratic state
  estimation, with λ chosen by cross-validation;
* :class:`ConstrainedRLS` — recursive least squares subject to ``Cθ = d``.

Why Clarabel for the inequality-constrained problems
----------------------------------------------------
The problems here are small to medium and dense. We need a maintained solver
that (1) reaches tight tolerances reliably, so that the active set can be
read off and the solution polished exactly; (2) certifies infeasibility
instead of returning a wrong point; (3) does not need ``AᵀA``. Clarabel (a
primal–dual interior-point method with a homogeneous embedding; Rust core,
Apache-2.0, actively maintained, cvxpy's default solver) meets all three:
it converges to 1e-10 in a few more iterations than its 1e-8 default,
returns primal/dual infeasibility certificates, and accepts the problem in
the form ``min ‖r‖²`` s.t. ``Ax − r = b`` whose Hessian is ``diag(0, 2I)``.
Alternatives considered: OSQP (ADMM, first order: 1e-3–1e-6 accuracy, needs
its own polish); ``scipy.optimize`` (``lsq_linear`` handles bounds only,
``SLSQP`` / ``trust-constr`` are general NLP methods without infeasibility
certificates); quadprog (dual active set, needs ``AᵀA`` positive definite;
not maintained, not installed).
"""

from .._exceptions import IllConditionedWarning, InfeasibleError
from ._cls import CLSResult, MultiObjectiveResult, constrained_lstsq, multi_objective_lstsq
from ._lq import (
    LQControlResult,
    LQCVResult,
    LQEstimateResult,
    OpenLoopResult,
    lq_control,
    lq_estimate,
    lq_estimate_cv,
    open_loop,
)
from ._piecewise import PiecewisePolynomial, piecewise_polyfit
from ._rls import ConstrainedRLS

__all__ = [
    "CLSResult",
    "ConstrainedRLS",
    "IllConditionedWarning",
    "InfeasibleError",
    "LQCVResult",
    "LQControlResult",
    "LQEstimateResult",
    "MultiObjectiveResult",
    "OpenLoopResult",
    "PiecewisePolynomial",
    "constrained_lstsq",
    "lq_control",
    "lq_estimate",
    "lq_estimate_cv",
    "multi_objective_lstsq",
    "open_loop",
    "piecewise_polyfit",
]


def _register():
    from ..estimators._statefile import register_state_class
    register_state_class("ConstrainedRLS", ConstrainedRLS)


_register()
