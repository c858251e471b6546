r"""Figures of frequency responses: Bode (dB, degrees) and Nyquist, with bands.

Drawn for :meth:`FrequencyResponse.plot` and :func:`adaptid.models.compare`
with frequency-domain data: one panel (or magnitude–phase pair) per channel
on an ny × nu grid, every axis named with its unit.
"""

from __future__ import annotations

import numpy as np

from ..._lazy import pyplot

__all__ = ["bode", "nyquist"]


def _unit(fr, hz):
    if fr.dt is not None:
        return "Hz" if hz else "rad/s"
    return ("cycles" if hz else "rad") + " per time unit"


def _legend(fig, ax):
    handles, labels = ax.get_legend_handles_labels()
    if len(handles) > 1:      # outside the axes: the legend never covers the curves
        from matplotlib.layout_engine import ConstrainedLayoutEngine

        outside = isinstance(fig.get_layout_engine(), ConstrainedLayoutEngine)
        fig.legend(handles, labels, loc="outside upper right" if outside else "upper right",
                   fontsize=8, ncols=min(len(handles), 4))


def _channel(fr, i, j):
    """(G, |G| sd, arg sd) of channel (i, j) as 1-d arrays (sd None when unknown)."""
    ny, nu = len(fr.y_names), len(fr.u_names)
    pick = lambda a: None if a is None else a.reshape(ny, nu, -1)[i, j]   # noqa: E731
    return pick(fr.response), pick(fr.magnitude_sd), pick(fr.phase_sd)


def _bode_band(am, ap, f, G, msd, psd, sd, label):
    mag = np.abs(G)
    ph = np.degrees(np.unwrap(np.angle(G)))
    if sd > 0 and msd is not None:
        tiny = np.finfo(float).tiny
        lo = 20 * np.log10(np.maximum(mag - sd * msd, np.maximum(mag * 1e-6, tiny)))
        hi = 20 * np.log10(mag + sd * msd)
        am.fill_between(f, lo, hi, alpha=0.25, lw=0, label=label)
    if sd > 0 and psd is not None:
        ap.fill_between(f, ph - sd * np.degrees(psd), ph + sd * np.degrees(psd), alpha=0.25,
                        lw=0, label=label)


def bode(fr, sd=3, *, hz=False, fig=None, label="response", overlays=()):
    r"""Bode diagram of ``fr`` (and of ``overlays``: (label, FrequencyResponse) pairs).

    Rows 2i and 2i + 1 of the grid are output i's magnitude (dB) and phase
    (degrees), column j input j; each pair titled ``input → output``.
    """
    plt = pyplot()
    ny, nu = len(fr.y_names), len(fr.u_names)
    if fig is None:
        fig = plt.figure(figsize=(max(6.5, 3.6 * nu), max(5.5, 3.6 * ny)), layout="constrained")
    axes = fig.subplots(2 * ny, nu, squeeze=False, sharex=True)
    unit = _unit(fr, hz)
    scale = (lambda w: w / (2 * np.pi)) if hz else (lambda w: w)   # noqa: E731
    f = scale(fr.w)
    for i, yn in enumerate(fr.y_names):
        for j, un in enumerate(fr.u_names):
            am, ap = axes[2 * i, j], axes[2 * i + 1, j]
            G, msd, psd = _channel(fr, i, j)
            am.semilogx(f, 20 * np.log10(np.abs(G)), lw=1.2, label=label)
            ap.semilogx(f, np.degrees(np.unwrap(np.angle(G))), lw=1.2, label=label)
            _bode_band(am, ap, f, G, msd, psd, sd, f"±{sd:g} sd")
            for name, other in overlays:
                Go, mo, po = _channel(other, i, j)
                fo = scale(other.w)
                line = am.semilogx(fo, 20 * np.log10(np.abs(Go)), lw=1.0, ls="--", label=name)
                ap.semilogx(fo, np.degrees(np.unwrap(np.angle(Go))), lw=1.0, ls="--",
                            color=line[0].get_color(), label=name)
            am.set_title(f"{un} → {yn}", fontsize=9)
            am.set_ylabel("magnitude (dB)")
            ap.set_ylabel("phase (deg)")
            for ax in (am, ap):
                ax.set_xlabel(f"frequency ({unit})")
                if fr.dt is not None:
                    ax.axvline((0.5 / fr.dt) if hz else (np.pi / fr.dt), color="0.6", lw=0.8,
                               ls=":")
                ax.grid(True, which="both", lw=0.3)
    _legend(fig, axes[0, 0])
    fig.suptitle("Bode diagram", fontsize=10)
    return fig


def _ellipses(ax, G, msd, psd, sd, count):
    """±sd ellipses at ``count`` frequencies: radial half-axis sd·σ_|G|, tangential sd·|G|σ_arg."""
    from matplotlib.patches import Ellipse

    ok = np.flatnonzero(np.isfinite(G) & np.isfinite(msd) & np.isfinite(psd))
    if ok.size == 0:
        return
    for k in ok[np.unique(np.linspace(0, ok.size - 1, count).round().astype(int))]:
        ang = np.degrees(np.angle(G[k]))
        ax.add_patch(Ellipse((G[k].real, G[k].imag), 2 * sd * msd[k],
                             2 * sd * np.abs(G[k]) * psd[k], angle=ang, fill=False, lw=0.8,
                             color="C0", alpha=0.7))
    ax.plot([], [], color="C0", lw=0.8, alpha=0.7, label=f"±{sd:g} sd")


def nyquist(fr, sd=3, *, fig=None, ellipses=12, label="response", overlays=()):
    r"""Nyquist diagram of ``fr``: Im G against Re G per channel, ±sd ellipses.

    The ellipses are drawn at ``ellipses`` frequencies spread over the
    grid, with half-axes :math:`sd\cdot\sigma_{|G|}` along G and
    :math:`sd\cdot|G|\sigma_{\arg G}` across it (the first-order region
    of the magnitude and phase standard deviations, their correlation
    neglected). The point −1 is marked.
    """
    plt = pyplot()
    ny, nu = len(fr.y_names), len(fr.u_names)
    if fig is None:
        fig = plt.figure(figsize=(max(5.5, 3.8 * nu), max(5.0, 3.6 * ny)), layout="constrained")
    axes = fig.subplots(ny, nu, squeeze=False)
    for i, yn in enumerate(fr.y_names):
        for j, un in enumerate(fr.u_names):
            ax = axes[i, j]
            G, msd, psd = _channel(fr, i, j)
            ax.plot(G.real, G.imag, lw=1.2, label=label)
            ax.plot(G.real[:1], G.imag[:1], "o", ms=3, color="C0")
            if sd > 0 and msd is not None and psd is not None:
                _ellipses(ax, G, msd, psd, sd, ellipses)
            for name, other in overlays:
                Go = _channel(other, i, j)[0]
                ax.plot(Go.real, Go.imag, lw=1.0, ls="--", label=name)
            ax.plot([-1], [0], "+", color="k", ms=8)
            ax.axhline(0, color="0.6", lw=0.6)
            ax.axvline(0, color="0.6", lw=0.6)
            ax.set_title(f"{un} → {yn}", fontsize=9)
            ax.set_xlabel(f"Re G ({yn}/{un})")
            ax.set_ylabel(f"Im G ({yn}/{un})")
            ax.grid(True, lw=0.3)
    _legend(fig, axes[0, 0])
    w0, w1 = (fr.w[0], fr.w[-1]) if fr.w.size else (0, 0)
    unit = _unit(fr, False)
    fig.suptitle(f"Nyquist diagram (w = {w0:.3g} … {w1:.3g} {unit}; ○ first frequency)",
                 fontsize=10)
    return fig
