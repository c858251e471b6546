"""Layer 2: the recursive estimators, their results, state files and factory.

Every estimator (``RLS``, ``SlidingWindowRLS``, ``KalmanRLS``) shares one
engine; :func:`estimator` maps a method name to one of them, and
:func:`recursive_fit_stats` is the one rule for σ̂² and standard errors of a
recursive fit.
"""

from .._estimators import KalmanRLS, RLS, SlidingWindowRLS
from .._trajectory import Trajectory
from ._factory import METHODS, estimator, method_of, method_options
from ._settings import KernelSettings
from ._stats import RecursiveFitStats, recursive_fit_stats, sample_factors

__all__ = ["RLS", "SlidingWindowRLS", "KalmanRLS", "Trajectory", "estimator", "METHODS",
           "method_of", "method_options", "recursive_fit_stats", "RecursiveFitStats",
           "sample_factors", "KernelSettings"]
