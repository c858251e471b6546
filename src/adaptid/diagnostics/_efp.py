r"""Empirical fluctuation processes (R strucchange's ``efp`` and ``sctest.efp``)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .._kernels.layers._breakpoints import moving_estimates, recursive_estimates
from .._validation import check_choice, check_scalar, param_error
from ._pvalues import efp_critical_value, pvalue_efp
from ._recursive import recursive_residuals
from ._format import frame, htest_text, short_repr
from ._sc_common import new_axes, ols, outside_legend, regression_data, root_from_factor

__all__ = ["EfpResult", "efp"]

_KINDS = ("rec-cusum", "ols-cusum", "rec-mosum", "ols-mosum", "re", "me")
_LIMIT = {
    "rec-cusum": "Brownian motion",
    "ols-cusum": "Brownian bridge",
    "rec-mosum": "Brownian motion increments",
    "ols-mosum": "Brownian bridge increments",
    "re": "Brownian bridge",
    "me": "Brownian bridge increments",
}
#: strucchange's name of each ``sctest`` statistic.
_STAT = {"rec-cusum": "S", "ols-cusum": "S0", "rec-mosum": "M", "ols-mosum": "M0",
         "re": "RE", "me": "ME"}
_NAMES = {
    "rec-cusum": "Recursive CUSUM test",
    "ols-cusum": "OLS-based CUSUM test",
    "rec-mosum": "Recursive MOSUM test",
    "ols-mosum": "OLS-based MOSUM test",
    "re": "RE test (recursive estimates test)",
    "me": "ME test (moving estimates test)",
}


@dataclass(frozen=True, eq=False)
class EfpResult:
    r"""An empirical fluctuation process and its test (from :func:`efp`).

    Attributes
    ----------
    kind : str
        One of ``"rec-cusum"``, ``"ols-cusum"``, ``"rec-mosum"``,
        ``"ols-mosum"``, ``"re"``, ``"me"``.
    process : ndarray, shape (L,) or (L, n)
        The process, exactly as strucchange's ``efp(...)$process`` (one
        column per regressor for ``"re"`` and ``"me"``).
    index : ndarray of int, shape (L,)
        0-based sample index each point of the process belongs to (the
        last sample summed for CUSUMs, the centre of the window for
        MOSUMs and ``"me"``; the leading zero of the CUSUMs and RE sits
        one sample before the first sum).
    limit_process : str
        Its limit under no change (Brownian motion, bridge, or their
        increments).
    h : float or None
        Bandwidth of the moving processes.
    n_params : int
        Number of regressors n.
    """

    kind: str
    process: np.ndarray
    index: np.ndarray
    limit_process: str
    h: float | None
    n_params: int
    _stat_source: np.ndarray = field(repr=False)

    @property
    def statistic(self) -> float:
        r"""``sctest``'s statistic: max ``|process|`` (the recursive CUSUM divided by 1 + 2t)."""
        return float(np.max(np.abs(self._stat_source)))

    @property
    def pvalue(self) -> float:
        """strucchange's asymptotic p-value of :attr:`statistic`."""
        return pvalue_efp(self.statistic, self.limit_process, k=self._k, h=self.h)

    @property
    def _k(self) -> int:
        return 1 if self.process.ndim == 1 else self.process.shape[1]

    @property
    def break_index(self) -> int:
        """0-based sample at which :attr:`statistic` is attained.

        A break-date estimate for the OLS-CUSUM and RE processes (their
        peak); for the recursive CUSUM (whose drift continues after a
        break) and the moving processes only indicative.
        """
        src = np.abs(self._stat_source).reshape(self._stat_source.shape[0], -1).max(axis=1)
        offset = self.process.shape[0] - src.size
        return int(self.index[offset + int(np.argmax(src))])

    def __repr__(self) -> str:
        return short_repr("EfpResult", kind=self.kind, statistic=self.statistic,
                          pvalue=self.pvalue, break_index=self.break_index,
                          length=self.process.shape[0])

    def summary(self) -> str:
        """The test as strucchange's ``print(sctest(efp(...)))`` prints it."""
        return htest_text(_NAMES[self.kind], "X, y", [(_STAT[self.kind], self.statistic)],
                          self.pvalue, [f"break index (0-based): {self.break_index}"])

    def to_frame(self):
        """One row: ``test``, ``statistic``, ``pvalue``, ``break_index`` (a pandas DataFrame)."""
        return frame([(self.kind, self.statistic, self.pvalue, self.break_index)],
                     ("test", "statistic", "pvalue", "break_index"))

    def critical_value(self, alpha=0.05) -> float:
        """Critical value c of the test at level ``alpha`` (``pvalue(c) = alpha``)."""
        alpha = check_scalar(alpha, "alpha", low=0.0, high=1.0, low_open=True, high_open=True)
        return efp_critical_value(alpha, self.limit_process, k=self._k, h=self.h)

    def boundary(self, alpha=0.05) -> np.ndarray:
        r"""The boundary of the process at level ``alpha``, shape (L,).

        ``c (1 + 2t)``, t = 0 … 1, for the recursive CUSUM (the Brown,
        Durbin & Evans lines), the constant ``c`` otherwise (strucchange's
        ``boundary.efp``).
        """
        c = self.critical_value(alpha)
        L = self.process.shape[0]
        if self.limit_process == "Brownian motion":
            return c + 2.0 * c * np.arange(L) / (L - 1)
        return np.full(L, c)

    def plot(self, ax=None, *, alpha=0.05):
        """Plot the process and its boundary; returns the matplotlib Figure.

        ``ax`` (optional): draw there (the Figure returned is ``ax.figure``).
        """
        ax = new_axes(ax)
        ax.plot(self.index, self.process, lw=1, label=_NAMES[self.kind])
        b = self.boundary(alpha)
        band = f"{100 * (1 - alpha):g} % boundary"
        ax.plot(self.index, b, "r--", lw=1, label=band)
        ax.plot(self.index, -b, "r--", lw=1, label=band)
        ax.axhline(0.0, color="k", lw=0.5, label="zero")
        ax.set_title(f"{_NAMES[self.kind]}, p = {self.pvalue:.3g}")
        ax.set_xlabel("sample")
        ax.set_ylabel("empirical fluctuation process")
        outside_legend(ax)
        return ax.figure


def _sdev(x, df=None):
    # strucchange's sdev: sd(x) * sqrt((length(x) - 1) / df)
    d = x.size - 1 if df is None else df
    return float(np.std(x, ddof=1) * np.sqrt((x.size - 1) / d))


def efp(X, y, *, kind, h=0.15):
    r"""Empirical fluctuation process of a linear regression (R strucchange's ``efp``).

    Parameters
    ----------
    X : array_like, shape (N, n)
        Regressors (a 1-D array is one column; use a column of ones for a
        mean).
    y : array_like, shape (N,)
        Observations.
    kind : {"rec-cusum", "ols-cusum", "rec-mosum", "ols-mosum", "re", "me"}
        The process (strucchange's ``type`` in lower case).
    h : float, optional
        Bandwidth of the moving processes (``"rec-mosum"``, ``"ols-mosum"``,
        ``"me"``) as a fraction of the sample, in (0, 1). Default 0.15.

    Returns
    -------
    EfpResult
        ``process``, ``statistic``, ``pvalue``, ``boundary(alpha)``,
        ``break_index``, ``plot()``.

    Raises
    ------
    ValueError
        On bad shapes, non-finite data, rank-deficient X, an unknown
        ``kind`` or ``h`` outside (0, 1).

    Notes
    -----
    With :math:`w_t` the recursive residuals, :math:`e_t` the OLS
    residuals, :math:`\hat\sigma` their standard deviation (degrees of
    freedom as strucchange), :math:`\hat\theta^{(i)}` the estimate on the
    first i samples and :math:`\hat\theta_{(t,h)}` on the window of
    :math:`\lfloor Nh\rfloor` samples starting at t:

    .. math::

        \text{rec-CUSUM: } W(t) = \frac{1}{\hat\sigma\sqrt{N-n}}\sum_{i=n+1}^{n+\lfloor t(N-n)\rfloor} w_i,
        \qquad
        \text{OLS-CUSUM: } W^0(t) = \frac{1}{\hat\sigma\sqrt N}\sum_{i=1}^{\lfloor tN\rfloor} e_i,

    the MOSUMs are the same sums over moving windows of
    :math:`\lfloor Nh\rfloor` residuals, and

    .. math::

        \text{RE: } \frac{i}{\hat\sigma\sqrt N}\,(X_i^T X_i/i)^{1/2}(\hat\theta^{(i)} - \hat\theta),
        \qquad
        \text{ME: } \frac{\lfloor Nh\rfloor}{\hat\sigma\sqrt N}\,
        (X_{(t,h)}^T X_{(t,h)}/\lfloor Nh\rfloor)^{1/2}(\hat\theta_{(t,h)} - \hat\theta).

    Under no change they converge to a Brownian motion (rec-CUSUM), a
    Brownian bridge (OLS-CUSUM, RE) or their increments (MOSUMs, ME); the
    statistic is the supremum of the absolute process (the rec-CUSUM
    divided by 1 + 2t) and the p-value strucchange's (Kuan & Hornik 1995;
    Zeileis et al. 2002, §3). Recursive and moving estimates come from
    compiled Givens QR updates: O(N n²) for ``"re"``; each window
    factorised afresh for ``"me"``, O(N ⌊Nh⌋ n²).

    References
    ----------
    .. [1] A. Zeileis, F. Leisch, K. Hornik, C. Kleiber, "strucchange: An R
       package for testing for structural change in linear regression
       models", J. Statist. Software 7(2):1–38, 2002.
    .. [2] C.-M. Kuan, K. Hornik, "The generalized fluctuation test: A
       unifying view", Econometric Reviews 14:135–161, 1995.
    .. [3] W. Ploberger, W. Krämer, "The CUSUM test with OLS residuals",
       Econometrica 60(2):271–285, 1992.

    Examples
    --------
    The OLS-CUSUM of a mean that shifts half way peaks at the shift:

    >>> import numpy as np
    >>> from adaptid.diagnostics import efp
    >>> y = np.r_[np.zeros(100), np.ones(100)] + 0.3 * np.random.default_rng(0).standard_normal(200)
    >>> p = efp(np.ones(200), y, kind="ols-cusum")
    >>> p.break_index, bool(p.pvalue < 0.01)
    (99, True)
    """
    kind = check_choice(kind, "kind", _KINDS)
    h = check_scalar(h, "h", low=0.0, high=1.0, low_open=True, high_open=True)
    X, y = regression_data(X, y, min_rows=None)
    N, n = X.shape
    # the recursive residuals' σ̂ needs two of them (rec-MOSUM: N - 2n > 0 too)
    need = {"rec-cusum": n + 2, "rec-mosum": max(n + 2, 2 * n + 1)}.get(kind, n + 1)
    if N < need:
        raise param_error("X", f"at least {need} rows long for kind={kind!r} "
                               f"with {n} column(s)", f"<shape {X.shape}>")
    theta, e = ols(X, y)
    par = None
    if kind == "rec-cusum":
        w = recursive_residuals(X, y)
        sigma = _sdev(w)
        proc = np.r_[0.0, np.cumsum(w)] / (sigma * np.sqrt(N - n))
        index = np.arange(n - 1, N)
        j = np.arange(1, proc.size) / (proc.size - 1)
        stat_src = proc[1:] / (1.0 + 2.0 * j)
    elif kind == "ols-cusum":
        sigma = _sdev(e, N - n)
        proc = np.r_[0.0, np.cumsum(e)] / (sigma * np.sqrt(N))
        index = np.arange(-1, N)
        stat_src = proc[1:]
    elif kind == "rec-mosum":
        par = h
        w = recursive_residuals(X, y)
        nw = N - n
        nh = int(np.floor(nw * h))
        if nh < 1:
            raise param_error("h", f"at least 1/(N - n) = {1 / nw:.3g}", h)
        c = np.r_[0.0, np.cumsum(w)]
        proc = (c[nh:] - c[:nw - nh + 1]) / (_sdev(w, nw - n) * np.sqrt(nw))
        index = n + np.arange(nw - nh + 1) + (nh - 1) // 2
        stat_src = proc
    elif kind == "ols-mosum":
        par = h
        nh = int(np.floor(N * h))
        if nh < 1:
            raise param_error("h", f"at least 1/N = {1 / N:.3g}", h)
        c = np.r_[0.0, np.cumsum(e)]
        proc = (c[nh:] - c[:N - nh + 1]) / (_sdev(e, N - n) * np.sqrt(N))
        index = np.arange(N - nh + 1) + (nh - 1) // 2
        stat_src = proc
    elif kind == "re":
        sigma = _sdev(e, N - n)
        L = np.arange(n, N)                       # prefix lengths n .. N-1
        th = np.empty((N - n + 1, n))
        Rf = np.empty((N - n + 1, n, n))
        recursive_estimates(X, y, n, th, Rf)
        Q = root_from_factor(Rf[:-1]) / (sigma * np.sqrt(L))[:, None, None]
        d = np.einsum("tij,tj->ti", Q, th[:-1] - theta)
        proc = np.vstack([np.zeros((1, n)), d, np.zeros((1, n))])
        proc *= np.arange(n - 1, N + 1)[:, None] / np.sqrt(N)
        index = np.arange(n - 2, N)
        stat_src = proc[1:]
    else:  # "me"
        par = h
        sigma = _sdev(e, N - n)
        nh = int(np.floor(N * h))
        if nh < n:
            raise param_error("h", f"at least n/N = {n / N:.3g} (a window of n samples)", h)
        th = np.empty((N - nh + 1, n))
        Rf = np.empty((N - nh + 1, n, n))
        moving_estimates(X, y, nh, th, Rf)
        Q = root_from_factor(Rf) / (sigma * np.sqrt(nh))
        proc = nh * np.einsum("tij,tj->ti", Q, th - theta) / np.sqrt(N)
        index = np.arange(N - nh + 1) + (nh - 1) // 2
        stat_src = proc
    if proc.ndim == 2 and proc.shape[1] == 1 and kind not in ("re", "me"):
        proc = proc[:, 0]  # pragma: no cover - 1-D kinds are already 1-D
    return EfpResult(kind=kind, process=proc, index=index, limit_process=_LIMIT[kind],
                     h=par, n_params=n, _stat_source=stat_src)
