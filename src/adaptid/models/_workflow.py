r"""The identification workflow on a record: compare, resid, select_order."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .._teststats import fit_percent
from .._validation import check_int, check_scalar, param_error
from ._iddata import as_record
from ._segments import pooled_cross_correlation, pooled_ljung_box, record_runs

__all__ = ["compare", "resid", "CompareResult", "ResidResult"]


def _as_iddata(data, name="data", u=None):
    """The record: :func:`adaptid.models._iddata.as_record` (the one input convention)."""
    return as_record(data, u, where=name)


def _is_model(obj):
    return hasattr(obj, "predict")


def _split_models(data, models):
    """``f(data, *models)`` or ``f(y, u, *models)``: the record and the models."""
    if models and isinstance(models[0], (str, bytes)):
        # a model's name ("ARX") is neither an input signal nor a model
        raise param_error("models", "fitted models (with predict), not their names",
                          models[0], exc=TypeError)
    if models and not _is_model(models[0]):
        data, models = _as_iddata(data, "data", models[0]), models[1:]
    else:
        data = _as_iddata(data)
    for i, m in enumerate(models):
        if not _is_model(m):
            raise param_error(f"models[{i}]", "a fitted model (with predict)", m,
                              exc=TypeError)
    return data, models


def _single_output(data, name="data"):
    if data.n_outputs != 1:
        raise param_error(name, "a record with one output", f"<{data.n_outputs} outputs>")
    if not np.nanmax(data.y) > np.nanmin(data.y):       # NaN: gaps
        raise param_error(name, "a record whose output is not constant", "<a constant output>")


# --------------------------------------------------------------------- compare
@dataclass(frozen=True, eq=False)
class CompareResult:
    r"""Result of :func:`compare`.

    Attributes
    ----------
    fit : ndarray, shape (n_models,)
        NRMSE fit in percent, one per model.
    names : tuple of str
        The models' labels (``repr`` of the model unless ``names`` was given).
    y_hat : list of ndarray, shape (N,)
        Each model's simulated (``k=None``) or k-step predicted output.
    y : ndarray, shape (N,)
        The measured output.
    time : ndarray, shape (N,)
    k : int or None
    y_name : str
    fit_experiments : ndarray, shape (n_models, n_experiments)
        The fit of each model on each experiment of a merged record (one
        column for one experiment). The outputs restart from zero initial
        conditions at each experiment and after each NaN gap (NaN in the
        gap, left out of the fit).
    """

    fit: np.ndarray
    names: tuple
    y_hat: list
    y: np.ndarray
    time: np.ndarray
    k: int | None
    y_name: str
    figure: object = field(default=None, repr=False)
    fit_experiments: np.ndarray = field(default=None, repr=False)

    def plot(self, *, ax=None, fig=None):
        """The figure (:func:`adaptid.plot.compare`)."""
        from ..estimators._hooks import upward
        figure = upward("adaptid.plot").compare  # drawing lives in layer 7

        return figure(self, ax=ax, fig=fig)

    def __repr__(self):
        body = ", ".join(f"{n}: {f:.2f} %" for n, f in zip(self.names, self.fit))
        what = "simulation" if self.k is None else f"{self.k}-step prediction"
        return f"CompareResult({what}; {body})"


def compare(data, *models, k=None, ax=None, names=None):
    r"""Fit of models to a record: MATLAB's ``compare``.

    For each model, the simulated output (``k=None``) or the k-step-ahead
    prediction from the measured input and output, with zero initial
    conditions (a :class:`~adaptid.models.NARX` simulation starts from the
    first L measured outputs), and its normalised fit

    .. math::

        \mathrm{fit} = 100\left(1 - \frac{\lVert y - \hat y\rVert_2}{\lVert y - \bar y\rVert_2}\right)

    in percent (MATLAB's NRMSE definition; 100 is a perfect model, 0 the
    mean of y).

    With a measured :class:`~adaptid.models.FrequencyResponse` as ``data``
    (from :func:`~adaptid.models.spa`, :func:`~adaptid.models.etfe`,
    :func:`~adaptid.models.spafdr` or arrays), each model's ``freqresp`` at
    the data's frequencies is compared with it: the fit is the same NRMSE
    applied to the complex response over the finite frequencies,
    :math:`100(1 - \lVert G - \hat G\rVert/\lVert G - \bar G\rVert)`, one per
    channel, and the result (a
    :class:`~adaptid.models.frequency.FrequencyCompareResult`) plots the
    Bode (or Nyquist) diagram of the data with its bands and the models.
    A merged record (:meth:`IDData.merge`) is simulated or predicted
    experiment by experiment, and a record with NaN samples run by run
    between the gaps, each from zero initial conditions; the fit is then
    over all measured samples, and ``fit_experiments`` gives it per
    experiment.

    Parameters
    ----------
    data : IDData, (y, u) tuple, DataFrame (output column first), Series or FrequencyResponse
        The record to compare on (usually the validation part). Arrays may
        also come as two arguments, ``compare(y, u, *models)`` (the one
        input convention of the models' ``fit``). A FrequencyResponse
        compares responses (then ``k`` and ``ax`` must be None; the models
        need the data's ``dt``).
    *models : fitted models
        Anything with ``simulate(u)`` and ``predict(y, u, k)``.
    k : int, optional
        Prediction horizon ≥ 1; None (default) compares simulations.
    ax : matplotlib Axes, optional
        If given, the figure (:func:`adaptid.plot.compare`) is drawn into
        it; otherwise no figure is drawn (``result.plot()`` draws one).
    names : sequence of str, optional
        Labels of the models in the result and the legend.

    Returns
    -------
    CompareResult, tuple of CompareResult, or FrequencyCompareResult
        ``fit`` (one value per model), the outputs and ``figure`` when drawn.
        A record with several outputs (MIMO models, whose ``simulate`` and
        ``predict`` return (N, ny)) gives one result per output, in order
        (:func:`adaptid.models.mimo._workflow.compare_outputs`; ``ax`` must
        then be None). For frequency-response data: ``fit``, ``responses``
        and ``plot()``.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import lfilter
    >>> from adaptid import IDData
    >>> from adaptid.models import ARX, compare
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal(500)
    >>> y = lfilter([0, 1.0], [1, -0.8], u) + 0.05 * rng.standard_normal(500)
    >>> est, val = IDData(y, u).split(0.5)
    >>> res = compare(val, ARX(1, 1, 1).fit(est))
    >>> bool(res.fit[0] > 90)
    True
    """
    from .frequency._response import FrequencyResponse

    if isinstance(data, FrequencyResponse):           # issue 36: a Bode comparison
        from .frequency._compare import compare_frequency

        for name, value in (("k", k), ("ax", ax)):
            if value is not None:
                raise param_error(name, "None with frequency-response data "
                                  "(draw with result.plot(fig=...))", value)
        return compare_frequency(data, models, names=names)
    data, models = _split_models(data, models)
    if not models:
        raise param_error("models", "at least one fitted model", "<none>", exc=TypeError)
    if k is not None:
        k = check_int(k, "k", low=1)
    if names is None:
        names = tuple(repr(m).split(" [")[0] for m in models)
    else:
        names = tuple(str(v) for v in names)
        if len(names) != len(models):
            raise param_error("names", f"{len(models)} labels", f"<{len(names)} labels>")
    if data.n_outputs > 1:      # one result per output (MIMO models: adaptid.models.mimo)
        from .mimo._workflow import compare_outputs

        if ax is not None:
            raise param_error("ax", "None for a record with several outputs (draw each result "
                              "with its plot())", "<axes>")
        return tuple(CompareResult(names=names, time=np.asarray(data.t), k=k, **r)
                     for r in compare_outputs(data, models, k=k))
    _single_output(data)
    y, u = data.y, data.u
    runs = record_runs(data)         # each experiment, split at NaN gaps: outputs restart
    outs = []
    for m in models:
        yh = np.full(len(data), np.nan)
        for a, b in runs:
            yh[a:b] = _compare_one(m, y[a:b], None if u is None else u[a:b], k)
        outs.append(yh)
    fit, per = _fits(y, outs, data.bounds)
    res = CompareResult(fit=fit, names=names, y_hat=outs, y=y, time=np.asarray(data.t), k=k,
                        y_name=data.y_names[0], fit_experiments=per)
    if ax is not None:
        object.__setattr__(res, "figure", res.plot(ax=ax))
    return res


def _compare_one(m, y, u, k):
    """One model's output on one experiment (or run between gaps)."""
    if k is not None:
        yh = m.predict(y, u, k=k)
    elif getattr(m, "_simulate_needs_y0", False):  # NARX: starts from the measured outputs
        yh = m.simulate(u, y0=y)
    else:
        yh = m.simulate(u)
    return np.asarray(yh, dtype=np.float64).reshape(-1)


def _fits(y, outs, bounds):
    """fit % of each output on the samples both measured and predicted; and per experiment."""
    def fit(a, b, yh):
        ok = np.isfinite(y[a:b]) & np.isfinite(yh[a:b])
        return fit_percent(y[a:b][ok], yh[a:b][ok]) if ok.sum() > 1 else float("nan")

    total = np.array([fit(0, y.size, yh) for yh in outs])
    per = np.array([[fit(a, b, yh) for a, b in zip(bounds[:-1], bounds[1:])] for yh in outs])
    return total, per


# ----------------------------------------------------------------------- resid
@dataclass(frozen=True, eq=False)
class ResidResult:
    r"""Result of :func:`resid`.

    Attributes
    ----------
    e : ndarray, shape (N - start,)
        One-step prediction errors on the record from sample ``start`` on
        (for a merged record or one with NaN gaps: of each experiment and
        each run between gaps from its sample ``start`` on, concatenated).
    start : int
        The first sample tested (the predictor's lags before it lie
        outside the record).
    autocorrelation : dict
        ``acf`` (M + 1,), ``band``, ``q_stat`` (Ljung–Box), ``dof``, ``p_value``.
    cross_correlation : list of dict
        Per input: ``lags`` (−M … M), ``ccf``, ``band``, ``q_stat``, ``dof``, ``p_value``.
    alpha : float
    y_name : str
    u_names : tuple of str
    """

    e: np.ndarray
    start: int
    autocorrelation: dict
    cross_correlation: list
    alpha: float
    y_name: str
    u_names: tuple
    figure: object = field(default=None, repr=False)

    @property
    def white(self) -> bool:
        """The Ljung–Box test does not reject whiteness at ``alpha``."""
        return bool(self.autocorrelation["p_value"] > self.alpha)

    @property
    def independent(self) -> tuple:
        """Per input: the cross-correlation test does not reject independence at ``alpha``."""
        return tuple(bool(c["p_value"] > self.alpha) for c in self.cross_correlation)

    @property
    def acf_outside(self) -> np.ndarray:
        """Lags 1 … M whose autocorrelation lies outside the band (bool, shape (M,))."""
        ac = self.autocorrelation
        return np.abs(ac["acf"][1:]) > ac["band"]

    def plot(self, *, ax=None, fig=None):
        """The figure (:func:`adaptid.plot.resid`)."""
        from ..estimators._hooks import upward
        figure = upward("adaptid.plot").resid  # drawing lives in layer 7

        return figure(self, ax=ax, fig=fig)

    def __repr__(self):
        ind = ", ".join(f"{n}: p={c['p_value']:.3g}" for n, c in zip(self.u_names, self.cross_correlation))
        return (f"ResidResult(Ljung-Box p={self.autocorrelation['p_value']:.3g} "
                f"(white={self.white}); cross-correlation {ind}; alpha={self.alpha})")


def resid(data, *models, max_lag=25, alpha=0.01, ax=None, start=None):
    r"""Residual analysis on a record: MATLAB's ``resid``.

    The one-step prediction errors :math:`\varepsilon_k = y_k - \hat y_{k|k-1}`
    of ``model`` on ``data`` (zero initial conditions; the first ``start``
    samples, whose predictions need samples before the record, are left
    out), their normalised
    autocorrelation at lags 0 … M with the Ljung–Box test, and for each
    input the cross-correlation :math:`r_{\varepsilon u}(\tau)`, τ = −M … M,
    with the portmanteau test over τ = 0 … M; bands
    :math:`\pm z_{1-\alpha/2}/\sqrt N` (the formulas of
    :func:`adaptid.diagnostics.autocorrelation_test` and
    :func:`~adaptid.diagnostics.cross_correlation_test`; Ljung 1999, sec. 16.6).
    MATLAB's ``resid`` draws a 99 % band, hence ``alpha=0.01``.

    A merged record (:meth:`IDData.merge`) is predicted experiment by
    experiment, and a record with NaN samples run by run between the gaps,
    each from zero initial conditions with its first ``start`` errors left
    out; the correlations sum the products inside each piece only (none
    across a boundary) over the pooled variance, with N the total number
    of errors.

    Parameters
    ----------
    data : IDData, (y, u) tuple, DataFrame (output column first) or Series
        Arrays may also come as two arguments, ``resid(y, u, *models)``
        (the one input convention of the models' ``fit``).
    *models : fitted models
        One or more, each with ``predict(y, u, k)`` (as :func:`compare`).
    max_lag : int
        M, 1 ≤ M < N (default 25, as MATLAB).
    alpha : float
        Level of the bands and tests (default 0.01).
    ax : sequence of 1 + m matplotlib Axes, optional
        If given, the figure (:func:`adaptid.plot.resid`) is drawn into them.
        Only with one model.
    start : int, optional
        First sample tested; default each model's first fitted row
        ``model.index[0]`` (max(na, nk + nb − 1) for ARX), 0 if the model
        has no ``index``.

    Returns
    -------
    ResidResult or tuple of ResidResult
        For one model, its :class:`ResidResult` (the numbers, the verdicts
        ``white`` and ``independent``, and ``figure`` when drawn); for
        several, a tuple of one :class:`ResidResult` per model, in order.
        A record with several outputs gives, per model, a tuple of one
        result per output (:func:`adaptid.models.mimo._workflow.resid_outputs`).
    """
    data, models = _split_models(data, models)
    if not models:
        raise param_error("models", "at least one fitted model", "<none>", exc=TypeError)
    if len(models) > 1:
        if ax is not None:
            raise param_error("ax", "None when several models are analysed (draw each "
                              "result with its plot())", "<axes>")
        return tuple(_resid_one(data, m, max_lag=max_lag, alpha=alpha, ax=None, start=start)
                     for m in models)
    return _resid_one(data, models[0], max_lag=max_lag, alpha=alpha, ax=ax, start=start)


def _resid_one(data, model, *, max_lag, alpha, ax, start):
    if data.n_outputs > 1:      # one result per output (MIMO models: adaptid.models.mimo)
        from .mimo._workflow import resid_outputs

        if ax is not None:
            raise param_error("ax", "None for a record with several outputs (draw each result "
                              "with its plot())", "<axes>")
        return tuple(ResidResult(**r) for r in resid_outputs(data, model, max_lag=max_lag,
                                                             alpha=alpha, start=start))
    _single_output(data)
    alpha = check_scalar(alpha, "alpha", low=0.0, high=1.0, low_open=True, high_open=True)
    if start is None:
        idx = getattr(model, "index", None)
        start = int(np.asarray(idx)[0]) if idx is not None and np.size(idx) else 0
    start = check_int(start, "start", low=0, high=len(data) - 3)
    y, u = data.y, data.u
    # each experiment (and run between NaN gaps) from zero initial conditions, its first
    # `start` errors left out; the tests pool the pieces without a product across two
    pieces = [(a, b) for a, b in record_runs(data) if b - a > start]
    e_parts = []
    for a, b in pieces:
        yh = model.predict(y[a:b], None if u is None else u[a:b], k=1)
        e_parts.append((y[a:b] - np.asarray(yh, dtype=np.float64).reshape(-1))[start:])
    e = np.concatenate(e_parts) if e_parts else np.zeros(0)
    N = e.size
    max_lag = check_int(max_lag, "max_lag", low=1, high=max(N - 1, 1))
    if not np.ptp(e) > 0:
        raise param_error("model", "a model whose residuals on data are not constant",
                          "<constant residuals>")
    ac = pooled_ljung_box(e_parts, max_lag, alpha)
    U_parts = [data.inputs[a + start:b] for a, b in pieces]
    U = np.concatenate(U_parts) if U_parts else data.inputs[:0]
    cc = [pooled_cross_correlation([p[:, j] for p in U_parts], e_parts, max_lag, alpha)
          for j in range(data.n_inputs) if np.ptp(U[:, j]) > 0]
    res = ResidResult(e=e, start=start, autocorrelation=ac, cross_correlation=cc, alpha=alpha,
                      y_name=data.y_names[0],
                      u_names=tuple(n for j, n in enumerate(data.u_names) if np.ptp(U[:, j]) > 0))
    if ax is not None:
        object.__setattr__(res, "figure", res.plot(ax=ax))
    return res


# ----------------------------------------------------------------- select_order
