r"""Nyblom–Hansen score test of parameter (and variance) constancy."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validation import param_error
from ._pvalues import pvalue_efp
from ._format import frame, htest_text, short_repr
from ._sc_common import ols, regression_data

__all__ = ["NyblomHansenResult", "nyblom_hansen"]


@dataclass(frozen=True, eq=False)
class NyblomHansenResult:
    """``statistic`` (Hansen's L_c), ``pvalue``, ``process`` (N+1, n+1) and ``break_index``."""

    statistic: float
    pvalue: float
    process: np.ndarray

    def __repr__(self) -> str:
        return short_repr("NyblomHansenResult", statistic=self.statistic, pvalue=self.pvalue,
                          break_index=self.break_index)

    def summary(self) -> str:
        """The test as strucchange's ``print(sctest(..., type = "Nyblom-Hansen"))`` prints it."""
        return htest_text("Nyblom-Hansen test", "X, y", [("L", self.statistic)], self.pvalue,
                          [f"break index (0-based): {self.break_index}"])

    def to_frame(self):
        """One row: ``test``, ``statistic``, ``pvalue``, ``break_index``."""
        return frame([("nyblom", self.statistic, self.pvalue, self.break_index)],
                     ("test", "statistic", "pvalue", "break_index"))

    @property
    def break_index(self) -> int:
        """0-based sample where the squared norm of the score process peaks."""
        return int(np.argmax(np.sum(self.process ** 2, axis=1))) - 1


def nyblom_hansen(X, y):
    r"""Nyblom (1989) – Hansen (1992) test of constant coefficients and variance.

    Parameters
    ----------
    X : array_like, shape (N, n)
        Regressors (1-D: one column).
    y : array_like, shape (N,)
        Observations.

    Returns
    -------
    NyblomHansenResult
        ``statistic``, ``pvalue`` (strucchange's table of the mean squared
        L2 norm of an (n+1)-dimensional Brownian bridge, clamped to
        [0.005, 1] as strucchange), ``process``.

    Notes
    -----
    With OLS residuals :math:`e_t`, :math:`\hat\sigma^2 = \frac1N\sum e_t^2`
    and the scores :math:`f_t = (x_t e_t,\ e_t^2 - \hat\sigma^2)`
    (n + 1 of them), partial sums :math:`S_t = \sum_{i\le t} f_i` and
    :math:`V = \sum_t f_t f_t^T`,

    .. math::

        L_c = \frac1N \sum_{t=1}^N S_t^T V^{-1} S_t

    (Hansen 1992, eq. 9; strucchange's ``sctest(type = "Nyblom-Hansen")``,
    i.e. the Score-CUSUM process with the mean-L2 functional; statsmodels'
    ``breaks_hansen``). :math:`V^{-1/2}` is applied through the
    eigen-decomposition of V.

    References
    ----------
    .. [1] J. Nyblom, "Testing for the constancy of parameters over time",
       J. Am. Statist. Assoc. 84(405):223–230, 1989.
    .. [2] B. E. Hansen, "Testing for parameter instability in linear
       models", J. Policy Modeling 14(4):517–533, 1992.

    Examples
    --------
    >>> import numpy as np
    >>> from adaptid.diagnostics import nyblom_hansen
    >>> rng = np.random.default_rng(0)
    >>> x = rng.standard_normal(300)
    >>> y = np.where(np.arange(300) < 150, 1.0, 2.0) * x + 0.5 * rng.standard_normal(300)
    >>> bool(nyblom_hansen(np.column_stack([np.ones(300), x]), y).pvalue < 0.01)
    True
    """
    X, y = regression_data(X, y)
    N, n = X.shape
    _, e = ols(X, y)
    s2 = np.sum(e * e) / N
    f = np.column_stack([X * e[:, None], e * e - s2]) / np.sqrt(N)
    lam, V = np.linalg.eigh(f.T @ f)
    if lam[0] <= lam[-1] * 1e-14:
        raise param_error("y", "not fitted exactly (the scores are degenerate)",
                          "<a singular score covariance>")
    S = np.vstack([np.zeros((1, n + 1)), np.cumsum(f, axis=0)])
    proc = (S @ V) / np.sqrt(lam) @ V.T                 # S V^{-1/2}, V^{-1/2} symmetric
    stat = float(np.mean(np.sum(proc[1:] ** 2, axis=1)))
    p = pvalue_efp(stat, "Brownian bridge", k=n + 1, functional="meanL2")
    return NyblomHansenResult(statistic=stat, pvalue=p, process=proc)
