"""Layer 2: the recursive estimators on one engine, their results, state files, factory.

* :class:`RLS`, :class:`SlidingWindowRLS`, :class:`KalmanRLS`, :class:`LMS`,
  :class:`NLMS` — algorithms
  on the engine :class:`RecursiveEstimator` (update / run / run_batched /
  run_segments / predict / state files, written once);
* :func:`estimator` — the one map from a method name to an estimator;
* :func:`recursive_fit_stats` — the one rule for σ̂² and standard errors;
* :class:`Trajectory`, :class:`SegmentResult`, :class:`WindowStats` — results of the runs;
* :func:`load_state` / :func:`save_state` — the safe state-file container.
"""

from ._engine import RecursiveEstimator
from ._factory import METHODS, estimator, method_of, method_options
from ._kalman import KalmanRLS
from ._lms import LMS, NLMS
from ._rls import RLS
from ._segments import SegmentResult
from ._settings import KernelSettings
from ._sizes import size_generic_kernels
from ._statefile import load_state, register_state_class, save_state
from ._stats import RecursiveFitStats, recursive_fit_stats, sample_factors
from ._trajectory import Trajectory
from ._window import SlidingWindowRLS
from ._windowstats import WindowStats

for _cls in (RLS, SlidingWindowRLS, KalmanRLS, LMS, NLMS):
    register_state_class(_cls.__name__, _cls)
del _cls

__all__ = ["RLS", "SlidingWindowRLS", "KalmanRLS", "LMS", "NLMS", "RecursiveEstimator", "Trajectory",
           "SegmentResult", "estimator", "METHODS", "method_of", "method_options",
           "recursive_fit_stats", "RecursiveFitStats", "sample_factors", "KernelSettings",
           "load_state", "save_state", "register_state_class", "size_generic_kernels",
           "WindowStats"]
