"""Warning classes of adaptid.

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
    "StateFileError",
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


class StateFileError(ValueError):
    """A state file is truncated, corrupted, of the wrong type or version.

    Subclasses :class:`ValueError`.
    """
