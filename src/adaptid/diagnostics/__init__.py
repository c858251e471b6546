"""Diagnostics of identified models: parameter constancy and residual tests.

* :func:`recursive_residuals` — Brown–Durbin–Evans recursive residuals,
  one compiled QR-updating pass;
* :func:`cusum`, :func:`cusum_squares` — tests of parameter (and variance)
  constancy on them, with significance bounds (:class:`CusumResult`);
* :func:`autocorrelation_test` — residual whiteness (autocorrelation with
  its band, Ljung–Box statistic);
* :func:`cross_correlation_test` — input–residual cross-correlation with
  its band;
* :func:`fit_percent` — normalised fit of a simulated output;
* structural change (R strucchange parity): :func:`efp` (empirical
  fluctuation processes), :func:`fstats` and :func:`chow` (F tests for a
  break), :func:`nyblom_hansen`, :func:`breakpoints` (Bai–Perron dating),
  :class:`Monitor` (online monitoring), :func:`change_tests` (a battery
  with one verdict).
"""

from ._breakpoints import BreakConfidenceWarning, BreakpointsResult, breakpoints
from ._change import ChangeTest, ChangeTests, change_tests
from ._cusum import CusumResult, cusum, cusum_squares
from ._efp import EfpResult, efp
from ._fstats import ChowResult, FstatsResult, FTest, chow, fstats
from ._monitor import Monitor
from ._nyblom import NyblomHansenResult, nyblom_hansen
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
    "efp",
    "EfpResult",
    "fstats",
    "FstatsResult",
    "FTest",
    "chow",
    "ChowResult",
    "nyblom_hansen",
    "NyblomHansenResult",
    "breakpoints",
    "BreakpointsResult",
    "BreakConfidenceWarning",
    "Monitor",
    "change_tests",
    "ChangeTests",
    "ChangeTest",
]
