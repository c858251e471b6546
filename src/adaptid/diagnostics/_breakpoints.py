r"""Dating of multiple structural breaks (Bai & Perron; R strucchange's ``breakpoints``)."""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import brentq
from scipy.special import log_ndtr

from .._exceptions import AdaptidWarning
from .._kernels.layers._breakpoints import breakpoints_dp
from .._validation import check_int, check_scalar, param_error
from ._format import format_num, frame
from ._sc_common import new_axes, ols, outside_legend, regression_data

__all__ = ["BreakpointsResult", "BreakConfint", "BreakConfidenceWarning", "breakpoints"]


class BreakConfidenceWarning(AdaptidWarning):
    """A Bai (1997) confidence interval cannot be computed (strucchange's warning)."""


def _pargmaxV(x, xi=1.0, phi1=1.0, phi2=1.0):
    r"""P(argmax V <= x), Bai (1997) Proposition 3 as strucchange's ``pargmaxV``."""
    phi = xi * (phi2 / phi1) ** 2
    x = float(x)
    if x < 0:
        a = abs(x)
        frac = xi / phi
        return (-np.exp(np.log(a) / 2 - a / 8 - np.log(2 * np.pi) / 2)
                - (phi / xi * (phi + 2 * xi) / (phi + xi))
                * np.exp(frac * (1 + frac) * a / 2 + log_ndtr(-(0.5 + frac) * np.sqrt(a)))
                + np.exp(np.log(a / 2 - 2 + (phi + 2 * xi) ** 2 / ((phi + xi) * xi))
                         + log_ndtr(-np.sqrt(a) / 2)))
    a = abs(x)
    frac = xi * xi / phi
    with np.errstate(divide="ignore"):
        return (1 + np.sqrt(frac) * np.exp(np.log(a) / 2 - frac * a / 8 - np.log(2 * np.pi) / 2)
                + (xi / phi * (2 * phi + xi) / (phi + xi))
                * np.exp((phi + xi) * a / 2 + log_ndtr(-(phi + xi / 2) / np.sqrt(phi) * np.sqrt(a)))
                - np.exp(np.log((2 * phi + xi) ** 2 / ((phi + xi) * phi) - 2 + frac * a / 2)
                         + log_ndtr(-np.sqrt(frac) * np.sqrt(a) / 2)))


class BreakConfint(np.ndarray):
    r"""Confidence intervals of break dates: an (m, 3) float array with labels.

    Indexes, unpacks and computes as the plain ndarray it is (row i: lower
    bound, break date, upper bound, 0-based sample numbers, NaN where
    undefined); adds the labels: :attr:`lower`, :attr:`estimate`,
    :attr:`upper`, a labelled ``repr`` and :meth:`to_frame`.

    Attributes
    ----------
    time : sequence or None
        The time axis of the data (the index of a pandas ``y``), or None.
    """

    def __new__(cls, values, time=None):
        obj = np.asarray(values, dtype=float).view(cls)
        obj.time = time
        return obj

    def __array_finalize__(self, obj):
        self.time = getattr(obj, "time", None)

    def _column(self, j):
        return np.asarray(self)[:, j]

    @property
    def lower(self) -> np.ndarray:
        """Lower bounds, shape (m,)."""
        return self._column(0)

    @property
    def estimate(self) -> np.ndarray:
        """Break dates, shape (m,)."""
        return self._column(1)

    @property
    def upper(self) -> np.ndarray:
        """Upper bounds, shape (m,)."""
        return self._column(2)

    def _labels(self, col):
        if self.time is None:
            return list(col)
        return [None if np.isnan(v) else self.time[int(v)] for v in col]

    def to_frame(self):
        """The table: index ``break 1`` … ``break m``, columns ``lower``, ``estimate``, ``upper``.

        A pandas DataFrame (a dict of columns when pandas is missing);
        with a time axis the entries are its labels, otherwise 0-based
        sample numbers.
        """
        a = np.asarray(self)
        rows = list(zip(*(self._labels(a[:, j]) for j in range(3))))
        return frame(rows, ("lower", "estimate", "upper"),
                     index=[f"break {i + 1}" for i in range(a.shape[0])])

    def __repr__(self) -> str:
        if self.ndim != 2 or self.shape[1] != 3:
            return repr(np.asarray(self))
        a = np.asarray(self)
        cells = [["", "lower", "estimate", "upper"]]
        for i in range(a.shape[0]):
            cells.append([f"break {i + 1}", *(("NA" if v is None or (isinstance(v, float) and np.isnan(v))
                                               else (format_num(v, 7) if isinstance(v, float) else str(v)))
                                              for v in (self._labels(a[i:i + 1, j])[0] for j in range(3)))])
        w = [max(len(r[j]) for r in cells) for j in range(4)]
        return "\n".join("  ".join(c.ljust(w[j]) if j == 0 else c.rjust(w[j]) for j, c in enumerate(r))
                         for r in cells)

    __str__ = __repr__


@dataclass(frozen=True, eq=False)
class BreakpointsResult:
    r"""Optimal break dates for every number of breaks (from :func:`breakpoints`).

    Attributes
    ----------
    rss : ndarray, shape (M+1,)
        Minimal residual sum of squares with m = 0 … M breaks.
    bic, lwz : ndarray, shape (M+1,)
        Their information criteria (see :func:`breakpoints`).
    n_breaks : int
        The number of breaks that minimises the BIC.
    breakpoints : ndarray of int, shape (n_breaks,)
        0-based index of the last sample of each segment but the last
        (R's breakpoints minus one).
    h : int
        Minimal segment length in samples.
    """

    rss: np.ndarray
    bic: np.ndarray
    lwz: np.ndarray
    n_breaks: int
    breakpoints: np.ndarray
    h: int
    _X: np.ndarray = field(repr=False)
    _y: np.ndarray = field(repr=False)
    _B: np.ndarray = field(repr=False)
    _time: object = field(default=None, repr=False)

    def __repr__(self) -> str:
        return (f"BreakpointsResult(n_breaks={self.n_breaks}, "
                f"breakpoints={self.breakpoints.tolist()}, h={self.h}, "
                f"max_breaks={self.max_breaks}, n_obs={self._y.size})")

    def summary(self) -> str:
        """The partition as strucchange's ``print(breakpoints(...))`` and its RSS/BIC table."""
        m = self.n_breaks
        bp = " ".join(str(b) for b in self.breakpoints) if m else "NA"
        out = ["", f"\t Optimal {m + 1}-segment partition: ", "",
               f"Minimal segment length h = {self.h}, N = {self._y.size}", "",
               "Breakpoints at observation number (0-based, last sample of a segment):", bp, "",
               f"{'m':>3}  {'RSS':>12}  {'BIC':>12}"]
        out += [f"{k:>3}  {format_num(r, 7):>12}  {format_num(b, 7):>12}"
                for k, (r, b) in enumerate(zip(self.rss, self.bic))]
        return "\n".join(out) + "\n"

    def to_frame(self):
        """One row per break of the BIC choice: ``break`` (0-based last sample), segment sizes."""
        edges = np.r_[0, self.breakpoints + 1, self._y.size]
        rows = [(int(b), int(edges[i + 1] - edges[i]), int(edges[i + 2] - edges[i + 1]))
                for i, b in enumerate(self.breakpoints)]
        return frame(rows, ("breakpoint", "n_before", "n_after"),
                     index=[f"break {i + 1}" for i in range(len(rows))])

    @property
    def max_breaks(self) -> int:
        return self.rss.size - 1

    def breakpoints_for(self, m) -> np.ndarray:
        """0-based break dates of the optimal partition with ``m`` breaks."""
        m = check_int(m, "m", low=0, high=self.max_breaks)
        N = self._y.size
        out = []
        e = N - 1
        for layer in range(m, 0, -1):
            s = int(self._B[layer, e])
            out.append(s - 1)
            e = s - 1
        return np.array(out[::-1], dtype=np.int64)

    def _segments(self, m):
        bp = self.breakpoints if m is None else self.breakpoints_for(m)
        edges = np.r_[0, bp + 1, self._y.size]
        return bp, edges

    def coef(self, m=None) -> np.ndarray:
        """Least-squares coefficients of each segment, shape (m+1, n) (strucchange's ``coef``)."""
        _, edges = self._segments(m)
        return np.array([ols(self._X[a:b], self._y[a:b])[0] for a, b in zip(edges[:-1], edges[1:])])

    def confint(self, level=0.95, m=None) -> BreakConfint:
        r"""Bai (1997) confidence intervals of the break dates, shape (m, 3).

        Columns: lower bound, break date, upper bound (0-based, as
        :attr:`breakpoints`), returned as a :class:`BreakConfint`: the
        (m, 3) float array, labelled (``.lower``, ``.estimate``,
        ``.upper``) and with ``to_frame()``, a DataFrame indexed
        ``break 1`` … with the data's time labels when ``y`` was a pandas
        Series; strucchange's ``confint.breakpointsfull``
        with its defaults (heterogeneous regressors and errors across
        segments, ``het.reg = het.err = TRUE``). A row whose interval
        cannot be computed (P(argmax V ≤ 0) outside the level) is NaN,
        with a :class:`BreakConfidenceWarning`.

        Notes
        -----
        For the break between segments 1 and 2 with coefficient change
        δ, :math:`Q_i = X_i^T X_i / N_i`, :math:`\sigma_i^2` the segment
        residual variances, :math:`\xi = \delta^T Q_2\delta / \delta^T Q_1\delta`:
        the interval is :math:`[\hat T - \lceil u\,\sigma_1^2/\delta^T
        Q_1\delta\rceil,\ \hat T - \lfloor l\,\sigma_1^2/\delta^T Q_1\delta\rfloor]`
        with l, u the α/2 and 1 − α/2 quantiles of Bai's (1997, Prop. 3)
        argmax distribution.
        """
        level = check_scalar(level, "level", low=0.0, high=1.0, low_open=True, high_open=True)
        bp, edges = self._segments(m)
        if bp.size == 0:
            raise param_error("m", "at least 1 (no break, no interval)", 0)
        X, y = self._X, self._y
        N = y.size
        a2 = (1.0 - level) / 2.0
        out = np.full((bp.size, 3), np.nan)
        out[:, 1] = bp

        def seg(i):
            Xi, yi = X[edges[i]:edges[i + 1]], y[edges[i]:edges[i + 1]]
            b, r = ols(Xi, yi)
            return b, Xi.T @ Xi / Xi.shape[0], r @ r / Xi.shape[0]

        beta2, Q2, s2 = seg(0)
        for i in range(1, bp.size + 1):
            beta1, Q1, s1 = beta2, Q2, s2
            beta2, Q2, s2 = seg(i)
            d = beta2 - beta1
            q1, q2 = d @ Q1 @ d, d @ Q2 @ d
            xi = q2 / q1
            phi1, phi2 = np.sqrt(s1), np.sqrt(s2)
            p0 = _pargmaxV(0.0, xi, phi1, phi2)
            if not np.isfinite(p0) or p0 < a2 or p0 > 1 - a2:
                warnings.warn(f"confidence interval {i} cannot be computed: "
                              f"P(argmax V <= 0) = {p0:.4g}", BreakConfidenceWarning, stacklevel=2)
                continue
            ub = lb = 0.0
            while _pargmaxV(ub, xi, phi1, phi2) < 1 - a2:
                ub += 1000.0
            while _pargmaxV(lb, xi, phi1, phi2) > a2:
                lb -= 1000.0
            up = brentq(lambda t: _pargmaxV(t, xi, phi1, phi2) - (1 - a2), 0.0, ub, xtol=1e-10)
            lo = brentq(lambda t: _pargmaxV(t, xi, phi1, phi2) - a2, lb, 0.0, xtol=1e-10)
            up *= s1 / q1
            lo *= s1 / q1
            out[i - 1, 0] = bp[i - 1] - np.ceil(up)
            out[i - 1, 2] = bp[i - 1] - np.floor(lo)
        return BreakConfint(out, self._time)

    def plot(self, ax=None):
        """Plot RSS, BIC and LWZ against the number of breaks; returns the Figure.

        ``ax`` (optional): draw there (the Figure returned is ``ax.figure``);
        RSS goes on a second y axis.
        """
        ax = new_axes(ax)
        m = np.arange(self.rss.size)
        ax.plot(m, self.bic, "o-", label="BIC")
        ax.plot(m, self.lwz, "s-", label="LWZ")
        ax.set_xlabel("number of breaks")
        ax.set_ylabel("information criterion")
        ax2 = ax.twinx()
        ax2.plot(m, self.rss, "k^--", label="RSS (right axis)")
        ax2.set_ylabel("residual sum of squares")
        outside_legend(ax2, ax)
        return ax.figure


def breakpoints(X, y, *, h=0.15, max_breaks=None):
    r"""Least-squares dating of m = 0 … M structural breaks (Bai & Perron 2003).

    Parameters
    ----------
    X : array_like, shape (N, n)
        Regressors (1-D: one column; a column of ones for a mean).
    y : array_like, shape (N,)
        Observations.
    h : float or int, optional
        Minimal segment length: a fraction of N in (0, 1) (``floor(h N)``
        samples) or a number of samples; more than n and at most N/2.
        Default 0.15.
    max_breaks : int, optional
        Largest number of breaks M; default and upper limit
        ``ceil(N/h) − 2`` (strucchange's).

    Returns
    -------
    BreakpointsResult
        ``rss``, ``bic``, ``lwz`` for every m; ``n_breaks`` (by BIC) and
        ``breakpoints``; ``breakpoints_for(m)``, ``coef(m)``,
        ``confint(level, m)``, ``plot()``.

    Notes
    -----
    For m breaks :math:`T_1 < \dots < T_m` (segments of at least h
    samples) the dates minimise :math:`\sum_{j=0}^{m} S(T_j + 1, T_{j+1})`,
    S(i, j) the RSS of the regression on samples i … j. Bai & Perron's
    (2003, §3) dynamic programme

    .. math::

        F_m(e) = \min_{s} \bigl[F_{m-1}(s - 1) + S(s, e)\bigr]

    runs in a compiled kernel over the columns of the triangular RSS
    matrix, each column a pass of recursive residuals (strucchange's
    algorithm), O(N² n²) time and O(M N) memory (the matrix itself is not
    stored). Ties go to the earliest date, as strucchange.

    Criteria (strucchange ``summary.breakpointsfull``; Liu, Wu & Zidek
    1997 as in Bai & Perron 2003, §5.1):

    .. math::

        \mathrm{BIC}_m = N\bigl(\log S_m + 1 - \log N + \log 2\pi\bigr)
                         + \log N\,(n + 1)(m + 1),

        \mathrm{LWZ}_m = \log\frac{S_m}{N - p_m}
                         + \frac{p_m\,c_0}{N}(\log N)^{2 + \delta_0},
        \quad p_m = (m + 1)n + m,\ c_0 = 0.299,\ \delta_0 = 0.1.

    References
    ----------
    .. [1] J. Bai, P. Perron, "Computation and analysis of multiple
       structural change models", J. Applied Econometrics 18:1–22, 2003.
    .. [2] J. Bai, "Estimation of a change point in multiple regression
       models", Rev. Econ. Stat. 79(4):551–563, 1997.
    .. [3] A. Zeileis, C. Kleiber, W. Krämer, K. Hornik, "Testing and
       dating of structural changes in practice", Computational
       Statistics & Data Analysis 44:109–123, 2003.

    Examples
    --------
    The Nile's flow drops after 1898 (sample 27 of 100):

    >>> import numpy as np
    >>> from adaptid.diagnostics import breakpoints
    >>> y = np.r_[np.full(28, 1100.0), np.full(72, 850.0)]
    >>> y += 100 * np.random.default_rng(0).standard_normal(100)
    >>> bp = breakpoints(np.ones(100), y)
    >>> bp.n_breaks, bp.breakpoints
    (1, array([27]))
    """
    time = getattr(y, "index", None)
    X, y = regression_data(X, y)
    N, n = X.shape
    if isinstance(h, (float, np.floating)) and h < 1:
        h = check_scalar(h, "h", low=0.0, high=1.0, low_open=True, high_open=True)
        hh = int(np.floor(N * h))
    else:
        hh = check_int(h, "h", low=1)
    if hh <= n:
        raise param_error("h", f"a minimal segment of more than n = {n} samples", f"<{hh} samples>")
    if hh > N // 2:
        raise param_error("h", f"a minimal segment of at most N/2 = {N // 2} samples",
                          f"<{hh} samples>")
    m_lim = int(np.ceil(N / hh)) - 2
    if max_breaks is None:
        M = m_lim
    else:
        M = check_int(max_breaks, "max_breaks", low=1, high=m_lim)
    M = max(M, 0)
    F = np.empty((M + 1, N))
    B = np.empty((M + 1, N), dtype=np.int64)
    breakpoints_dp(X, y, hh, F, B)
    rss = F[:, N - 1].copy()
    m = np.arange(M + 1)
    bic = N * (np.log(rss) + 1 - np.log(N) + np.log(2 * np.pi)) + np.log(N) * (n + 1) * (m + 1)
    p = (m + 1) * n + m
    lwz = np.log(rss / (N - p)) + p * 0.299 / N * np.log(N) ** 2.1
    nb = int(np.argmin(bic))
    res = BreakpointsResult(rss=rss, bic=bic, lwz=lwz, n_breaks=nb,
                            breakpoints=np.empty(0, dtype=np.int64), h=hh, _X=X, _y=y, _B=B,
                            _time=time)
    object.__setattr__(res, "breakpoints", res.breakpoints_for(nb))
    return res
