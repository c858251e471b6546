r"""Figures of identification results (matplotlib, imported on first use).

* :func:`tracks` — parameter estimates against time, with ±2σ bands;
* :func:`compare` — measured output against model outputs
  (:func:`adaptid.models.compare`);
* :func:`resid` — residual autocorrelation and residual–input
  cross-correlation with their bands (:func:`adaptid.models.resid`).

Every function returns the matplotlib Figure; axes carry the data's names.
Requires matplotlib: ``pip install 'adaptid[plot]'``.
"""

from __future__ import annotations

import numpy as np

from ._validation import as_float_array, param_error

__all__ = ["tracks", "compare", "resid"]


def _plt():
    try:
        import matplotlib.pyplot as plt
    except ImportError as err:  # pragma: no cover - depends on the extra
        raise ImportError("adaptid.plot needs matplotlib: pip install 'adaptid[plot]'") from err
    return plt


def _axes(fig, ax, n, height=1.6):
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


def tracks(theta, *, x=None, names=None, stderr=None, fig=None, true_theta=None, xlabel=None):
    r"""Parameter tracks: one panel per parameter, ±2σ bands when ``stderr`` is given.

    Parameters
    ----------
    theta : array_like, shape (N, n)
        Estimates after each sample (``Trajectory.theta``).
    x : array_like, shape (N,), optional
        Time stamps or sample positions (default 0 … N-1).
    names : sequence of str, length n, optional
        Panel labels (default ``theta0`` …).
    stderr : array_like, shape (N, n), optional
        Standard errors; the band is :math:`\hat\theta_k \pm 2\,\mathrm{se}_k`.
    fig : matplotlib Figure, optional
    true_theta : array_like, shape (n,), optional
        Dashed reference lines.
    xlabel : str, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    theta = as_float_array(theta, "theta", ndim=2, finite=False)
    N, n = theta.shape
    x = np.arange(N) if x is None else np.asarray(x)
    if x.shape != (N,):
        raise param_error("x", f"of shape ({N},)", f"<shape {x.shape}>")
    names = [f"theta{i}" for i in range(n)] if names is None else [str(v) for v in names]
    if len(names) != n:
        raise param_error("names", f"{n} names", f"<{len(names)} names>")
    if stderr is not None:
        stderr = as_float_array(stderr, "stderr", shape=(N, n), finite=False)
    fig, axes = _axes(fig, None, n)
    for i, ax in enumerate(axes):
        ax.plot(x, theta[:, i], lw=1.0, label="estimate")
        if stderr is not None:
            ax.fill_between(x, theta[:, i] - 2 * stderr[:, i], theta[:, i] + 2 * stderr[:, i],
                            alpha=0.25, lw=0, label="±2σ")
        if true_theta is not None:
            ax.axhline(np.ravel(true_theta)[i], ls="--", color="k", lw=0.8)
        ax.set_ylabel(names[i])
    axes[-1].set_xlabel(xlabel or ("time" if x.dtype.kind == "M" or x.dtype.kind == "f" else "sample"))
    return fig


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
    fig, (ax,) = _axes(fig, ax, 1, height=3.0)
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
    fig, axes = _axes(fig, ax, 1 + m, height=2.2)
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
