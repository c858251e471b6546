r"""Online monitoring of a regression against a stable history (R strucchange's ``mefp``)."""

from __future__ import annotations

import warnings

import numpy as np
from scipy.optimize import brentq
from scipy.stats import norm

from .._exceptions import AdaptidWarning
from .._kernels.layers._breakpoints import moving_estimates
from .._validation import as_float_array, check_choice, check_scalar, param_error
from . import _sc_tables as _T
from ._format import format_num, frame
from ._sc_common import new_axes, ols, outside_legend, regression_data, root_from_factor

__all__ = ["Monitor"]

#: A history whose residual standard deviation is at most this times rms(y) fits exactly.
_EXACT_FIT = 1e-12


def _csw_critical_value(alpha: float) -> float:
    # strucchange mefp.efp (OLS-CUSUM): a solves 2 - 2 (Phi(a) - a phi(a)) = alpha
    # (Chu, Stinchcombe & White 1996, boundary crossing of a Brownian motion).
    return float(brentq(lambda a: 2.0 - 2.0 * (norm.cdf(a) - a * norm.pdf(a)) - alpha,
                        1e-9, 10.0, xtol=1e-14))


class Monitor:
    r"""Sequential test for a change after a stable history period.

    Parameters
    ----------
    X_hist : array_like, shape (N_h, n)
        Regressors of the history period, assumed free of change (1-D: one
        column).
    y_hist : array_like, shape (N_h,)
        Its observations.
    kind : {"ols-cusum", "me"}, optional
        ``"ols-cusum"`` (Chu, Stinchcombe & White 1996): cumulated
        residuals of new samples under the history's estimate;
        ``"me"`` (Leisch, Hornik & Kuan 2000): moving estimates on windows
        of ``floor(h N_h)`` samples against the history's. Default
        ``"ols-cusum"``.
    alpha : float, optional
        Significance level of the whole monitoring. Default 0.05.
    horizon : {2, 4, 6, 8, 10}, optional
        For ``"me"``: the monitoring ends at ``horizon × N_h`` samples
        (strucchange's ``period``; its critical values are tabulated for
        these); later samples are not monitored (one ``AdaptidWarning``). The ``"ols-cusum"`` boundary holds for an unbounded
        horizon and ignores it. Default 10.
    h : {0.25, 0.5, 1.0}, optional
        Window of ``"me"`` as a fraction of N_h. Default 0.5.

    Attributes
    ----------
    alarm : int or None
        0-based index, counted from the first history sample (R's
        ``breakpoint`` minus one), of the first sample at which the
        statistic crossed its boundary; None before an alarm.
    n_seen : int
        Samples seen so far (history included).
    critical_value : float

    Raises
    ------
    ValueError
        A history of at most n + 1 rows, or one the regressors fit exactly
        (σ̂ ≤ 1e-12·rms(y): the statistics are scaled by 1/σ̂, and rounding
        errors alone would cross or never reach the boundary).

    Notes
    -----
    With :math:`\hat\theta, \hat\sigma` from the history (N_h samples,
    σ̂² = RSS/(N_h − n)) and t = k/N_h for sample k:

    .. math::

        \text{OLS-CUSUM: } \Bigl|\frac{1}{\hat\sigma\sqrt{N_h}}\sum_{i=1}^{k}
        (y_i - x_i^T\hat\theta)\Bigr| > \sqrt{t(t-1)\bigl(c^2 + \log\tfrac{t}{t-1}\bigr)},

        \text{ME: } \max_{j \le k}\Bigl\|\frac{K}{\hat\sigma\sqrt{N_h}}
        (X_{(j)}^TX_{(j)}/K)^{1/2}(\hat\theta_{(j)} - \hat\theta)\Bigr\|_\infty
        > c\sqrt{2\log^+ t},

    :math:`\hat\theta_{(j)}` the estimate on the K = ⌊h N_h⌋ samples
    ending at j, :math:`\log^+ t = \max(1, \log t)`; c solves
    :math:`2 - 2(\Phi(c) - c\varphi(c)) = \alpha` (OLS-CUSUM) or is
    interpolated in strucchange's ``monitorMECritvalTable`` at level
    α/n per parameter (ME). As strucchange's ``mefp``/``monitor``.

    References
    ----------
    .. [1] C.-S. J. Chu, M. Stinchcombe, H. White, "Monitoring structural
       change", Econometrica 64(5):1045–1065, 1996.
    .. [2] F. Leisch, K. Hornik, C.-M. Kuan, "Monitoring structural changes
       with the generalized fluctuation test", Econometric Theory
       16:835–854, 2000.
    .. [3] A. Zeileis, F. Leisch, C. Kleiber, K. Hornik, "Monitoring
       structural change in dynamic econometric models", J. Applied
       Econometrics 20:99–121, 2005.

    Examples
    --------
    >>> import numpy as np
    >>> from adaptid.diagnostics import Monitor
    >>> rng = np.random.default_rng(0)
    >>> y = np.r_[np.zeros(150), np.full(150, 1.0)] + 0.5 * rng.standard_normal(300)
    >>> mon = Monitor(np.ones(100), y[:100])
    >>> alarm = mon.run(np.ones(200), y[100:])
    >>> 150 <= alarm < 175
    True
    """

    def __init__(self, X_hist, y_hist, *, kind="ols-cusum", alpha=0.05, horizon=10, h=0.5):
        self.kind = check_choice(kind, "kind", ("ols-cusum", "me"))
        self.alpha = check_scalar(alpha, "alpha", low=0.0, high=1.0, low_open=True, high_open=True)
        X, y = regression_data(X_hist, y_hist, min_rows=None)
        N, n = X.shape
        if N <= n + 1:
            raise param_error("X_hist", f"longer than n + 1 = {n + 1} rows", f"<shape {X.shape}>")
        self.n_params = n
        self.n_hist = N
        self.theta, e = ols(X, y)
        self.sigma = float(np.sqrt(e @ e / (N - n)))
        scale = float(np.sqrt(np.mean(y * y)))
        if not self.sigma > _EXACT_FIT * scale:  # also catches σ̂ = 0 and NaN
            raise param_error("y_hist", "a history that the regressors do not fit exactly "
                              f"(σ̂ > {_EXACT_FIT:g}·rms(y): the statistics are scaled by 1/σ̂, "
                              "so an exact fit alarms on rounding errors)",
                              f"<σ̂ = {self.sigma:.3g}, rms(y) = {scale:.3g}>")
        self.n_seen = N
        self.alarm = None
        self._chunks: list[np.ndarray] = []
        self._bounds: list[np.ndarray] = []
        if self.kind == "ols-cusum":
            self.critical_value = _csw_critical_value(self.alpha)
            self._cum = float(np.sum(e)) / (self.sigma * np.sqrt(N))
        else:
            if horizon not in _T.MONITOR_ME_PERIOD:
                raise param_error("horizon", "one of 2, 4, 6, 8, 10 for kind='me'", horizon)
            hs = [w for w in _T.MONITOR_ME_WINSIZE if np.isclose(w, h)] if isinstance(
                h, (int, float)) else []
            if not hs:
                raise param_error("h", "one of 0.25, 0.5, 1.0 for kind='me'", h)
            level = 1.0 - self.alpha / n
            lo, hi = _T.MONITOR_ME_PROB[0], _T.MONITOR_ME_PROB[-1]
            if not lo <= level <= hi:
                raise param_error("alpha", f"such that alpha/n is in [{1 - hi:.3g}, {1 - lo:.3g}] "
                                  "(the range of strucchange's ME table)", alpha)
            row = _T.MONITOR_ME[_T.MONITOR_ME_WINSIZE.index(hs[0]),
                                _T.MONITOR_ME_PERIOD.index(horizon)]
            self.critical_value = float(np.interp(level, _T.MONITOR_ME_PROB, row))
            self._K = int(np.floor(hs[0] * N))
            if self._K < n:
                raise param_error("h", f"a window of at least n = {n} samples", h)
            self.horizon = int(horizon)
            self._Xbuf = X[N - self._K + 1:].copy()
            self._ybuf = y[N - self._K + 1:].copy()
            self._max = 0.0

    # ------------------------------------------------------------------
    def boundary_at(self, k) -> np.ndarray:
        """Boundary at 1-based sample counts ``k`` (> N_h), as strucchange's ``border``."""
        t = np.asarray(k, dtype=np.float64) / self.n_hist
        c = self.critical_value
        if self.kind == "ols-cusum":
            return np.sqrt(t * (t - 1.0) * (c * c + np.log(t / (t - 1.0))))
        return c * np.sqrt(2.0 * np.where(t <= np.e, 1.0, np.log(np.maximum(t, np.e))))

    def update(self, x, y):
        """Monitor one new sample; returns :attr:`alarm`."""
        x = as_float_array(x, "x", ndim=(0, 1))
        return self.run(x.reshape(1, -1), [y])

    def run(self, X, y):
        """Monitor new samples X (m, n), y (m,); returns :attr:`alarm` (None if no alarm)."""
        X = as_float_array(X, "X", ndim=(1, 2))
        if X.ndim == 1:
            X = X.reshape(-1, 1) if self.n_params == 1 else X.reshape(1, -1)
        if X.shape[1] != self.n_params:
            raise param_error("X", f"of shape (m, {self.n_params})", f"<shape {X.shape}>")
        m = X.shape[0]
        y = as_float_array(y, "y", shape=(m,))
        m = self._within_horizon(m)
        X, y = X[:m], y[:m]
        if m == 0:
            return self.alarm
        k = self.n_seen + 1 + np.arange(m)
        if self.kind == "ols-cusum":
            proc = self._cum + np.cumsum(y - X @ self.theta) / (self.sigma * np.sqrt(self.n_hist))
            self._cum = float(proc[-1])
            stat = np.abs(proc)
        else:
            Xa = np.ascontiguousarray(np.vstack([self._Xbuf, X]))
            ya = np.ascontiguousarray(np.r_[self._ybuf, y])
            K, n = self._K, self.n_params
            th = np.empty((m, n))
            Rf = np.empty((m, n, n))
            moving_estimates(Xa, ya, K, th, Rf)
            Q = root_from_factor(Rf) / np.sqrt(K)
            proc = np.einsum("tij,tj->ti", Q, th - self.theta) * K / (self.sigma * np.sqrt(self.n_hist))
            stat = np.maximum.accumulate(np.maximum(np.abs(proc).max(axis=1), self._max))
            self._max = float(stat[-1])
            self._Xbuf, self._ybuf = Xa[Xa.shape[0] - K + 1:], ya[ya.size - K + 1:]
        bound = self.boundary_at(k)
        if self.alarm is None:
            hit = np.flatnonzero(stat > bound)
            if hit.size:
                self.alarm = int(k[hit[0]] - 1)
        self._chunks.append(proc)
        self._bounds.append(bound)
        self.n_seen += m
        return self.alarm

    def _within_horizon(self, m) -> int:
        """How many of m new samples the "me" test's critical values cover (warns for the rest)."""
        if self.kind != "me":
            return m
        left = max(self.horizon * self.n_hist - self.n_seen, 0)
        if m > left:
            warnings.warn(f"Monitor(kind='me'): the monitoring ended at horizon × N_h = "
                          f"{self.horizon * self.n_hist} samples (its critical values hold up to "
                          f"there); {m - left} later sample(s) not monitored. Start a new Monitor "
                          "or use a larger horizon.", AdaptidWarning, stacklevel=3)
        return min(m, left)

    @property
    def process(self) -> np.ndarray:
        """The monitored process at samples N_h … n_seen−1 (strucchange's ``$process``)."""
        if not self._chunks:
            return np.empty((0,) if self.kind == "ols-cusum" else (0, self.n_params))
        return np.concatenate(self._chunks)

    @property
    def boundary(self) -> np.ndarray:
        """The boundary at the same samples."""
        return np.concatenate(self._bounds) if self._bounds else np.empty(0)

    def plot(self, ax=None):
        """Plot the monitored statistic, its boundary and the alarm; returns the Figure.

        ``ax`` (optional): draw there (the Figure returned is ``ax.figure``).
        """
        ax = new_axes(ax)
        k = np.arange(self.n_hist, self.n_seen)
        proc = self.process
        names = ["OLS-CUSUM process"] if proc.ndim == 1 else [f"ME process, θ{j}"
                                                              for j in range(proc.shape[1])]
        for j, lab in enumerate(names):
            ax.plot(k, proc if proc.ndim == 1 else proc[:, j], lw=1, label=lab)
        ax.plot(k, self.boundary, "r--", lw=1, label="boundary")
        ax.plot(k, -self.boundary, "r--", lw=1, label="boundary")
        if self.alarm is not None:
            ax.axvline(self.alarm, color="k", ls=":", label=f"alarm at {self.alarm}")
        ax.set_xlabel("sample")
        ax.set_ylabel("monitored statistic")
        outside_legend(ax)
        return ax.figure

    def __repr__(self) -> str:
        return (f"Monitor(kind={self.kind!r}, n_hist={self.n_hist}, n_seen={self.n_seen}, "
                f"alarm={self.alarm})")

    def summary(self) -> str:
        """The monitoring state as strucchange's ``print(mefp)`` reports it."""
        method = ("Monitoring with OLS-based CUSUM test" if self.kind == "ols-cusum"
                  else "Monitoring with ME test (moving estimates test)")
        alarm = ("No structural change detected" if self.alarm is None
                 else f"Break detected at observation # {self.alarm} (0-based)")
        return (f"\n\t{method}\n\nInitial monitoring sample (history): {self.n_hist} observations, "
                f"seen: {self.n_seen}\ncritical value = {format_num(self.critical_value)}, "
                f"alpha = {self.alpha:g}\n{alarm}\n")

    def to_frame(self):
        """One row: ``test``, ``n_hist``, ``n_seen``, ``critical_value``, ``alpha``, ``alarm``."""
        return frame([(self.kind, self.n_hist, self.n_seen, self.critical_value, self.alpha,
                       self.alarm)], ("test", "n_hist", "n_seen", "critical_value", "alpha", "alarm"))
