r"""The workflow options of ``adaptid fit --fir NB[,NK] --method fastrls`` (issue 38).

``--detrend``, ``--validate``, ``--summary`` and ``--out`` do what they do
for ``--method rls`` on the same FIR structure, through the functions of
that path:

* **the record** (:func:`._problem._record`): split first, then each part
  detrended on its own (issue 33: MATLAB practice); FastRLS runs on the
  estimation part and the JSON gives both parts' offsets
  (:func:`._problem.detrend_offsets`);
* **--validate** (:func:`._fit._workflow`, :func:`._modelfit.validate`): the
  FIR model at the final estimate,

  .. math::

      \hat y_k = \sum_{j=0}^{n_b-1} b_j\,u_{k-n_k-j},

  simulated on the held-out part from zero initial conditions, as
  ``ARX(0, nb, nk).simulate`` does for the rls path: fit % (NRMSE), and the
  Ljung–Box and cross-correlation tests of its one-step errors from sample
  nb + nk − 1 on (:func:`adaptid.models.compare`, :func:`~adaptid.models.resid`);
* **--summary**: the table of :func:`adaptid.models.recursive_summary` for
  the equivalent :class:`adaptid.RLS` (``forgetting=λ``,
  ``P0=diag(λ**arange(n))/δ`` on the prewindowed regressors): the columns
  estimate, std err, t, P>|t| and the limits with Σc_k − n degrees of
  freedom, and N, N effective, dof, σ̂², SSR, log-likelihood, AIC, BIC, FPE
  and the Ljung–Box p-value of the final estimate's residuals. The standard
  errors are those of :func:`._fastrls.fastrls_theory` (FastRLS holds no
  P); where they are not computed (after ``--resume``, or beyond
  :data:`._fastrls.STDERR_MAX_WORK`) the columns that need them are NaN and
  a note under the table says why;
* **--out** (:func:`._fit._write_report`): the report of the rls path
  (estimates, validation, model output and residual figures, prediction
  errors, the constancy tests when N and n keep them quick
  (:data:`CONSTANCY_MAX_WORK`, :data:`BREAK_DATING_MAX_WORK`; else a note),
  ``estimates.csv``), with its own figure of
  the tracks, :func:`tracks_overview`: up to :data:`MAX_TRACK_PANELS` taps one
  panel per tap; a longer filter a heat map of every tap over time and the
  :data:`MAX_TRACK_PANELS` taps largest at the end as lines, so that the
  figure keeps one size for any number of taps. No ±2σ band (no P).
"""

from __future__ import annotations

import numpy as np

from ._errors import CLIError

__all__ = ["check_workflow", "record", "FIRModel", "fastrls_summary", "tracks_overview",
           "finish", "MAX_TRACK_PANELS"]

#: Taps drawn one panel each in the report; a longer filter gets the overview figure.
MAX_TRACK_PANELS = 8
#: Time points of the heat map and the lines (the figure's resolution).
HEATMAP_POINTS = 1000
#: The report's constancy tests run when N·n² is at most this (the battery of
#: ``diagnostics.change_tests`` costs O(N n²) with a large constant: minutes for
#: N = 20000 samples of 64 taps) ...
CONSTANCY_MAX_WORK = 2e7
#: ... and, when the break dates are estimated (N up to ``_engine.MAX_BREAK_DATING``),
#: N²·n² at most this (``diagnostics.breakpoints``, O(N² n²)).
BREAK_DATING_MAX_WORK = 2e10


def check_workflow(structure, *, export_c):
    """Before reading: what the workflow options cannot do with the delay-line filter."""
    if export_c is not None and structure.detrend is not None:
        raise CLIError("--export-c with --detrend does not apply to --method fastrls: the "
                       "filter's C code (NAME_update(s, u, y)) has no offsets; remove them in "
                       "your code, or use --method rls (its C model removes constant offsets)")


def record(table, structure, nan, names):
    """``(Problem, u, y, complete-row mask)`` of the estimation part.

    The record of the rls path (:func:`._problem._record`: ``--nan``,
    ``--time``, ``--dt``, split, detrend), one equation ``FIR`` whose rows
    are every sample of the estimation part (the delay line is prewindowed).
    """
    from ._problem import Problem, _record

    data, est, val, cols, time, is_dt, n_nan, source = _record(table, structure, nan)
    if len(cols) != 1:
        raise CLIError(f"--method fastrls takes one --u column (a single delay line), got "
                       f"{len(cols)}")
    y = np.ascontiguousarray(np.asarray(est.y, dtype=np.float64).reshape(-1))
    u = np.ascontiguousarray(np.asarray(est.inputs, dtype=np.float64)[:, 0])
    problem = Problem("fir", [("FIR", list(names), None, y, np.arange(len(y)))],
                      len(data) if data is not None else len(est), time=time,
                      columns=[structure.y, *cols], nan_rows=n_nan, data=data, est_data=est,
                      val_data=val, time_name=structure.time, datetime=is_dt,
                      dt_source=source)
    return problem, u, y, np.isfinite(u) & np.isfinite(y)


class FIRModel:
    r"""The FIR model at the filter's estimate, for compare/resid.

    :math:`\hat y_k = \sum_j b_j u_{k-n_k-j}` from zero initial conditions
    (``scipy.signal.lfilter``); with no output lags the k-step prediction is
    the simulation. ``index[0]`` = nb + nk − 1 is the first sample with a
    full regressor, as ``ARX(0, nb, nk)``'s, where :func:`adaptid.models.resid`
    starts.
    """

    def __init__(self, theta, nk, label):
        self.theta = np.asarray(theta, dtype=np.float64).copy()
        self.nk, self.label = int(nk), label
        self.index = np.array([self.theta.size + self.nk - 1])

    def simulate(self, u):
        from scipy.signal import lfilter

        v = np.asarray(u, dtype=np.float64).reshape(-1)    # the one input
        return lfilter(np.concatenate([np.zeros(self.nk), self.theta]), [1.0], v)

    def predict(self, y, u, k=1):
        return self.simulate(u)

    def __repr__(self):
        return self.label


def fastrls_summary(fit, line, *, alpha=0.05, max_lag=25):
    """The summary table of the rls path (see the module docstring) for the filter's fit."""
    from adaptid._summary import Summary, parameter_rows
    from adaptid._teststats import gaussian_llf, information_criteria, ljung_box

    theta = np.asarray(fit.theta, dtype=np.float64)
    n = theta.size
    r, c = line.r, line.c          # the final θ's residuals, c_k = λ^(N−k) (cli/_fastrls.py)
    ssr, n_eff = float(np.sum(c * r * r)), float(np.sum(c))
    dof = n_eff - n
    llf = gaussian_llf(ssr, n_eff)
    ic = information_criteria(llf, n_eff, n, loss=ssr / n_eff)
    st = {"method": "FastRLS", "N": int(fit.n_samples), "N effective": n_eff, "dof": dof,
          "sigma^2": fit.sigma2, "SSR": ssr, "log-likelihood": llf, "AIC": ic["aic"],
          "BIC": ic["bic"], "FPE": ic["fpe"]}
    if r.size > 2 and np.ptp(r) > 0:
        M = min(max_lag, r.size - 1)
        st[f"Ljung-Box p (lags 1..{M})"] = ljung_box(r, M, alpha)["p_value"]
    notes = ["sigma^2, stderr, dof: the rule of adaptid.recursive_fit_stats for the equivalent "
             "RLS (forgetting=lambda, P0=diag(lambda**i)/delta); FastRLS holds no P, so P "
             "comes from a QR of the weighted regressors"]
    if not np.isfinite(fit.stderr).any():
        why = [w for w in fit.warnings if w.startswith("stderr")]
        notes.append("std err, t, P>|t| and the limits are not available (NaN): "
                     + (why[0] if why else "the degrees of freedom are not positive"))
    with np.errstate(invalid="ignore"):
        params = parameter_rows(theta, np.asarray(fit.stderr, dtype=np.float64), dof, alpha)
    return Summary(title="Recursive fit (FastRLS)", names=tuple(fit.names), params=params,
                   stats=st, alpha=alpha, notes=tuple(notes))


def tracks_overview(problem, fit):
    """``(Figure, caption)`` of the estimates over time (see the module docstring)."""
    from adaptid import plot

    rows = fit.index if fit.ends is None else fit.ends
    use_time = problem.time is not None
    x = np.asarray(problem.time)[rows] if use_time else rows + 1.0
    xlabel = (problem.time_name or "time") if use_time else "sample"
    th, n = np.asarray(fit.track, dtype=np.float64), len(fit.names)
    read = ("" if fit.ends is None else
            f" θ read at {len(rows)} evenly spaced samples (a long record; every sample with "
            "--tracks FILE).")
    nobands = " FastRLS holds no P: no ±2σ band; the standard errors of the final estimate " \
              "are in the table above."
    if n <= MAX_TRACK_PANELS:
        fig, axes = plot.panel_axes(n)
        plot.tracks(x, th, fit.names, label=fit.label, xlabel=xlabel, ax=axes)
        fig.legend(*axes[0].get_legend_handles_labels(), loc="outside upper center", ncol=1,
                   fontsize=9, frameon=False)
        return fig, "Estimates after each sample." + read + nobands
    fig, top, vmax = _overview(x, th, fit.names, xlabel, fit.label)
    caption = (f"{n} taps, too many for one panel each: the heat map shows every tap's "
               f"estimate over time (colours clipped at ±{vmax:.3g}), the lines the "
               f"{len(top)} taps largest in magnitude at the end ({', '.join(top)}). Every "
               "final estimate is in the table above and estimates.csv." + read + nobands)
    return fig, caption


def _overview(x, th, names, xlabel, label):
    """The heat map of every tap and the lines of the largest ones: (fig, their names, vmax)."""
    from adaptid import plot

    step = max(1, len(x) // HEATMAP_POINTS)
    xs, ts = x[::step], th[::step]
    settled = th[len(th) // 20:]              # the colour scale after the first transient
    finite = np.abs(settled[np.isfinite(settled)])
    vmax = float(np.percentile(finite, 99.5)) if finite.size else 1.0
    vmax = vmax if vmax > 0 else 1.0
    fig = plot.new_figure((11, 7.2))
    heat, lines = fig.subplots(2, 1, sharex=True, height_ratios=[3, 2])
    mesh = heat.pcolormesh(xs, np.arange(th.shape[1]), ts.T, shading="nearest", cmap="RdBu_r",
                           vmin=-vmax, vmax=vmax, rasterized=True)
    fig.colorbar(mesh, ax=heat, label="estimate", pad=0.01)
    heat.yaxis.get_major_locator().set_params(integer=True)   # taps are whole numbers
    heat.set_ylabel("tap j (b_j)")
    heat.set_title(f"every tap: {label}", fontsize=10)
    final = np.where(np.isfinite(th[-1]), np.abs(th[-1]), -1.0)
    top = np.sort(np.argsort(-final, kind="stable")[:MAX_TRACK_PANELS])
    colors = _colors(len(top))
    for i, j in enumerate(top):
        lines.plot(xs, ts[:, j], lw=1.0, color=colors[i], label=names[j])
    lim = plot.robust_limits([ts[:, j] for j in top])
    if lim is not None:
        lines.set_ylim(*lim)
    lines.set_xlabel(xlabel)
    lines.set_ylabel("estimate")
    lines.set_title(f"the {len(top)} taps largest at the end", fontsize=10)
    lines.grid(alpha=0.3)
    lines.legend(ncol=min(len(top), 8), fontsize=8, frameon=False, loc="best")
    return fig, [names[j] for j in top], vmax


def _colors(k):
    """k distinct colours (matplotlib's tab10)."""
    import matplotlib

    cmap = matplotlib.colormaps["tab10"]
    return [cmap(i % 10) for i in range(k)]


def _constancy_affordable(N, n) -> bool:
    """Whether the constancy tests fit :data:`CONSTANCY_MAX_WORK` and
    :data:`BREAK_DATING_MAX_WORK` (the report of a long filter stays quick)."""
    from ._engine import MAX_BREAK_DATING

    N, n = float(N), float(n)
    if N * n * n > CONSTANCY_MAX_WORK:
        return False
    return N > MAX_BREAK_DATING or N * N * n * n <= BREAK_DATING_MAX_WORK


def _constancy(fit, line):
    """The report's constancy tests (:func:`._engine._cusum`, as for the rls path) on
    the run's rows with a full regressor; None when too short for them."""
    from ._engine import _cusum

    n = len(fit.names)
    Phi = np.full((line.ok.size, n), np.nan)          # skipped rows stay NaN (left out)
    Phi[line.ok] = line.rows
    # the rows of the rls path: those whose regressor holds no zero of the prewindow
    Phi[np.flatnonzero(line.ok)[:line.first_full]] = np.nan
    y = np.full(line.ok.size, np.nan)
    y[line.ok] = line.y
    return _cusum(Phi, y)


def finish(result, table, problem, structure, fit, line, *, out, summary):
    """Offsets, --validate, --summary and the staged --out report; ``(report, summaries)``."""
    from ._fit import _workflow, _write_report
    from ._modelfit import summary_json
    from ._problem import detrend_offsets

    result["n_rows"] = int(problem.n_rows)
    if problem.data is not None:
        result["dt"], result["dt_source"] = float(problem.data.dt), problem.dt_source
    if structure.detrend is not None:
        result["detrend"] = structure.detrend
        result["detrend_offsets"] = detrend_offsets(problem)
    model = FIRModel(fit.theta, structure.fir[1], fit.label)
    checks = _workflow(problem, structure, [fit], {fit.title: model},
                       want_figures=out is not None)
    if checks.get("validation") is not None:
        result["validation"] = checks["validation"]
    summ = None
    if summary:
        summ = [fastrls_summary(fit, line)]
        result["summary"] = [summary_json(x) for x in summ]
    rep = None
    if out is not None:
        small = _constancy_affordable(line.y.size, len(fit.names))
        fit.cusum = _constancy(fit, line) if small else None
        figure = tracks_overview(problem, fit)
        if not small:
            figure = (figure[0], figure[1] + " The constancy tests (CUSUM, F tests, break "
                      "dates) are left out: their cost, O(N n²) and O(N² n²), is beyond the "
                      "bounds of cli/_fastrls_workflow.py for this N and n.")
        rep = _write_report(out, table, problem, [fit], None, result, checks=checks,
                            tracks_figure=figure)
        result["report"] = str(rep.out / "index.html")
    return rep, summ
