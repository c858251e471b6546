"""Layer 2: the recursive estimators on one engine, their results, state files, factory.

* :class:`RLS`, :class:`SlidingWindowRLS`, :class:`KalmanRLS`, :class:`LMS`,
  :class:`NLMS` — algorithms, each declared by an ``AlgorithmSpec``
  (:mod:`._spec`) on the one engine (:mod:`._engine`: update / run /
  run_batched / run_segments / predict / state files, written once);
* :func:`estimator` — the one map from a method name to an estimator;
* :func:`recursive_fit_stats` — the one rule for σ̂² and standard errors;
* :class:`Trajectory`, :class:`SegmentResult`, :class:`WindowStats`,
  :class:`RecursiveFitStats`, :class:`KernelSettings` — results;
* :func:`load_state` / :func:`save_state` — the safe state-file container;
* :func:`size_generic_kernels` — build estimators on the size-generic kernels.

Only these names are public. The engine and its parts, the factory's tables
(``METHODS``, ``method_of``, ``method_options`` in :mod:`._factory`) and the
state-class registry (:func:`._statefile.register_state_class`) are imported
from their private modules by the layers above.
"""

from ._factory import estimator
from ._fastrls import FastRLS
from ._kalman import KalmanRLS
from ._lms import LMS, NLMS
from ._rls import RLS
from ._segments import SegmentResult
from ._settings import KernelSettings
from ._sizes import size_generic_kernels
from ._statefile import load_state, register_state_class as _register, save_state
from ._stats import RecursiveFitStats, recursive_fit_stats
from ._trajectory import Trajectory
from ._window import SlidingWindowRLS
from ._windowstats import WindowStats

for _cls in (RLS, SlidingWindowRLS, KalmanRLS, LMS, NLMS, FastRLS):
    _register(_cls.__name__, _cls)
del _cls

__all__ = ["RLS", "SlidingWindowRLS", "KalmanRLS", "LMS", "NLMS", "Trajectory", "SegmentResult",
           "WindowStats", "estimator", "recursive_fit_stats", "RecursiveFitStats",
           "KernelSettings", "load_state", "save_state", "size_generic_kernels",
           "FastRLS"]  # FastRLS: issue 38
