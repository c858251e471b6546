r"""CUSUM and CUSUM-of-squares tests of parameter constancy."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validation import as_float_array, check_choice, check_scalar, param_error
from ._format import format_num, frame
from ._sc_common import new_axes, outside_legend

__all__ = ["CusumResult", "cusum", "cusum_squares"]

# Brown, Durbin & Evans (1975), p. 154: a = 0.850, 0.948, 1.143 for
# alpha = 0.10, 0.05, 0.01 (two-sided). Other levels solve their eq. for a.
_BDE_A = {0.10: 0.850, 0.05: 0.948, 0.01: 1.143}

# Edgerton & Wells (1994), response surface of the critical value c0 of the
# CUSUM-of-squares test, c0 = a1/sqrt(n') + a2/n' + a3/n'^(3/2) with
# n' = (T - k)/2 - 1; one column per one-sided level alpha/2. The same
# coefficients are used by statsmodels (recursive_ls._cusum_squares_scalars).
_EW_HALF_ALPHA = (0.1, 0.05, 0.025, 0.01, 0.005)
_EW_COEF = np.array([
    [1.072983, 1.2238734, 1.3581015, 1.5174271, 1.6276236],
    [-0.6698868, -0.6700069, -0.6701218, -0.6702672, -0.6703724],
    [-0.5816458, -0.7351697, -0.8858694, -1.0847745, -1.2365861],
])
_EW_ALPHA = tuple(2 * h for h in _EW_HALF_ALPHA)  # 0.2, 0.1, 0.05, 0.02, 0.01


@dataclass(frozen=True, eq=False)
class CusumResult:
    r"""Result of :func:`cusum` or :func:`cusum_squares`.

    Attributes
    ----------
    kind : str
        ``"cusum"`` or ``"cusum_squares"``.
    statistic : ndarray, shape (m,)
        The statistic at j = 1 … m (sample k = n + j of the regression).
    lower, upper : ndarray, shape (m,)
        Significance bounds at the same points.
    alpha : float
        Significance level of the (two-sided) test.
    critical_value : float
        BDE's *a* (CUSUM) or Edgerton–Wells' :math:`c_0` (CUSUM of squares).
    scale : float
        The :math:`\hat\sigma` that divides the CUSUM (``nan`` for the
        CUSUM of squares, which is scale free).
    crossings : ndarray of bool, shape (m,)
        Where the statistic lies outside the bounds.
    """

    kind: str
    statistic: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    alpha: float
    critical_value: float
    scale: float
    crossings: np.ndarray

    @property
    def crossed(self) -> bool:
        """True if the statistic leaves the band anywhere (constancy rejected)."""
        return bool(self.crossings.any())

    @property
    def first_crossing(self) -> int | None:
        """Index (0-based, into ``statistic`` and ``w``) of the first crossing, or None."""
        idx = np.flatnonzero(self.crossings)
        return int(idx[0]) if idx.size else None

    def __repr__(self) -> str:
        return (f"CusumResult(kind={self.kind!r}, m={self.statistic.size}, "
                f"alpha={self.alpha}, crossed={self.crossed}, "
                f"first_crossing={self.first_crossing})")

    def summary(self) -> str:
        """The test in the layout of R's ``print.htest``: bounds crossed or not, and where."""
        method = ("CUSUM test (Brown, Durbin & Evans)" if self.kind == "cusum"
                  else "CUSUM of squares test")
        where = "" if self.first_crossing is None else f", first crossing at j = {self.first_crossing}"
        return (f"\n\t{method}\n\ndata:  w (m = {self.statistic.size})\n"
                f"critical value = {format_num(self.critical_value)}, alpha = {self.alpha:g}, "
                f"crossed = {self.crossed}{where}\n")

    def to_frame(self):
        """One row: ``test``, ``critical_value``, ``alpha``, ``crossed``, ``first_crossing``."""
        return frame([(self.kind, self.critical_value, self.alpha, self.crossed, self.first_crossing)],
                     ("test", "critical_value", "alpha", "crossed", "first_crossing"))

    def plot(self, ax=None, *, x=None):
        """Plot the statistic and its band; returns the matplotlib Figure.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Where to draw (the Figure returned is ``ax.figure``); a new
            figure if omitted.
        x : array_like, shape (m,), optional
            Abscissa (e.g. sample numbers n+1 … N or times); 1 … m if omitted.
        """
        m = self.statistic.size
        xs = np.arange(1, m + 1) if x is None else as_float_array(x, "x", shape=(m,))
        ax = new_axes(ax)
        label = "CUSUM" if self.kind == "cusum" else "CUSUM of squares"
        band = f"{100 * (1 - self.alpha):g} % band"
        ax.plot(xs, self.statistic, label=label)
        ax.plot(xs, self.upper, "k--", lw=1, label=band)
        ax.plot(xs, self.lower, "k--", lw=1, label=band)
        ax.set_xlabel("sample" if x is None else "x")
        ax.set_ylabel(label)
        outside_legend(ax)
        return ax.figure


def _as_residuals(w, min_len: int) -> np.ndarray:
    w = as_float_array(w, "w", ndim=1)
    if w.size < min_len:
        raise param_error("w", f"at least {min_len} recursive residuals long",
                          f"<{w.size} values>")
    if not np.any(w):
        raise param_error("w", "not identically zero", "<all zeros>")
    return w


def _bde_critical_value(alpha: float) -> float:
    for level, a in _BDE_A.items():
        if alpha == level:
            return a
    from scipy.optimize import brentq
    from scipy.stats import norm

    # Brown, Durbin & Evans (1975), sec. 2.3: probability that a Brownian
    # motion crosses the line a + 2 a t, t in [0, 1], on one side.
    def excess(a):
        return norm.sf(3.0 * a) + np.exp(-4.0 * a * a) * norm.cdf(a) - alpha / 2.0

    return float(brentq(excess, 1e-12, 40.0, xtol=1e-14, rtol=1e-14))


def cusum(w, alpha=0.05, *, scale="std"):
    r"""CUSUM test of Brown, Durbin & Evans on recursive residuals.

    Parameters
    ----------
    w : array_like, shape (m,)
        Recursive residuals :math:`w_{n+1}, …, w_N` (m = N − n), e.g. from
        :func:`recursive_residuals`; at least 2, finite.
    alpha : float, optional
        Significance level of the two-sided test, in (0, 1). Default 0.05.
    scale : {"std", "ols"} or float, optional
        The :math:`\hat\sigma` dividing the sums:

        * ``"std"`` (default; R strucchange's ``efp(type="Rec-CUSUM")``,
          Stata ``cusum6``, statsmodels' ``RecursiveLS.cusum``, Harvey
          1990): the sample standard deviation of the :math:`w_j`
          (``ddof=1``, mean removed);
        * ``"ols"`` (Brown, Durbin & Evans 1975):
          :math:`\hat\sigma^2 = \frac{1}{m}\sum_j w_j^2`, which equals the
          residual variance :math:`S_N/(N-n)` of the least-squares fit on
          all samples;
        * a positive float: a known σ.

    Returns
    -------
    CusumResult
        ``statistic`` :math:`W_{n+j}`, bounds ``lower``/``upper``,
        ``crossings``, ``crossed``, ``first_crossing``, the critical value
        *a* and the ``scale`` used.

    Raises
    ------
    ValueError
        If ``w`` is too short, not finite or all zero, ``alpha`` is outside
        (0, 1), or ``scale`` is not a choice or not positive.
    TypeError
        If ``alpha`` or ``scale`` has the wrong type.

    Notes
    -----
    With :math:`r = n + j`,

    .. math::

        W_r = \frac{1}{\hat\sigma}\sum_{i=n+1}^{r} w_i, \qquad
        \pm\Bigl(a\sqrt{m} + 2a\,\frac{r - n}{\sqrt{m}}\Bigr),

    the bounds being the lines through :math:`(n, \pm a\sqrt{m})` and
    :math:`(N, \pm 3a\sqrt{m})`; constancy of θ is rejected at level α when
    :math:`W_r` leaves them (Brown, Durbin & Evans 1975, §2.3). *a* solves
    BDE's boundary-crossing equation

    .. math::

        1 - \Phi(3a) + e^{-4a^2}\,\Phi(a) = \tfrac{\alpha}{2};

    for α = 0.10, 0.05, 0.01 the values printed by BDE (0.850, 0.948,
    1.143) are used, for other α the equation is solved.

    Conventions: with the default ``scale="std"`` the statistic and bounds equal
    statsmodels' ``RecursiveLS`` results ``.cusum`` and
    ``._cusum_significance_bounds(alpha)`` for α = 0.05 and 0.01 (bounds
    evaluated at sample r; the bounds are not rescaled, only the
    statistic). For α = 0.10 statsmodels uses a = 0.950 where BDE (and
    their equation) give 0.850; this function uses 0.850.

    References
    ----------
    .. [1] R. L. Brown, J. Durbin, J. M. Evans, "Techniques for testing the
       constancy of regression relationships over time", J. R. Statist.
       Soc. B 37(2):149–192, 1975.
    .. [2] A. C. Harvey, *The Econometric Analysis of Time Series*, 2nd ed.,
       1990, §5.4.

    Examples
    --------
    >>> import numpy as np
    >>> from adaptid.diagnostics import cusum
    >>> w = np.random.default_rng(0).standard_normal(200)
    >>> res = cusum(w)
    >>> res.critical_value, res.crossed
    (0.948, False)
    """
    w = _as_residuals(w, 2)
    alpha = check_scalar(alpha, "alpha", low=0.0, high=1.0, low_open=True, high_open=True)
    if isinstance(scale, str):
        scale = check_choice(scale, "scale", ("ols", "std"))
        sigma = float(np.sqrt(np.mean(w * w))) if scale == "ols" else float(np.std(w, ddof=1))
        if not sigma > 0.0:
            raise param_error("w", "not constant (its standard deviation is zero)", "<constant values>")
    else:
        try:
            sigma = check_scalar(scale, "scale", low=0.0, low_open=True)
        except TypeError:
            raise param_error("scale", "'ols', 'std' or a positive float", scale,
                              exc=TypeError) from None
    m = w.size
    a = _bde_critical_value(alpha)
    j = np.arange(1, m + 1, dtype=np.float64)
    root_m = np.sqrt(m)
    upper = a * root_m + 2.0 * a * j / root_m
    stat = np.cumsum(w) / sigma
    return CusumResult(kind="cusum", statistic=stat, lower=-upper, upper=upper,
                       alpha=alpha, critical_value=a, scale=sigma,
                       crossings=np.abs(stat) > upper)


def cusum_squares(w, alpha=0.05):
    r"""CUSUM-of-squares test on recursive residuals.

    Parameters
    ----------
    w : array_like, shape (m,)
        Recursive residuals :math:`w_{n+1}, …, w_N` (m = N − n), at least 3,
        finite, not all zero.
    alpha : {0.2, 0.1, 0.05, 0.02, 0.01}, optional
        Significance level of the two-sided test. Default 0.05.

    Returns
    -------
    CusumResult
        ``statistic`` :math:`s_{n+j}`, bounds ``lower``/``upper``,
        ``crossings``, ``crossed``, ``first_crossing`` and the critical
        value :math:`c_0`.

    Raises
    ------
    ValueError
        If ``w`` is too short, not finite or all zero, or ``alpha`` is not
        one of the tabulated levels.

    Notes
    -----
    With :math:`r = n + j`,

    .. math::

        s_r = \frac{\sum_{i=n+1}^{r} w_i^2}{\sum_{i=n+1}^{N} w_i^2},
        \qquad \frac{r - n}{N - n} \pm c_0

    (Brown, Durbin & Evans 1975, §2.4): under constant θ and σ,
    :math:`s_r` has a beta distribution of mean :math:`(r-n)/(N-n)`; a
    change in θ or σ pushes it out of the band. :math:`c_0` is Durbin's
    (1969) one-sided Kolmogorov–Smirnov-type critical value at level α/2,
    here from the response surface of Edgerton & Wells (1994),

    .. math::

        c_0 \approx \frac{a_1}{\sqrt{n'}} + \frac{a_2}{n'} + \frac{a_3}{n'^{3/2}},
        \qquad n' = \tfrac12 (N - n) - 1,

    accurate for medium and large samples (for small m, Durbin's table is
    exact and the approximation slightly conservative or liberal). Equal
    to statsmodels' ``RecursiveLS`` results ``.cusum_squares`` and
    ``._cusum_squares_significance_bounds(alpha)``.

    References
    ----------
    .. [1] R. L. Brown, J. Durbin, J. M. Evans, "Techniques for testing the
       constancy of regression relationships over time", J. R. Statist.
       Soc. B 37(2):149–192, 1975.
    .. [2] D. Edgerton, C. Wells, "Critical values for the CUSUMSQ
       statistic in medium and large sized samples", Oxford Bull. Econ.
       Stat. 56(3):355–365, 1994.
    .. [3] J. Durbin, "Tests for serial correlation in regression analysis
       based on the periodogram of least-squares residuals", Biometrika
       56(1):1–15, 1969.

    Examples
    --------
    >>> import numpy as np
    >>> from adaptid.diagnostics import cusum_squares
    >>> w = np.random.default_rng(0).standard_normal(200)
    >>> w[100:] *= 3.0          # the noise level triples half-way
    >>> cusum_squares(w).crossed
    True
    """
    w = _as_residuals(w, 3)
    alpha = check_scalar(alpha, "alpha", low=0.0, high=1.0, low_open=True, high_open=True)
    matches = [i for i, lev in enumerate(_EW_ALPHA) if np.isclose(alpha, lev, rtol=1e-12, atol=0)]
    if not matches:
        raise param_error("alpha", "one of " + ", ".join(f"{lev:g}" for lev in _EW_ALPHA), alpha)
    coef = _EW_COEF[:, matches[0]]
    m = w.size
    nn = 0.5 * m - 1.0
    c0 = float(coef[0] / np.sqrt(nn) + coef[1] / nn + coef[2] / nn ** 1.5)
    sq = np.cumsum(w * w)
    stat = sq / sq[-1]
    line = np.arange(1, m + 1, dtype=np.float64) / m
    lower, upper = line - c0, line + c0
    return CusumResult(kind="cusum_squares", statistic=stat, lower=lower, upper=upper,
                       alpha=alpha, critical_value=c0, scale=float("nan"),
                       crossings=(stat < lower) | (stat > upper))
