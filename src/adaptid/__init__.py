"""adaptid — least-squares parameter identification.

Estimate θ in ``y[k] = θᵀ φ[k] + e[k]`` in one batch or sample by sample:

* :class:`RLS` — recursive least squares with prior (ridge) and forgetting;
* :class:`SlidingWindowRLS` — the truncated least squares method (TLSM);
* :class:`KalmanRLS` — Kalman filter for a random-walk parameter;
* :class:`LMS`, :class:`NLMS` — (normalised) least mean squares, stochastic gradient;
* :func:`lstsq` — batch (weighted, ridge) least squares by QR;
* :mod:`adaptid.constrained`, :mod:`adaptid.continuous`,
  :mod:`adaptid.models`, :mod:`adaptid.diagnostics`, :mod:`adaptid.datasets`,
  :mod:`adaptid.fleet` — the layers built on them.

Conventions (names, shapes, argument order) are in ``docs/conventions.md``.
"""

from __future__ import annotations

import importlib

from ._exceptions import (
    AdaptidWarning,
    CompilationCacheWarning,
    CovarianceWindupWarning,
    DefinitenessLossWarning,
    DivergenceWarning,
    ExcitationWarning,
    PrecisionWarning,
    StateFileError,
)

__version__ = "0.1.0"

# Public names are imported on first use, so that `import adaptid` stays cheap
# (numba, scipy and the optional extras load only when needed).
_LAZY = {
    "RLS": "adaptid.estimators",
    "SlidingWindowRLS": "adaptid.estimators",
    "KalmanRLS": "adaptid.estimators",
    "LMS": "adaptid.estimators",
    "NLMS": "adaptid.estimators",
    "FastRLS": "adaptid.estimators",  # issue 38
    "Trajectory": "adaptid.estimators",
    "WindowStats": "adaptid.estimators",
    "estimator": "adaptid.estimators",
    "recursive_fit_stats": "adaptid.estimators",
    "IDData": "adaptid.models",
    "lstsq": "adaptid._lstsq",
    "LSResult": "adaptid._lstsq",
    "constrained_lstsq": "adaptid.constrained",
    "piecewise_polyfit": "adaptid.constrained",
    "lq_control": "adaptid.constrained",
    "lq_estimate": "adaptid.constrained",
    "multi_objective_lstsq": "adaptid.constrained",
    "lq_estimate_cv": "adaptid.constrained",
    "ConstrainedRLS": "adaptid.constrained",
    "load_state": "adaptid.estimators",
    "recursive_residuals": "adaptid.diagnostics",
    "cusum": "adaptid.diagnostics",
    "cusum_squares": "adaptid.diagnostics",
}
_SUBMODULES = (
    "estimators", "forgetting", "constrained", "continuous", "models", "diagnostics",
    "datasets", "fleet", "sklearn", "io", "plot",
)

__all__ = [
    "AdaptidWarning",
    "CovarianceWindupWarning",
    "DefinitenessLossWarning",
    "DivergenceWarning",
    "ExcitationWarning",
    "StateFileError",
    "CompilationCacheWarning",
    "PrecisionWarning",
    "__version__",
    *_LAZY,
]


def __getattr__(name: str):
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    if name in _SUBMODULES:
        return importlib.import_module(f"adaptid.{name}")
    raise AttributeError(f"module 'adaptid' has no attribute {name!r}")


def __dir__():
    return sorted(set(__all__) | set(_SUBMODULES))
