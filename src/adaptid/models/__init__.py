r"""Model structures: regressor builders and input–output model objects.

Regressor builders (each returns a :class:`Regression` — Φ, y, column
names and the sample index of every row — ready for :func:`adaptid.lstsq`
or any recursive estimator's ``run``):

* :func:`arx_regressors` — ARX (na, nb, nk; several inputs);
* :func:`fir_regressors` — finite impulse response;
* :func:`trend_regressors` — polynomial trend 1, τ, …, τʳ (scaled time);
* :func:`exponential_regressors` — sums of exponentials with given rates;
* :func:`dc_motor_regressors` — DC-motor physics (electrical and mechanical
  equations, :class:`DCMotorRegressors`);
* :func:`table_regressors` — from a pandas DataFrame: columns, lags,
  products, ``sign()``.

Model objects (fit / fit_recursive / predict / simulate / fit_percent /
aic / fpe / cov / to_control):

* :class:`ARX` — least squares;
* :class:`ARMAX` — extended least squares (recursive: RELS), optional
  prediction-error refinement;
* :class:`OE` — pseudo-linear regression (recursive: RPLR), Steiglitz–McBride;
* :class:`BJ` — Box–Jenkins: prediction errors from a Steiglitz–McBride /
  Hannan–Rissanen start (recursive: pseudo-linear regression);
* :class:`MIMOARX` — several outputs and inputs (``ARX`` with order
  matrices, subpackage :mod:`adaptid.models.mimo`);
* :class:`AR`, :class:`ARMA` — time series (least squares; Hannan–Rissanen
  and prediction errors; recursive: RLS / RELS).

Nonlinear models linear in the parameters (subpackage :mod:`adaptid.models.nonlinear`):

* :class:`NARX` — polynomial NARX, terms selected by FROLS (error reduction
  ratio) and an information criterion;
* :func:`stlsq`, :class:`SINDy` — sparse regression of dynamics (SINDy);
* :class:`RecursiveNARX` — a selected NARX structure re-estimated sample by sample.

The workflow on a measured record (:class:`IDData`, MATLAB's ``iddata``):
:func:`select_order` (``arxstruc``/``selstruc``), :func:`compare` (fit %),
:func:`resid` (residual tests), ``model.summary()`` /
:func:`model_summary`, :func:`recursive_summary`.

State-space models (subpackage :mod:`adaptid.models.statespace`):
:func:`n4sid` (subspace identification: N4SID, MOESP, CVA), :func:`era`
(eigensystem realisation from Markov parameters), :func:`okid`
(observer/Kalman filter identification), all returning a
:class:`StateSpaceModel`.

Regularised estimation (subpackage :mod:`adaptid.models.regularised`):
:func:`impulseest` (FIR with TC, DC, SS, SE, HF or DI kernels, hyperparameters by
marginal likelihood), :func:`arx_regul` (regularised ARX),
:func:`kernel_matrix`. Instrumental variables (subpackage
:mod:`adaptid.models.iv`): :func:`iv4` (Ljung's four-stage method),
:func:`ivx` (given instruments), :class:`RecursiveIV` (recursive, with
instruments from an auxiliary model; :class:`RecursiveIVResult`). All
return (or give, ``to_model()``) :class:`ARX` objects.

Closed-loop identification (subpackage :mod:`adaptid.models.closedloop`):
:func:`checkfeedback` (a test for feedback, :class:`FeedbackResult`),
:func:`indirect` (known controller), :func:`two_stage` (projection method).

Frequency domain (subpackage :mod:`adaptid.models.frequency`):
:class:`FrequencyResponse` (Bode with confidence bands; returned by every
polynomial model's ``freqresp``), :func:`spa` (Blackman–Tukey spectral
analysis), :func:`etfe` (empirical transfer-function estimate),
:func:`spafdr` (spectral analysis with frequency-dependent resolution),
:func:`tfest` (transfer-function estimation, a :class:`TransferFunctionModel`),
:class:`StepResponse` and :class:`Roots` (the polynomial models'
``step_response``, ``poles`` and ``zeros`` with standard deviations).

Streaming model objects (subpackage :mod:`adaptid.models.streaming`,
MATLAB's ``recursiveARX``/``recursiveAR``/…): :class:`RecursiveARX`,
:class:`RecursiveAR`, :class:`RecursiveARMAX`, :class:`RecursiveARMA`,
:class:`RecursiveOE`, :class:`RecursiveBJ` — ``step(y, u)`` one sample at
a time, ``run`` a record in one compiled pass (:class:`StreamResult`),
state files.
"""

from __future__ import annotations

import importlib

from ._ar import AR, ARMA
from ._armax import ARMAX
from ._arx import ARX
from ._builders import (
    arx_regressors,
    exponential_regressors,
    fir_regressors,
    trend_regressors,
)
from ._bj import BJ
from ._iddata import IDData
from ._oe import OE
from ._polymodel import NotFittedError
from ._regression import Regression
from ._summary import model_summary, recursive_summary
from ._table import table_regressors
from .statespace import StateSpaceModel, era, n4sid, okid
from .nonlinear import NARX, RecursiveNARX, SINDy, stlsq
from .regularised import arx_regul, impulseest, kernel_matrix
from .iv import RecursiveIV, RecursiveIVResult, iv4, ivx
from .closedloop import FeedbackResult, checkfeedback, indirect, two_stage
from .mimo import MIMOARX
from .frequency import (FrequencyCompareResult, FrequencyResponse, Roots, StepResponse,
                        TransferFunctionModel, etfe, spa, spafdr, tfest)
from ._workflow import CompareResult, ResidResult, compare, resid
from ._selection import OrderSelection, select_order
from .streaming import (RecursiveAR, RecursiveARMA, RecursiveARMAX, RecursiveARX, RecursiveBJ,
                        RecursiveOE, StreamResult)

# The DC-motor builder lives in its own module, loaded on first use.
_LAZY = {
    "dc_motor_regressors": "adaptid.models._dcmotor",
    "DCMotorRegressors": "adaptid.models._dcmotor",
}

__all__ = [
    "IDData",
    "Regression",
    "arx_regressors",
    "fir_regressors",
    "trend_regressors",
    "exponential_regressors",
    "table_regressors",
    "dc_motor_regressors",
    "DCMotorRegressors",
    "ARX",
    "ARMAX",
    "OE",
    "AR",
    "ARMA",
    "BJ",
    "NARX",
    "stlsq",
    "SINDy",
    "NotFittedError",
    "compare",
    "resid",
    "select_order",
    "CompareResult",
    "ResidResult",
    "OrderSelection",
    "model_summary",
    "recursive_summary",
    "StateSpaceModel",
    "n4sid",
    "era",
    "okid",
    "impulseest",
    "arx_regul",
    "kernel_matrix",
    "iv4",
    "ivx",
    "FrequencyResponse",
    "spa",
    "etfe",
    "tfest",
    "TransferFunctionModel",
    "StepResponse",
    "Roots",
    "RecursiveARX",
    "RecursiveAR",
    "StreamResult",
    "RecursiveIV",
    "RecursiveIVResult",
    "checkfeedback",
    "FeedbackResult",
    "indirect",
    "two_stage",
    "MIMOARX",
    "RecursiveNARX",
    "spafdr",
    "FrequencyCompareResult",
    "RecursiveARMAX",
    "RecursiveARMA",
    "RecursiveOE",
    "RecursiveBJ",
]


def __getattr__(name: str):
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'adaptid.models' has no attribute {name!r}")


def __dir__():
    return sorted(set(__all__) | set(globals()))
