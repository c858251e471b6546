r"""Residual whiteness and input–residual independence tests."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._teststats import cross_correlation, ljung_box
from .._validation import as_float_array, check_int, check_scalar, param_error
from ._format import frame, htest_text

__all__ = [
    "AutocorrelationResult",
    "CrossCorrelationResult",
    "autocorrelation_test",
    "cross_correlation_test",
]


@dataclass(frozen=True, eq=False)
class AutocorrelationResult:
    r"""Result of :func:`autocorrelation_test`.

    Attributes
    ----------
    lags : ndarray of int, shape (M + 1,)
        0 … M.
    acf : ndarray, shape (M + 1,)
        Normalised autocorrelation :math:`r(\tau)`, ``acf[0] == 1``.
    band : float
        Half-width of the confidence band of :math:`r(\tau)`, τ ≥ 1, under
        whiteness: :math:`z_{1-\alpha/2}/\sqrt N`.
    outside : ndarray of bool, shape (M + 1,)
        ``|acf| > band`` (False at lag 0).
    q_stat : float
        Ljung–Box statistic over lags 1 … M.
    dof : int
        Its degrees of freedom, M − ``ddof``.
    p_value : float
        :math:`P(\chi^2_{dof} > Q)`.
    alpha : float
        Level of the band and of ``white``.
    """

    lags: np.ndarray
    acf: np.ndarray
    band: float
    outside: np.ndarray
    q_stat: float
    dof: int
    p_value: float
    alpha: float

    @property
    def white(self) -> bool:
        """True if the Ljung–Box test does not reject whiteness at ``alpha``."""
        return bool(self.p_value > self.alpha)

    def __repr__(self) -> str:
        return (f"AutocorrelationResult(max_lag={self.lags[-1]}, q_stat={self.q_stat:.4g}, "
                f"dof={self.dof}, p_value={self.p_value:.4g}, white={self.white})")

    def summary(self) -> str:
        """The test as R's ``print(Box.test(e, lag, type = "Ljung-Box"))`` prints it."""
        return htest_text("Box-Ljung test", "residuals", [("X-squared", self.q_stat), ("df", self.dof)],
                          self.p_value, [f"white at alpha = {self.alpha:g}: {self.white}"])

    def to_frame(self):
        """One row: ``test``, ``statistic``, ``dof``, ``pvalue``, ``white``."""
        return frame([("ljung-box", self.q_stat, self.dof, self.p_value, self.white)],
                     ("test", "statistic", "dof", "pvalue", "white"))


@dataclass(frozen=True, eq=False)
class CrossCorrelationResult:
    r"""Result of :func:`cross_correlation_test`.

    Attributes
    ----------
    lags : ndarray of int, shape (2M + 1,)
        −M … M.
    ccf : ndarray, shape (2M + 1,)
        Normalised cross-correlation :math:`r_{\varepsilon u}(\tau)` of the
        residual with the input τ samples earlier.
    band : float
        Half-width of the confidence band, :math:`z_{1-\alpha/2}/\sqrt N`.
    outside : ndarray of bool, shape (2M + 1,)
        ``|ccf| > band``.
    q_stat : float
        :math:`N\sum_{\tau=0}^{M} r_{\varepsilon u}(\tau)^2` (lags ≥ 0).
    dof : int
        Its degrees of freedom, M + 1 − ``ddof``.
    p_value : float
        :math:`P(\chi^2_{dof} > Q)`.
    alpha : float
        Level of the band and of ``independent``.
    """

    lags: np.ndarray
    ccf: np.ndarray
    band: float
    outside: np.ndarray
    q_stat: float
    dof: int
    p_value: float
    alpha: float

    @property
    def independent(self) -> bool:
        """True if the portmanteau test does not reject independence at ``alpha``."""
        return bool(self.p_value > self.alpha)

    def __repr__(self) -> str:
        return (f"CrossCorrelationResult(max_lag={self.lags[-1]}, q_stat={self.q_stat:.4g}, "
                f"dof={self.dof}, p_value={self.p_value:.4g}, independent={self.independent})")

    def summary(self) -> str:
        """The portmanteau test of residual–input independence in the layout of ``print.htest``."""
        return htest_text("Cross-correlation test of residuals and input", "residuals, input",
                          [("X-squared", self.q_stat), ("df", self.dof)], self.p_value,
                          [f"independent at alpha = {self.alpha:g}: {self.independent}"])

    def to_frame(self):
        """One row: ``test``, ``statistic``, ``dof``, ``pvalue``, ``independent``."""
        return frame([("cross-correlation", self.q_stat, self.dof, self.p_value, self.independent)],
                     ("test", "statistic", "dof", "pvalue", "independent"))


def _centred(x, name):
    x = as_float_array(x, name, ndim=1)
    xc = x - x.mean()
    ss = float(xc @ xc)
    if not ss > 0.0:
        raise param_error(name, "not constant", "<a constant signal>")
    return xc, ss


def _check_common(N, max_lag, alpha, ddof, n_lags_in_test):
    max_lag = check_int(max_lag, "max_lag", low=1, high=N - 1)
    alpha = check_scalar(alpha, "alpha", low=0.0, high=1.0, low_open=True, high_open=True)
    ddof = check_int(ddof, "ddof", low=0, high=n_lags_in_test(max_lag) - 1)
    return max_lag, alpha, ddof


def autocorrelation_test(e, max_lag=25, alpha=0.05, *, ddof=0):
    r"""Whiteness test of residuals: autocorrelation, band and Ljung–Box.

    Parameters
    ----------
    e : array_like, shape (N,)
        Residuals (prediction errors), finite, not constant.
    max_lag : int, optional
        Largest lag M, 1 ≤ M < N. Default 25 (as MATLAB's ``resid``).
    alpha : float, optional
        Level of the band and of the test, in (0, 1). Default 0.05.
    ddof : int, optional
        Parameters estimated from ``e``'s own past (e.g. p + q of an ARMA
        noise model) to subtract from the degrees of freedom. Default 0.

    Returns
    -------
    AutocorrelationResult
        ``acf``, ``band``, ``outside``, ``q_stat``, ``dof``, ``p_value``
        and ``white``.

    Notes
    -----
    With :math:`\tilde e = e - \bar e`,

    .. math::

        r(\tau) = \frac{\sum_{t=\tau+1}^{N} \tilde e_t \tilde e_{t-\tau}}
                       {\sum_{t=1}^{N} \tilde e_t^2}, \qquad
        Q = N(N+2)\sum_{\tau=1}^{M}\frac{r(\tau)^2}{N-\tau}
        \sim \chi^2_{M - \mathrm{ddof}},

    (Box & Jenkins; Ljung & Box 1978). Under whiteness
    :math:`\sqrt N\,r(\tau) \to N(0, 1)` for τ ≥ 1, so about a fraction α
    of the lags lie outside :math:`\pm z_{1-\alpha/2}/\sqrt N` by chance;
    the decision ``white`` uses the portmanteau p-value instead. Equal to
    ``statsmodels.tsa.stattools.acf(e, nlags=M, adjusted=False)`` and
    ``acorr_ljungbox(e, lags=[M], model_df=ddof)``.

    References
    ----------
    .. [1] G. M. Ljung, G. E. P. Box, "On a measure of lack of fit in time
       series models", Biometrika 65(2):297–303, 1978.
    .. [2] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
       1999, §16.6.

    Examples
    --------
    >>> import numpy as np
    >>> from adaptid.diagnostics import autocorrelation_test
    >>> e = np.random.default_rng(1).standard_normal(1000)
    >>> autocorrelation_test(e).white
    True
    """
    ec, _ = _centred(e, "e")
    N = ec.size
    max_lag, alpha, ddof = _check_common(N, max_lag, alpha, ddof, lambda M: M)
    r = ljung_box(ec, max_lag, alpha, ddof)   # the one formula, shared with adaptid.models
    outside = np.abs(r["acf"]) > r["band"]
    outside[0] = False
    return AutocorrelationResult(lags=np.arange(max_lag + 1), acf=r["acf"], band=r["band"],
                                 outside=outside, q_stat=r["q_stat"], dof=r["dof"],
                                 p_value=r["p_value"], alpha=alpha)


def cross_correlation_test(u, e, max_lag=25, alpha=0.05, *, ddof=0):
    r"""Independence test of residuals from an input: cross-correlation.

    Parameters
    ----------
    u : array_like, shape (N,)
        Input, finite, not constant.
    e : array_like, shape (N,)
        Residuals, finite, not constant.
    max_lag : int, optional
        Largest lag M, 1 ≤ M < N. Default 25.
    alpha : float, optional
        Level of the band and of the test, in (0, 1). Default 0.05.
    ddof : int, optional
        Number of estimated input-dynamics parameters to subtract from the
        degrees of freedom (Box & Jenkins' r + s + 1). Default 0.

    Returns
    -------
    CrossCorrelationResult
        ``ccf`` over lags −M … M, ``band``, ``outside``, ``q_stat``,
        ``dof``, ``p_value`` and ``independent``.

    Notes
    -----
    With centred signals,

    .. math::

        r_{\varepsilon u}(\tau) = \frac{\sum_t \tilde e_t\,\tilde u_{t-\tau}}
            {\sqrt{\sum_t \tilde e_t^2\,\sum_t \tilde u_t^2}},
        \qquad -M \le \tau \le M,

    the sum over the t for which both samples exist. τ > 0 pairs the
    residual with *past* inputs: correlation there means input dynamics
    left unmodelled; correlation at τ < 0 indicates feedback from the
    output to the input (expected in closed loop). If the residual is
    white and independent of u, :math:`\sqrt N\,r_{\varepsilon u}(\tau)
    \to N(0, 1)` whatever the colour of u (Ljung 1999, §16.6), hence the
    band :math:`\pm z_{1-\alpha/2}/\sqrt N` and the portmanteau
    :math:`Q = N\sum_{\tau=0}^{M} r_{\varepsilon u}(\tau)^2 \sim
    \chi^2_{M+1-\mathrm{ddof}}` (Box & Jenkins 1976, §11.3). If the
    residual is coloured the band is too narrow: test whiteness first.

    References
    ----------
    .. [1] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
       1999, §16.6.
    .. [2] G. E. P. Box, G. M. Jenkins, *Time Series Analysis: Forecasting
       and Control*, revised ed., 1976, §11.3.

    Examples
    --------
    >>> import numpy as np
    >>> from adaptid.diagnostics import cross_correlation_test
    >>> rng = np.random.default_rng(2)
    >>> u = rng.standard_normal(2000)
    >>> e = 0.5 * np.roll(u, 3) + rng.standard_normal(2000)   # unmodelled delay-3 path
    >>> res = cross_correlation_test(u, e, max_lag=10)
    >>> int(res.lags[np.argmax(np.abs(res.ccf))]), res.independent
    (3, False)
    """
    uc, _ = _centred(u, "u")
    ec, _ = _centred(e, "e")
    N = ec.size
    if uc.size != N:
        raise param_error("u", f"of the same length as e ({N})", f"<length {uc.size}>")
    max_lag, alpha, ddof = _check_common(N, max_lag, alpha, ddof, lambda M: M + 1)
    r = cross_correlation(uc, ec, max_lag, alpha, ddof)   # shared with adaptid.models
    return CrossCorrelationResult(lags=r["lags"], ccf=r["ccf"], band=r["band"],
                                  outside=np.abs(r["ccf"]) > r["band"], q_stat=r["q_stat"],
                                  dof=r["dof"], p_value=r["p_value"], alpha=alpha)
