"""Diagnostics of identified models: parameter constancy and residual tests.

* :func:`recursive_residuals` — Brown–Durbin–Evans recursive residuals,
  one compiled QR-updating pass;
* :func:`cusum`, :func:`cusum_squares` — tests of parameter (and variance)
  constancy on them, with significance bounds (:class:`CusumResult`);
* :func:`autocorrelation_test` — residual whiteness (autocorrelation with
  its band, Ljung–Box statistic);
* :func:`cross_correlation_test` — input–residual cross-correlation with
  its band;
* :func:`fit_percent` — normalised fit of a simulated output.
"""

from ._cusum import CusumResult, cusum, cusum_squares
from ._metrics import fit_percent
from ._recursive import recursive_residuals
from ._whiteness import (
    AutocorrelationResult,
    CrossCorrelationResult,
    autocorrelation_test,
    cross_correlation_test,
)

__all__ = [
    "recursive_residuals",
    "cusum",
    "cusum_squares",
    "CusumResult",
    "autocorrelation_test",
    "AutocorrelationResult",
    "cross_correlation_test",
    "CrossCorrelationResult",
    "fit_percent",
]
