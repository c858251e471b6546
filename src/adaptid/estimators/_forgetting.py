"""The forgetting factor λ of the estimators that have one (RLS, the sliding window)."""

from __future__ import annotations

from .._validation import check_scalar, param_error

__all__ = ["ForgettingMixin"]


class ForgettingMixin:
    """Validation of forgetting (λ ∈ (0, 1], scalar or per sample).

    Replaces the engine's ``_lam_step`` / ``_lam_run`` (no forgetting factor) for
    an estimator with the attributes ``_lam`` (constant λ, or None under a
    strategy) and ``_strategy`` (a strategy of :mod:`adaptid.forgetting`, or None).
    """

    @staticmethod
    def _check_lambda(value, name="forgetting"):
        return check_scalar(value, name, low=0.0, high=1.0, low_open=True)

    def _lam_step(self, forgetting):
        if forgetting is None:
            return self._lam if self._lam is not None else 1.0
        self._no_strategy("forgetting")
        return self._check_lambda(forgetting)

    def _lam_run(self, forgetting, shape_N):
        if forgetting is None:
            forgetting = self._lam if self._lam is not None else 1.0
        else:
            self._no_strategy("forgetting")
        return self._per_sample(forgetting, "forgetting", shape_N, low=0.0, high=1.0, low_open=True)

    def _no_strategy(self, name):
        if getattr(self, "_strategy", None) is not None:
            raise param_error(name, f"None (per-sample λ needs exponential forgetting; this "
                              f"estimator uses {type(self._strategy).__name__})", "<a value>")
