r"""``adaptid.plot``: the figures of the ``adaptid fit`` / ``adaptid demo`` reports.

* :func:`tracks` — parameter estimates after each sample, with ±2σ bands;
* :func:`prediction_errors` — a-priori prediction errors (or residuals);
* :func:`cusum` — the CUSUM of the recursive residuals with its bounds.

Each takes data arrays, draws on ``ax`` (a new ``matplotlib.figure.Figure``
with the Agg canvas when None: no pyplot, no GUI backend, no global state)
and returns the Figure. matplotlib is imported only when a figure is drawn
(``pip install 'adaptid[plot]'``).
"""

from __future__ import annotations

import math

import numpy as np

from ._validation import param_error

__all__ = ["tracks", "prediction_errors", "cusum", "fstats", "panel_axes", "compare", "resid"]

COLORS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b")


def _abscissa(x):
    """The x values: date-times stay ``datetime64`` (matplotlib draws a date axis), else float."""
    x = np.asarray(x)
    return x if x.dtype.kind == "M" else x.astype(float)


def _date_axis(ax, x):
    """For date-time abscissae: at most 6 date ticks, slanted, so narrow panels stay legible."""
    if np.asarray(x).dtype.kind != "M":
        return
    import matplotlib.dates as mdates

    loc = mdates.AutoDateLocator(minticks=3, maxticks=6)
    ax.xaxis.set_major_locator(loc)
    ax.xaxis.set_major_formatter(mdates.AutoDateFormatter(loc))
    ax.tick_params(axis="x", labelrotation=20)


def new_figure(figsize):
    """An Agg-backed ``matplotlib.figure.Figure`` (ImportError names the extra)."""
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError as err:  # pragma: no cover - the plot extra installs it
        raise ImportError("adaptid.plot needs matplotlib: pip install 'adaptid[plot]'") from err
    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def decimate(n: int, target: int = 3000) -> slice:
    """A stride that keeps about ``target`` of ``n`` points (enough for a figure)."""
    return slice(None, None, max(1, n // target))


def robust_limits(arrays, truth=None, skip_frac=0.05):
    """y-limits from the 1–99 % range of the curves (after the first transient).

    With a truth, the limits never reach beyond the truth's range ± 50 % of its
    magnitude, so that an estimator losing identifiability for a while does
    not flatten everybody else's curve. None when no value is finite.
    """
    lo = hi = None
    for a in arrays:
        a = np.asarray(a, dtype=float)
        a = a[int(len(a) * skip_frac):]
        a = a[np.isfinite(a)]
        if a.size:
            p1, p99 = np.percentile(a, [1, 99])
            lo = p1 if lo is None else min(lo, p1)
            hi = p99 if hi is None else max(hi, p99)
    if truth is not None:
        t = np.asarray(truth, dtype=float)
        t = t[np.isfinite(t)]
        if t.size:
            tmin, tmax = float(t.min()), float(t.max())
            mag = max(abs(tmin), abs(tmax)) or 1.0
            lo = tmin if lo is None else max(min(lo, tmin), tmin - 0.5 * mag)
            hi = tmax if hi is None else min(max(hi, tmax), tmax + 0.5 * mag)
    if lo is None:
        return None
    span = hi - lo
    if not span > 0:
        span = abs(hi) * 0.1 or 1.0
    return lo - 0.1 * span, hi + 0.1 * span


def _axes(ax, count, figsize_of, *, ncols=1, sharex=False):
    """(figure, flat list of ``count`` axes): ``ax`` given (one or a sequence) or new."""
    if ax is None:
        nrows = math.ceil(count / ncols)
        fig = new_figure(figsize_of(nrows))
        grid = fig.subplots(nrows, ncols, squeeze=False, sharex=sharex)
        flat = list(grid.flat)
        for extra in flat[count:]:
            extra.set_visible(False)
        return fig, flat[:count], True
    flat = list(np.ravel(np.asarray(ax, dtype=object)))
    if len(flat) < count:
        raise ValueError(f"ax must be one Axes per panel ({count}), got {len(flat)}")
    return flat[0].figure, flat[:count], False


def tracks(x, theta, names=None, *, band=None, band_at=None, truth=None, label=None,
           xlabel="sample", events=(), color=None, ax=None):
    r"""Parameter tracks: one panel per parameter, with a ±2σ band.

    Parameters
    ----------
    x : array_like, shape (N,)
        Abscissa of every estimate (sample number or time).
    theta : array_like, shape (N, n) or (N,)
        Estimates after each sample.
    names : sequence of str, length n, optional
        Panel titles (default ``theta[0]`` …).
    band : array_like, shape (K, n), optional
        One standard error σ of each parameter at the rows ``band_at``; the
        band drawn is :math:`\hat\theta \pm 2\sigma` around ``theta`` there.
    band_at : array_like of int, shape (K,), optional
        The rows of ``theta`` where ``band`` was read (default all, K = N).
    truth : tuple (x_t (M,), values (M, n)), optional
        Drawn dashed in black.
    label, color : str, optional
        Legend label and colour of this series (to draw several estimators
        on the same axes, call again with their ``ax``).
    xlabel : str
    events : sequence of float
        Abscissae marked with a dotted vertical line.
    ax : matplotlib Axes or sequence of n Axes, optional
        Where to draw; default a new figure (two columns of panels).

    Returns
    -------
    matplotlib.figure.Figure
    """
    x = _abscissa(x)
    th = np.asarray(theta, dtype=float)
    th = th[:, None] if th.ndim == 1 else th
    n = th.shape[1]
    names = [f"theta[{j}]" for j in range(n)] if names is None else list(names)
    fig, axes, fresh = _axes(ax, n, lambda r: (11, 2.6 * r + 0.6), ncols=2 if n > 1 else 1,
                             sharex=True)
    c = color or COLORS[0]
    sl = decimate(len(x))
    for j, a in enumerate(axes):
        if band is not None:
            rows = np.arange(len(x)) if band_at is None else np.asarray(band_at, dtype=np.int64)
            b = np.asarray(band, dtype=float)[:, j]
            mid = th[rows, j]
            a.fill_between(x[rows], mid - 2 * b, mid + 2 * b, color=c, alpha=0.18, lw=0)
        a.plot(x[sl], th[sl, j], color=c, lw=1.1, label=label)
        tvj = None
        if truth is not None:
            tx = np.asarray(truth[0], dtype=float)
            tv = np.asarray(truth[1], dtype=float)
            tvj = (tv[:, None] if tv.ndim == 1 else tv)[:, j]
            ts = decimate(len(tx))
            a.plot(tx[ts], tvj[ts], "k--", lw=1.2, label="truth")
        for ev in events:
            a.axvline(ev, color="#888", lw=0.8, ls=":")
        lim = robust_limits([ln.get_ydata() for ln in a.get_lines() if ln.get_label() != "truth"],
                            tvj)
        if lim is not None:
            a.set_ylim(*lim)
        a.set_title(names[j], fontsize=10, loc="left")
        a.set_ylabel(names[j])
        a.grid(alpha=0.3)
        _date_axis(a, x)
        spec = a.get_subplotspec()
        if spec is None or spec.is_last_row() or not _below_is_visible(a):
            a.set_xlabel(xlabel)
            a.xaxis.set_tick_params(labelbottom=True)   # the last panel of its column
    if fresh and label is not None:
        fig.legend(*axes[0].get_legend_handles_labels(), loc="outside upper center",
                   ncol=2, fontsize=9, frameon=False)
    return fig


def _below_is_visible(ax) -> bool:
    """Whether the panel under ``ax`` in its grid is drawn (else ``ax`` carries the x label)."""
    spec = ax.get_subplotspec()
    gs = spec.get_gridspec()
    below = spec.rowspan.stop
    for other in ax.figure.axes:
        osp = other.get_subplotspec()
        if (other.get_visible() and osp is not None and osp.get_gridspec() is gs
                and osp.rowspan.start == below and osp.colspan.start == spec.colspan.start):
            return True
    return False


def panel_axes(count, *, ncols=2):
    """A new figure with ``count`` track panels in ``ncols`` columns: (figure, list of Axes)."""
    ncols = ncols if count > 1 else 1
    fig, axes, _ = _axes(None, count, lambda r: (11, 2.6 * r + 0.6), ncols=ncols, sharex=True)
    return fig, axes


def prediction_errors(x, error, *, label=None, title=None, xlabel="sample", color=None,
                      ax=None):
    r"""Prediction errors :math:`\varepsilon_k = y_k - \varphi_k^T\hat\theta_{k-1}` (or residuals).

    Parameters
    ----------
    x : array_like, shape (N,)
    error : array_like, shape (N,)
        NaN for skipped samples (not drawn).
    label, title, color : str, optional
    xlabel : str
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    x = _abscissa(x)
    e = np.asarray(error, dtype=float)
    fig, (a,), fresh = _axes(ax, 1, lambda r: (11, 2.8))
    sl = decimate(len(x))
    a.plot(x[sl], e[sl], color=color or COLORS[0], lw=0.7, alpha=0.85, label=label)
    _date_axis(a, x)
    if fresh:
        symmetric_limits(a, [e])
        finish_errors_axes(a, title, xlabel, 1)
    return fig


def symmetric_limits(ax, arrays):
    """y-limits ±max of the robust range of ``arrays`` (errors are centred on 0)."""
    lim = robust_limits(arrays)
    if lim is not None:
        m = max(abs(lim[0]), abs(lim[1]))
        ax.set_ylim(-m, m)


def finish_errors_axes(ax, title, xlabel, ncol):
    if title:
        ax.set_title(title, fontsize=10, loc="left")
    ax.grid(alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=8, loc="upper right", ncol=ncol)
    ax.set_xlabel(xlabel)


def cusum(x, result, *, title=None, xlabel="sample", ax=None,
          label="CUSUM of recursive residuals"):
    r"""The CUSUM :math:`W_j` of the recursive residuals and its bounds (Brown, Durbin & Evans 1975).

    Parameters
    ----------
    x : array_like, shape (m,)
        Abscissa of each recursive residual.
    result : CusumResult
        From :func:`adaptid.diagnostics.cusum` (``statistic``, ``upper``,
        ``lower``, ``alpha``, ``crossed``, ``first_crossing``).
    title : str, optional
        Prefix of the verdict in the title.
    xlabel : str
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    x = _abscissa(x)
    fig, (a,), _ = _axes(ax, 1, lambda r: (11, 3.0))
    sl = decimate(len(x))
    a.plot(x[sl], result.statistic[sl], color=COLORS[0], lw=1.1, label=label)
    a.plot(x[sl], result.upper[sl], "k--", lw=1, label=f"{100 * (1 - result.alpha):g} % bounds")
    a.plot(x[sl], result.lower[sl], "k--", lw=1)
    if result.first_crossing is not None:
        a.axvline(x[result.first_crossing], color=COLORS[1], lw=0.9, ls=":",
                  label="first crossing")
    # this one test's verdict only: "no evidence of change" is for all tests to say
    verdict = (f"{label}: bounds crossed" if result.crossed
               else f"{label}: within its bounds")
    a.set_title(f"{title}: {verdict}" if title else verdict, fontsize=10, loc="left")
    _date_axis(a, x)
    a.grid(alpha=0.3)
    a.legend(fontsize=8, loc="upper left")
    a.set_xlabel(xlabel)
    return fig


def _plt():
    try:
        import matplotlib.pyplot as plt
    except ImportError as err:  # pragma: no cover - depends on the extra
        raise ImportError("adaptid.plot needs matplotlib: pip install 'adaptid[plot]'") from err
    return plt


def _stacked_axes(fig, ax, n, height=1.6):
    """n stacked axes: the given ones, or new ones on ``fig`` / a new figure."""
    plt = _plt()
    if ax is not None:
        axes = list(np.atleast_1d(ax).ravel())
        if len(axes) != n:
            raise param_error("ax", f"{n} matplotlib Axes", f"<{len(axes)} axes>")
        return axes[0].figure, axes
    if fig is None:
        fig = plt.figure(figsize=(7, height * n + 0.8))
    return fig, list(fig.subplots(n, 1, sharex=True, squeeze=False)[:, 0])


def compare(result, *, ax=None, fig=None):
    """Measured output and every model's output, fit % in the legend.

    Parameters
    ----------
    result : adaptid.models.CompareResult
    ax : matplotlib Axes, optional
    fig : matplotlib Figure, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, (ax,) = _stacked_axes(fig, ax, 1, height=3.0)
    t = result.time
    ax.plot(t, result.y, color="k", lw=1.0, label=f"{result.y_name} (measured)")
    for name, yh, f in zip(result.names, result.y_hat, result.fit):
        ax.plot(t, yh, lw=1.0, label=f"{name}: {f:.2f} %")
    ax.set_ylabel(result.y_name)
    ax.set_xlabel("time")
    what = "simulation" if result.k is None else f"{result.k}-step prediction"
    ax.set_title(f"{what}: fit (NRMSE) %")
    ax.legend(loc="best", fontsize="small")
    return fig


def resid(result, *, ax=None, fig=None):
    """Residual autocorrelation and, per input, the residual–input cross-correlation.

    Parameters
    ----------
    result : adaptid.models.ResidResult
    ax : sequence of 1 + m matplotlib Axes, optional
    fig : matplotlib Figure, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    m = len(result.u_names)
    fig, axes = _stacked_axes(fig, ax, 1 + m, height=2.2)
    ac = result.autocorrelation
    lags = np.arange(ac["acf"].size)
    axes[0].stem(lags, ac["acf"])
    axes[0].axhspan(-ac["band"], ac["band"], alpha=0.2)
    verdict = "white" if result.white else "not white"
    axes[0].set_title(f"residuals of {result.y_name}: Ljung–Box p = {ac['p_value']:.3g} ({verdict})")
    axes[0].set_ylabel(f"autocorr. e({result.y_name})")
    for j, name in enumerate(result.u_names):
        cc = result.cross_correlation[j]
        ax_ = axes[1 + j]
        ax_.stem(cc["lags"], cc["ccf"])
        ax_.axhspan(-cc["band"], cc["band"], alpha=0.2)
        ok = "independent" if result.independent[j] else "correlated"
        ax_.set_title(f"e vs {name}: p = {cc['p_value']:.3g} ({ok})", fontsize="medium")
        ax_.set_ylabel(f"corr. e, {name}")
    axes[-1].set_xlabel("lag (samples)")
    fig.tight_layout()
    return fig


def fstats(x, result, *, breaks=(), alpha=0.05, title=None, xlabel="sample", ax=None):
    r"""The Chow F statistic of every candidate break date, supF's critical value, the breaks.

    Parameters
    ----------
    x : array_like, shape (N,)
        Abscissa of every sample (``x[result.candidates]`` are drawn).
    result : FstatsResult
        From :func:`adaptid.diagnostics.fstats` (Andrews 1993; Hansen 1997 p-values).
    breaks : sequence of int
        0-based last samples of the segments of a break dating
        (:func:`adaptid.diagnostics.breakpoints`), drawn as vertical lines.
    alpha : float
        Level of the critical line.
    title : str, optional
    xlabel : str
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    from scipy.optimize import brentq

    from .diagnostics._pvalues import pvalue_fstats

    x = np.asarray(x)
    fig, (a,), _ = _axes(ax, 1, lambda r: (11, 3.0))
    xc = x[result.candidates]
    a.plot(xc, result.F, color=COLORS[0], lw=1.1, label="F statistics")
    crit = brentq(lambda c: pvalue_fstats(c, "supF", result.n_params, result.lam) - alpha,
                  1e-9, 1e4)
    a.axhline(crit, color="k", ls="--", lw=1, label=f"supF {100 * (1 - alpha):g} % critical value")
    for j, b in enumerate(breaks):
        a.axvline(x[int(b)], color=COLORS[1], lw=1.0, ls=":",
                  label="dated break (BIC)" if j == 0 else None)
    t = result.test("supF")
    verdict = (f"supF = {t.statistic:.3g}, p = {t.pvalue:.3g}: "
               + ("a break" if t.pvalue < alpha else "no break"))
    a.set_title(f"{title}: {verdict}" if title else verdict, fontsize=10, loc="left")
    a.set_xlabel(xlabel)
    a.grid(alpha=0.3)
    a.legend(loc="best", fontsize=8, frameon=False)
    return fig
