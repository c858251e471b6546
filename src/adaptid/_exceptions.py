"""Every exception and warning class of the library.

The command line's own exception, ``CLIError``, lives with the command line
(:mod:`adaptid.cli._errors`).

Numerical trouble is reported with warnings of our own, never a bare
``RuntimeWarning``, so that users can filter them precisely::

    import warnings, adaptid
    warnings.simplefilter("error", adaptid.CovarianceWindupWarning)
"""

__all__ = [
    "AdaptidWarning",
    "DefinitenessLossWarning",
    "CovarianceWindupWarning",
    "ExcitationWarning",
    "DivergenceWarning",
    "StateFileError",
    "InfeasibleError",
    "IllConditionedWarning",
    "DataFileError",
    "CompilationCacheWarning",
    "PrecisionWarning",
]


class AdaptidWarning(UserWarning):
    """Base class of every warning adaptid emits."""


class DefinitenessLossWarning(AdaptidWarning):
    """A covariance update would have lost positive definiteness.

    Emitted by :class:`~adaptid.SlidingWindowRLS` when removing the oldest
    sample from the window would make P indefinite in finite precision; the
    estimator then re-solves the window exactly from its buffer.
    """


class CovarianceWindupWarning(AdaptidWarning):
    """trace(P) grew past its threshold or the information matrix lost rank.

    Typical cause: forgetting (λ < 1) with a regressor direction that is not
    excited, so that P grows like λ⁻ᵏ in that direction ("covariance windup").
    """


class ExcitationWarning(AdaptidWarning):
    """The data do not excite every parameter direction."""


class DivergenceWarning(AdaptidWarning):
    """A gradient estimator's θ left the finite numbers (LMS/NLMS step too large).

    LMS is stable in the mean only for a step μ < 2/λ_max(E φφᵀ); NLMS for
    0 < μ < 2.
    """


class CompilationCacheWarning(AdaptidWarning):
    """Compiled kernels are not cached on disk in this environment.

    Emitted once, when the first kernel module is loaded, if no cache folder
    is both writable and safe (owned by the current user or root, not
    writable by group or others; see :mod:`adaptid._config`). adaptid then
    compiles its kernels in every new process (slower start, same results).
    """


class PrecisionWarning(AdaptidWarning):
    """A result lies outside the range float64 represents faithfully.

    Emitted when standard errors overflow to inf, or when the data are so
    small against the prior that an update cannot change the estimate.
    """


class StateFileError(ValueError):
    """A state file is truncated, corrupted, of the wrong type or version.

    Subclasses :class:`ValueError`.
    """


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


class DataFileError(ValueError):
    """A data table (:mod:`adaptid.io`) cannot be read or written as asked.

    The message is one line that names the file (and the column or row at
    fault). Subclasses :class:`ValueError`.
    """

    def __init__(self, message: str):
        super().__init__(" ".join(str(message).split()))
