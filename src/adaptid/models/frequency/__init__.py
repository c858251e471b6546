r"""Frequency-domain models: responses with their uncertainty and nonparametric estimates.

* :class:`FrequencyResponse` — a frequency response (complex, per output
  and input) with the standard deviations of its magnitude and phase and
  an optional noise spectrum; ``summary()``, ``to_frame()``, ``plot()``
  (Bode with confidence bands). Returned by the polynomial models'
  ``freqresp`` and by the estimators below.
* :func:`spa` — Blackman–Tukey spectral analysis with a Hann lag window
  (MATLAB's ``spa``);
* :func:`etfe` — the empirical transfer-function estimate Y(ω)/U(ω),
  optionally smoothed (MATLAB's ``etfe``);
* :func:`spafdr` — spectral analysis with frequency-dependent resolution
  (MATLAB's ``spafdr``);
* :func:`tfest` — transfer-function estimation (Levy, Sanathanan–Koerner,
  nonlinear least squares) returning a :class:`TransferFunctionModel`;
* :class:`FrequencyCompareResult` — :func:`adaptid.models.compare` of models
  with a measured frequency response (fit per channel, Bode overlay);
* :class:`StepResponse` and :class:`Roots` — the polynomial models'
  ``step_response()``, ``poles()`` and ``zeros()`` with standard deviations.
"""

from __future__ import annotations

from ._compare import FrequencyCompareResult
from ._response import FrequencyResponse, default_grid
from ._roots import Roots
from ._spafdr import spafdr
from ._spectral import etfe, spa
from ._step import StepResponse
from ._tfest import TransferFunctionModel, tfest

__all__ = ["FrequencyResponse", "spa", "etfe", "default_grid", "StepResponse", "Roots",
           "tfest", "TransferFunctionModel", "spafdr", "FrequencyCompareResult"]
