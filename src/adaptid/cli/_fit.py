"""``adaptid fit DATA``: read a file, build the regression, estimate, report."""

from __future__ import annotations

import os
import time as _time
import warnings
from pathlib import Path

import numpy as np

from ._engine import MethodSpec, fit_equation
from ._errors import CLIError
from ..io import read_table
from ._output import Output
from ._problem import PSEUDO_LINEAR, Problem, Structure, build_problem, detrend_offsets
from ._targets import c_targets, check_targets, report_targets, state_lock

__all__ = ["run_fit"]

N_CHUNKS = 200
#: --nan: the words of Python's ``nan_policy``; "error" is kept as an alias of "raise"
NAN_WORDS = {"raise": "raise", "skip": "skip", "error": "raise"}


def _load_resume(path):
    """``(estimator, labels)`` of the ``--resume`` file (labels None for a Python save)."""
    from adaptid._exceptions import StateFileError
    from adaptid.estimators._statefile import load_state_labelled

    try:
        est, labels = load_state_labelled(path)
    except StateFileError as err:
        raise CLIError(f"--resume: {err}") from None
    kind = type(est).__name__
    if kind.startswith("Recursive"):  # a streaming model object saved from Python
        raise CLIError(f"--resume {path}: a {kind} state (saved from Python); adaptid fit "
                       "resumes the states its --save-state writes (the estimator, labelled "
                       f"with the model) or an estimator's (RLS, ...); continue a {kind} in "
                       f"Python ({kind}.load_state)")
    return est, labels


def _labels(structure: Structure, problem: Problem) -> dict:
    """What a state saved by ``fit`` means: the model, the output and the regressors."""
    title, names = problem.equations[0][0], problem.equations[0][1]
    labels = {"saved_by": "adaptid fit", "model": problem.kind,
              "output": str(structure.y or title), "regressors": [str(n) for n in names]}
    if structure.is_model:  # the names of --arx 2,2,1 and 2,2,3 are the same: nk is not
        labels["orders"] = ",".join(map(str, structure.orders))
    return labels


def _check_labels(labels, want: dict, resume) -> None:
    """Refuse to resume a state saved for another model, output or regressor order."""
    if labels is None or labels.get("saved_by") != "adaptid fit":
        return  # saved from Python: only the parameter count can be checked
    for key, what in (("model", "model"), ("output", "output"), ("regressors", "regressors"),
                      ("orders", f"--{want['model']} orders")):
        if key == "orders" and (key not in labels or key not in want):
            continue  # saved before the orders were labelled (or a run without orders)
        have, given = labels.get(key), want[key]
        if have != given:
            show = (lambda v: ",".join(v) if isinstance(v, list) else str(v))
            order = (" (the same names in another order)" if key == "regressors"
                     and isinstance(have, list) and sorted(have) == sorted(given) else "")
            raise CLIError(f"--resume {resume}: the state was saved for {what} {show(have)!r}, "
                           f"this run has {show(given)!r}{order}; use the options it was saved "
                           "with or start a new state")


def _check_extras(structure: Structure, spec: MethodSpec, *, save_state, resume, tracks,
                  export_c, c_name):
    """Combinations of the workflow options (--tracks, --export-c, --arma/--bj) that cannot work."""
    kind = structure.kind
    if kind in PSEUDO_LINEAR and (save_state is not None or resume is not None):
        raise CLIError(f"--save-state/--resume are not available with --{kind}: its recursion "
                       "(pseudo-linear regression on filtered signals) has more state than an "
                       "estimator's")
    if tracks is not None and spec.resolved == "batch" and resume is None:
        raise CLIError("--tracks needs a recursive method (rls, window, kalman, lms, nlms): --method batch "
                       "has one estimate, no per-sample track")
    if export_c is not None:
        if spec.resolved == "batch" and resume is None:
            raise CLIError("--export-c needs a recursive method (rls, window, kalman, lms, nlms): --method "
                           "batch has no estimator to continue in C")
        if kind in PSEUDO_LINEAR:
            raise CLIError(f"--export-c is not available with --{kind}: its recursion filters the "
                           "regressors with the running estimate (pseudo-linear regression), not "
                           "a plain estimator run; export an --arx, --fir, --ar or --phi fit")
        if kind == "dc-motor":
            raise CLIError("--export-c is not available with --dc-motor (two estimators on "
                           "filtered derivatives); use --y/--phi with the regressor columns")
        if kind in ("arx", "ar", "fir") and structure.detrend == "linear":
            raise CLIError("--export-c with --detrend linear: the C model removes constant "
                           "offsets from raw measurements, a line cannot be continued; use "
                           "--detrend constant")
        if not c_name.isidentifier() or not c_name.isascii():
            raise CLIError(f"--c-name must be a C identifier (letters, digits, _), got {c_name!r}")
        from ..codegen._generate import check_name
        try:  # reserved words and header names refused before the run, too
            check_name(c_name)
        except ValueError as err:
            raise CLIError(f"--c-name: {err}") from None
    elif c_name != "rls":
        raise CLIError("--c-name applies with --export-c DIR only")
    if tracks is not None:
        from ..io import check_writable

        low = str(tracks).lower()
        if not low.endswith((".csv", ".parquet", ".pq")):
            raise CLIError(f"--tracks {tracks}: the name must end in .csv or .parquet")
        try:
            check_writable(tracks, what="--tracks")
        except ValueError as err:
            raise CLIError(f"--tracks: {err}") from None


def check_files(data, structure, spec, *, out, save_state, resume, tracks, export_c, c_name,
                float32):
    """The file checks of every ``fit`` path, before anything is read or written: the
    options that need another, the outputs' folders, and no output over an input."""
    if float32 and export_c is None:
        raise CLIError("--float32 applies with --export-c DIR only")
    _check_extras(structure, spec, save_state=save_state, resume=resume, tracks=tracks,
                  export_c=export_c, c_name=c_name)
    check_outputs(data, out=out, save_state=save_state, resume=resume)
    check_targets([("DATA", data), ("--resume", resume)],
                  report_targets(out) + [("--tracks", tracks), ("--save-state", save_state)]
                  + c_targets(export_c, c_name), allowed={("--save-state", "--resume")})


def run_fit(data, structure: Structure, spec: MethodSpec, *, nan: str, out=None,
            save_state=None, resume=None, output: Output, tracks=None, summary=False,
            export_c=None, c_name="rls", float32=False) -> dict:
    """The whole ``fit`` command; returns the JSON-ready result.

    (``--method fastrls`` goes to :func:`._fastrls.run_fastrls` instead: the
    command dispatches, see ``_app.fit``.)
    """
    t0 = _time.perf_counter()
    structure.check()
    if nan not in NAN_WORDS:
        raise CLIError(f"--nan must be raise or skip (error: the same as raise), got {nan!r}")
    if spec.method is None:
        from ._modelfit import default_method

        spec.default = default_method(structure, {
            "--forgetting": spec.forgetting, "--window": spec.window,
            "--process-cov": spec.process_cov, "--noise-var": spec.noise_var, "--P0": spec.P0,
            "--step": spec.step, "--eps": spec.eps, "--tracks": tracks, "--export-c": export_c,
            "--save-state": save_state, "--resume": resume})
    spec.check(resume=resume, save_state=save_state)
    if structure.kind == "dc-motor" and (save_state is not None or resume is not None):
        raise CLIError("--save-state/--resume are not available with --dc-motor (two estimators "
                       "and filtered derivatives); use --y/--phi with the regressor columns")
    check_files(data, structure, spec, out=out, save_state=save_state, resume=resume,
                tracks=tracks, export_c=export_c, c_name=c_name, float32=float32)
    with state_lock(save_state if save_state is not None else resume):
        return _run_fit_locked(data, structure, spec, nan=nan, out=out, save_state=save_state,
                               resume=resume, output=output, tracks=tracks, summary=summary,
                               export_c=export_c, c_name=c_name, float32=float32, t0=t0)


def _run_fit_locked(data, structure, spec, *, nan, out, save_state, resume, output, tracks,
                    summary, export_c, c_name, float32, t0) -> dict:
    """``run_fit`` after the checks, holding the state lock: read, fit, report, save."""
    est0, labels = _load_resume(resume) if resume is not None else (None, None)

    table = read_table(data, columns=structure.columns())
    output.detail(f"read {table.path} ({table.kind}): columns {', '.join(table.names[:20])}")
    policy = NAN_WORDS[nan]
    problem = build_problem(table, structure, policy)
    if est0 is not None:
        n = problem.equations[0][2].shape[1]
        est0 = spec.adopt(est0, n, policy, resume)
        _check_labels(labels, _labels(structure, problem), resume)
    _check_sample_counts(table, problem, spec, est0=est0, save_state=save_state, output=output)
    want_cusum = out is not None and problem.kind not in PSEUDO_LINEAR
    total = sum(len(eq[3]) for eq in problem.equations)
    fits, fitted_models = [], {}
    from ._modelfit import fit_model_equation, stream_runner, uses_model, uses_stream

    with output.progress(total, f"fitting ({spec.resolved})") as advance:
        for title, names, Phi, y, index in problem.equations:
            if uses_model(problem, structure, spec):  # the model object's fit / fit_recursive
                f, model = fit_model_equation(problem, structure, spec, nan_policy=policy,
                                              advance=advance)
                if want_cusum and Phi is not None:
                    from ._engine import _cusum

                    f.cusum = _cusum(Phi, y)
                fitted_models[f.title] = model
                fits.append(f)
                continue
            # --arx/--ar/--fir with a recursive method: the streaming object on the estimator
            runner = stream_runner(problem, structure) \
                if uses_stream(problem, structure, spec) else None
            fits.append(fit_equation(title, names, Phi, y, index, spec, nan_policy=policy,
                                     est=est0, n_chunks=N_CHUNKS, advance=advance,
                                     want_cusum=want_cusum, runner=runner))
    for f in fits:
        for w in f.warnings:
            output.warn(f"{f.title}: {w}")
    physical = None
    if problem.regs is not None:
        from ._physical import physical_estimates

        physical = physical_estimates(problem.regs, fits[0], fits[1])

    result = _result(table, problem, fits, spec, physical, policy)
    if problem.data is not None:
        result["dt"], result["dt_source"] = float(problem.data.dt), problem.dt_source
    if structure.detrend is not None:
        result["detrend"] = structure.detrend
        result["detrend_offsets"] = detrend_offsets(problem)
    checks = _workflow(problem, structure, fits, fitted_models, want_figures=out is not None)
    if checks.get("validation") is not None:
        result["validation"] = checks["validation"]
    summ = None
    if summary:
        from ._modelfit import summaries, summary_json

        summ = summaries(problem, fits, fitted_models)
        result["summary"] = [summary_json(x) for x in summ]
    result["elapsed_s"] = _time.perf_counter() - t0
    rep = None
    if out is not None:
        rep = _write_report(out, table, problem, fits, physical, result, checks=checks)
        result["report"] = str(rep.out / "index.html")
    _write_outputs(result, problem, fits, tracks=tracks, export_c=export_c, c_name=c_name,
                   float32=float32, structure=structure)
    if rep is not None:
        rep.commit()  # after the other outputs: a failure there leaves no report
    _print(output, result, fits, physical, summ)
    if output.json:
        output.emit_json(result)  # a failed write (a full disk) stops here, state unsaved
    if save_state is not None:  # last, after everything else succeeded (save_state is atomic)
        from adaptid.estimators._statefile import save_state as _save

        try:
            _save(fits[0].estimator, save_state, labels=_labels(structure, problem))
        except OSError as err:
            raise CLIError(f"--save-state {save_state}: cannot write ({err.strerror or err}); "
                           "the results above were not saved") from None
    return result


def _check_sample_counts(table, problem, spec, *, est0, save_state, output):
    """Refuse an equation with no samples or a window longer than the data; warn when N < n."""
    for title, names, Phi, y, index in problem.equations:
        if len(y) == 0:
            raise CLIError(f"{table.path}: no samples left for the {title} regression "
                           f"({problem.n_rows} rows in the file)")
        if (est0 is None and save_state is None and spec.resolved == "window"
                and spec.window is not None and spec.window > len(y)):
            # checked before the window's buffer is allocated; with --save-state a
            # later --resume may fill it
            raise CLIError(f"--window must be at most the number of samples ({len(y)}, "
                           f"{title}) unless --save-state is given, got {spec.window}")
    for title, names, Phi, y, index in problem.equations:
        if Phi is not None and est0 is None and len(y) < Phi.shape[1]:
            output.warn(f"{title}: {len(y)} samples for {Phi.shape[1]} parameters; the data "
                        "do not determine the estimate (it stays near the prior)")


def _write_outputs(result, problem, fits, *, tracks, export_c, c_name, float32, structure=None):
    """--tracks FILE and --export-c DIR (after the fit and the report)."""
    if tracks is not None:
        from ..io import write_table
        from ._modelfit import tracks_frame

        try:
            write_table(tracks_frame(problem, fits), tracks, index=False)
        except ValueError as err:
            raise CLIError(f"--tracks: {err}") from None
        result["tracks"] = str(tracks)
    if export_c is not None:
        from ._export import write_c

        est, offsets = fits[0].estimator, None
        kind = getattr(structure, "kind", None)
        if kind in ("arx", "ar", "fir") and not structure.intercept:
            # issue 33 point 8: the model's NAME_step (lag buffers, --detrend offsets) with
            # the estimator's NAME_update in the same files (docs/embedded.md)
            from ..codegen._model import fit_offsets, stream_of_fit

            na, nb, nk = (structure.arx if kind == "arx" else (structure.ar[0], 0, 1)
                          if kind == "ar" else (0, *structure.fir))
            m = 0 if kind == "ar" else len(problem.columns) - 1
            est = stream_of_fit(est, na=na, nb=nb, nk=nk, n_inputs=m)
            offsets = fit_offsets(problem.est_data, m)
        result["export_c"] = [str(p) for p in write_c(est, export_c, c_name, float32,
                                                      option="--export-c", offsets=offsets)]


def _workflow(problem, structure, fits, fitted_models, *, want_figures) -> dict:
    """--validate numbers and the compare/resid results for the report (model fits)."""
    from ._modelfit import validate, validation_model

    out = {}
    wanted = structure.validate is not None or (want_figures and structure.is_model)
    if not wanted or problem.data is None or problem.kind == "dc-motor":
        return out
    f = fits[0]
    model, k, label = validation_model(problem, structure, f, fitted_models.get(f.title))
    if structure.validate is not None:
        v, cmp, res = validate(problem.val_data, model, k, label, what="--validate")
        v["fraction"] = structure.validate
        out["validation"] = v
        out["on"] = "validation"
    else:
        _, cmp, res = validate(problem.est_data, model, k, label, what="compare/resid")
        out["on"] = "estimation"
    if want_figures and (structure.is_model or structure.validate is not None):
        out["compare"], out["resid"] = cmp, res
    return out


def check_outputs(data, *, out=None, save_state=None, resume=None):
    """Before reading or computing anything: every output can be written and is no input.

    ``--save-state`` may name the ``--resume`` file (that advances it), never the
    data file; ``--out`` must be a folder that exists or can be created.
    """
    from ..io import check_writable

    inputs = [p for p in (data, resume) if p is not None and os.path.exists(p)]
    if save_state is not None:
        try:
            check_writable(save_state, what="--save-state")
        except ValueError as err:
            raise CLIError(f"--save-state: {err}") from None
        if os.path.exists(save_state) and os.path.exists(data) and os.path.samefile(save_state, data):
            raise CLIError(f"--save-state {save_state} is the data file; choose another name")
    if out is not None:
        folder = Path(os.fspath(out))
        if folder.exists() and not folder.is_dir():
            raise CLIError(f"--out {folder}: exists and is not a folder")
        for p in inputs:
            if folder.exists() and os.path.samefile(folder, p):
                raise CLIError(f"--out {folder} is the input {p}")
        probe = folder
        while not probe.exists():
            probe = probe.parent
        if not probe.is_dir():
            raise CLIError(f"--out {folder}: cannot create the report folder ({probe} is not a "
                           "folder)")
        if not os.access(probe, os.W_OK | os.X_OK):
            raise CLIError(f"--out {folder}: cannot create the report folder ({probe} is not "
                           "writable)")


def _result(table, problem: Problem, fits, spec, physical, nan) -> dict:
    names, theta, stderr = [], [], []
    for f in fits:
        prefix = f"{f.title}:" if len(fits) > 1 else ""
        names += [prefix + n for n in f.names]
        theta += list(f.theta)
        stderr += list(f.stderr)
    res = {
        "file": str(table.path),
        "model": problem.kind,
        "method": spec.resolved,
        "names": names,
        "theta": theta,
        "stderr": stderr,
        "n_samples": int(fits[0].n_samples),
        "n_skipped": int(sum(f.n_skipped for f in fits)),
        "n_rows": int(problem.n_rows),
        "nan_policy": nan,
        "sigma2": [f.sigma2 for f in fits] if len(fits) > 1 else fits[0].sigma2,
        "rms_error": [f.rms_error for f in fits] if len(fits) > 1 else fits[0].rms_error,
        "warnings": [f"{f.title}: {w}" for f in fits for w in f.warnings],
    }
    if len(fits) > 1:
        res["equations"] = {f.title: {"names": f.names, "theta": list(f.theta),
                                      "stderr": list(f.stderr), "n_samples": f.n_samples,
                                      "n_skipped": f.n_skipped} for f in fits}
    est = fits[0].estimator
    if est is not None:
        res["n_updates"] = int(est.n_updates)
        opts = {k: v for k, v in est.get_state()["options"].items() if k not in ("nan_policy", "process_cov")}
        if hasattr(est, "process_cov"):
            opts["process_cov_diag"] = list(np.diag(est.process_cov))
        res["options"] = {k: (v if isinstance(v, (int, float, list)) else str(v)) for k, v in opts.items()}
    if physical is not None:
        res["physical"] = {k: {"estimate": v[0], "stderr": v[1]} for k, v in physical.items()}
    return res


def _print(output: Output, result, fits, physical, summ=None):
    if not output.chatty:
        return
    from ._output import rich_table

    c = output.console
    skipped = result["n_skipped"]
    c.print(f"adaptid fit {result['file']}: {result['model']} model, {fits[0].label}, "
            f"{result['n_samples']} samples, {skipped} skipped"
            + (" (rows with missing values, --nan skip)" if skipped else ""),
            markup=False, soft_wrap=True)
    for f in fits:
        c.print(rich_table(f"{f.title}: RMS a-priori error {f.rms_error:.4g}"
                           if f.track is not None else f"{f.title}: RMS residual {f.rms_error:.4g}",
                           ["parameter", "estimate", "stderr"],
                           [[n, f"{th:.6g}", f"{se:.3g}"] for n, th, se in zip(f.names, f.theta, f.stderr)]))
    if physical is not None:
        c.print(rich_table("physical parameters", ["parameter", "estimate", "stderr"],
                           [[k, f"{v:.6g}", f"{se:.3g}"] for k, (v, se) in physical.items()]))
    if "validation" in result:
        from ._modelfit import validation_rows

        v = result["validation"]
        c.print(rich_table(f"validation on the held-out {v['n_samples']} samples "
                           f"(last {100 * (1 - v['fraction']):.3g} %)", ["check", "value", "verdict"],
                           validation_rows(v)))
    for x in summ or ():
        c.print(x.as_text(), markup=False, soft_wrap=True)
    for key, what in (("tracks", "tracks"), ("report", "report")):
        if key in result:
            c.print(f"{what}: {result[key]}", markup=False, soft_wrap=True)
    if "export_c" in result:
        c.print("C code: " + ", ".join(result["export_c"]), markup=False, soft_wrap=True)
    output.detail(f"done in {result['elapsed_s']:.2f} s", markup=False, soft_wrap=True)


def _report_checks(rep, checks):
    """The report's validation table and compare/resid figures (model fits)."""
    if "validation" in checks:
        from ._modelfit import validation_rows

        v = checks["validation"]
        rep.section("Validation")
        rep.note(f"Estimated on the first {100 * v['fraction']:.3g} % of the record, checked on the "
                 f"held-out {v['n_samples']} samples: fit (NRMSE) of the {v['fit_kind']}, "
                 f"Ljung–Box test of the one-step prediction errors and their cross-correlation "
                 f"with each input (level {v['alpha']:g}; adaptid.models.compare and resid).")
        rep.table(["check", "value", "verdict"], validation_rows(v))
        rep.end()
    if "compare" in checks:
        from adaptid import plot

        on = "held-out" if checks["on"] == "validation" else "estimation"
        rep.section("Model output against the measurement")
        fig = plot.new_figure((11, 3.6))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)   # layout notes of matplotlib
            checks["compare"].plot(fig=fig)
        rep.figure("compare.png", fig, f"Measured output and the model's {checks['compare'].k or ''}"
                   f"{'-step prediction' if checks['compare'].k else 'simulation'} on the {on} data, "
                   "fit (NRMSE) % in the legend (adaptid.models.compare).")
        rep.end()
        rep.section("Residual analysis")
        res = checks["resid"]
        fig = plot.new_figure((11, 2.4 * (1 + len(res.u_names)) + 0.6))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)   # layout notes of matplotlib
            res.plot(fig=fig)
        rep.figure("resid.png", fig, f"Autocorrelation of the one-step prediction errors on the {on} "
                   "data and their cross-correlation with each input, with the "
                   f"{100 * (1 - res.alpha):g} % band (adaptid.models.resid).")
        rep.end()


def _write_report(out, table, problem: Problem, fits: list, physical, result, checks=None,
                  tracks_figure=None):
    """The report, staged (the caller commits it after the other outputs).

    ``tracks_figure``: ``(Figure, caption)`` drawn instead of one panel per
    parameter (``--method fastrls``: hundreds of taps, no P for a band).
    """
    from ._report import Report, constancy_figure, constancy_verdict, errors_figure

    rep = Report(out, f"adaptid fit: {Path(table.path).name}",
                 f"{problem.kind} model · {fits[0].label} · {result['n_samples']} samples · "
                 f"{result['n_skipped']} skipped · nan policy {result['nan_policy']}")
    rep.section("Estimates")
    for f in fits:
        if len(fits) > 1:
            rep.note(f"{f.title} equation")
        rep.table(["parameter", "estimate", "stderr", "−2σ", "+2σ"],
                  [[n, th, se, th - 2 * se, th + 2 * se] for n, th, se in zip(f.names, f.theta, f.stderr)])
    if physical is not None:
        rep.note("physical parameters (delta method from both equations)")
        rep.table(["parameter", "estimate", "stderr"], [[k, v, se] for k, (v, se) in physical.items()])
    rep.warnings(result["warnings"])
    rep.end()
    _report_checks(rep, checks or {})

    use_time = problem.time is not None
    xlabel = (problem.time_name or "time") if use_time else "sample"

    def xaxis(index):
        return problem.time[index] if use_time else index + 1.0

    if tracks_figure is not None:
        rep.section("Parameter tracks")
        rep.figure("tracks.png", *tracks_figure)
        rep.end()
    elif fits[0].track is not None:
        from adaptid import plot

        fig, axes = plot.panel_axes(sum(len(f.names) for f in fits))
        at = 0
        for f in fits:
            names = [(f"{f.title}: " if len(fits) > 1 else "") + n for n in f.names]
            plot.tracks(xaxis(f.index), f.track, names, band=f.band, band_at=f.ends,
                        label=f.label, xlabel=xlabel, ax=axes[at:at + len(names)])
            at += len(names)
        fig.legend(*axes[0].get_legend_handles_labels(), loc="outside upper center", ncol=1,
                   fontsize=9, frameon=False)
        rep.section("Parameter tracks")
        rep.figure("tracks.png", fig,
                   "Estimates after each sample, with ±2σ bands from the estimator's P "
                   "(σ̂² by the rule of adaptid.recursive_fit_stats).")
        rep.end()
    rep.section("Prediction error")
    rows = [(f"{f.title}: " + ("a-priori error" if f.track is not None else "residual"),
             [(f.label, xaxis(f.index), f.error)]) for f in fits]
    rep.figure("errors.png", errors_figure(rows, xlabel=xlabel),
               "A-priori prediction errors ε = y − φᵀθ̂ (recursive) or residuals (batch).")
    rep.end()
    checked = [f for f in fits if f.cusum is not None]
    if checked:
        rep.section("Parameter constancy")
        rep.figure("cusum.png", constancy_figure(checked, xaxis, xlabel=xlabel),
                   "CUSUM and CUSUM of squares of the recursive residuals (Brown, Durbin & "
                   "Evans 1975) with their 95 % bounds; the Chow F statistic of every "
                   "candidate break date with supF's 95 % critical value (Andrews 1993, "
                   "Hansen 1997 p-value) and the break dates chosen by BIC (Bai & Perron).")
        for f in checked:
            rep.note(f"{f.title}: {constancy_verdict(f.cusum)}")
        rep.end()
    estimates = []
    for f in fits:
        for n, th, se in zip(f.names, f.theta, f.stderr):
            estimates.append({"name": (f"{f.title}:" if len(fits) > 1 else "") + n,
                              "method": f.method, "estimate": th, "stderr": se, "truth": None})
    if physical is not None:
        for k, (v, se) in physical.items():
            estimates.append({"name": k, "method": fits[0].method, "estimate": v, "stderr": se,
                              "truth": None})
    rep.write(estimates, commit=False)
    return rep
