"""Exception and warning classes of :mod:`adaptid.constrained`."""

from __future__ import annotations

from .._exceptions import AdaptidWarning

__all__ = ["InfeasibleError", "IllConditionedWarning"]


class InfeasibleError(ValueError):
    """The constraints of a least-squares problem have no feasible point.

    Raised for inconsistent equality constraints (``d`` not in the range of
    ``C``), for ``lb > ub`` and when the QP solver certifies that the
    inequality constraints cannot be met. Subclasses :class:`ValueError`,
    and its message names the arguments involved.
    """


class IllConditionedWarning(AdaptidWarning):
    """A solution route squares the condition number of the problem.

    Emitted by ``constrained_lstsq(..., method="kkt")`` (which forms the Gram
    matrix ``AᵀA`` as in the reference) when the condition number of
    ``[A; C]`` is so large that the Gram route is expected to lose more than
    half of the significant digits; ``method="qr"`` does not lose them.
    """
