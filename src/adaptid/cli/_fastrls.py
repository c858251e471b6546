r"""``adaptid fit --fir NB[,NK] --u COL --y COL --method fastrls`` (issue 38, point 4).

:class:`adaptid.FastRLS` is not in the estimator factory (it refuses regressor
rows that are not a tapped delay line), so the fixed-Φ path of
:mod:`._fit` cannot run it: the FIR regressors of that path start at row
nb + nk − 1 without zero padding. Here the filter is fed from the columns
directly with :meth:`~adaptid.FastRLS.run_fir`, on the *prewindowed* delay
line (inputs before the first sample are zero) of the input delayed by nk
samples, :math:`v_k = u_{k-n_k}`:

.. math::

    \varphi_k = [v_k, v_{k-1}, \dots, v_{k-n_b+1}]^T,\qquad
    \theta = [b_0, \dots, b_{n_b-1}],

the FIR model's coefficients (``bj`` multiplies :math:`u_{k-n_k-j}`, the names of
``ARX(0, nb, nk)``).

Rows with a missing value (``--nan skip``) are left out of the record before
the delay (as FastRLS's ``nan_policy="skip"`` does: the sample is not shifted
in), so the line runs over the complete rows. ``--save-state`` stores the
FastRLS state file with the labels of ``adaptid fit`` plus the delay nk and
the nk inputs that are not yet in the line (exact hexadecimal floats), so a
record cut in two and resumed equals one run.

Standard errors follow the one rule of :func:`adaptid.recursive_fit_stats`
for the equivalent :class:`adaptid.RLS` (``forgetting=λ``,
``P0=diag(λ**arange(n))/δ``):
:math:`\hat\sigma^2 = \sum_k c_k r_k^2/(\sum_k c_k - n)` with
:math:`c_k = \lambda^{N-k}` and :math:`r_k` the residuals of the final θ on the
prewindowed regressors, and :math:`se_i = \sqrt{\hat\sigma^2 P_{ii}}` with
:math:`P^{-1} = \sum_k c_k\varphi_k\varphi_k^T + \delta\,\mathrm{diag}(\lambda^{N-i})`
the information matrix of the filter's cost, factored by a QR of the
weighted rows (never formed), O(N n²) once. They are NaN (with a warning)
after ``--resume`` (FastRLS holds no covariance and the earlier samples are
not in this file) and when N·n² exceeds :data:`STDERR_MAX_WORK`.

``--detrend``, ``--validate``, ``--summary`` and ``--out`` are those of
``--method rls`` on the same FIR structure, through the same functions (see
:mod:`._fastrls_workflow`).
"""

from __future__ import annotations

import math
import time as _time
import types

import numpy as np

from ._errors import CLIError

__all__ = ["parse_fir", "wants_fastrls", "run_fastrls", "fastrls_theory", "STDERR_MAX_WORK"]

FAST_METHODS = ("ftf", "lattice")
#: Largest N·n² for which the standard errors are computed (a QR of the N × n
#: weighted regression, about 2·N·n² flops); beyond it they are NaN.
STDERR_MAX_WORK = 5e9
#: Rows of the weighted regression factored per QR step (memory O(rows · n)).
QR_CHUNK = 4096
#: Largest N·n for which the report stores θ after every sample without --tracks;
#: beyond it θ is read at :data:`REPORT_TRACK_POINTS` chunk ends (the figure's resolution).
FULL_TRACK_VALUES = 2e7
REPORT_TRACK_POINTS = 2000
_DELTA_RANGE = (1e-100, 1e100)


# ------------------------------------------------------------------ the hooks
def parse_fir(text, method):
    """``--fir``: ``NB,NK``; with ``--method fastrls`` also ``N`` alone (NB = N, NK = 0)."""
    from ._problem import parse_orders

    if text is not None and (method or "").strip().lower() == "fastrls" and "," not in text:
        return parse_orders(text, "--fir", ("nb",)) + (0,)
    return parse_orders(text, "--fir", ("nb", "nk"))


def wants_fastrls(spec, resume) -> bool:
    """``--method fastrls``, or no ``--method`` and a ``--resume`` file holding a FastRLS."""
    if spec.method == "fastrls":
        return True
    if spec.method is not None or resume is None:
        return False
    try:
        from adaptid.estimators._statefile import load_state_labelled

        return type(load_state_labelled(resume)[0]).__name__ == "FastRLS"
    except Exception:  # noqa: BLE001 - unreadable: the usual path reports it
        return False


# ------------------------------------------------------------------ checks
def _refuse_options(structure, spec):
    """The options of ``fit`` that do not apply to the delay-line filter: one line each."""
    if structure.kind != "fir":
        raise CLIError("--method fastrls needs --fir NB[,NK] --u COL --y COL (a tapped delay "
                       f"line of one input), not --{structure.kind}")
    if structure.u is not None and len(structure.u) != 1:
        raise CLIError(f"--method fastrls takes one --u column (a single delay line), got "
                       f"{len(structure.u)}")
    if structure.fir[0] < 1:
        raise CLIError(f"--fir: nb must be >= 1 with --method fastrls, got {structure.fir[0]}")
    why = {
        "--intercept": (structure.intercept, "a constant regressor is not in the delay line"),
        "--P0": (spec.P0 is not None, "the soft start is set by --delta (P0 = diag(λ^i)/δ)"),
    }
    for opt in ("--window", "--process-cov", "--noise-var", "--step", "--eps"):
        key = opt[2:].replace("-", "_")
        why[opt] = (getattr(spec, key) is not None, "it is an option of another method")
    for opt, (given, reason) in why.items():
        if given:
            raise CLIError(f"{opt} does not apply to --method fastrls ({reason})")


def _check_values(spec, *, export_c, nk):
    """--forgetting, --delta, --fastrls-method, and what --export-c needs."""
    from ._engine import check_ranges

    check_ranges(forgetting=spec.forgetting)
    if spec.delta is not None:
        lo, hi = _DELTA_RANGE
        if not (math.isfinite(spec.delta) and lo <= spec.delta <= hi):
            raise CLIError(f"--delta must be in [1e-100, 1e100], got {spec.delta:g}")
    m = spec.fastrls_method
    if m is not None and m not in FAST_METHODS:
        raise CLIError(f"--fastrls-method must be ftf or lattice, got {m!r}")


def _check(data, structure, spec, *, nan, out, save_state, resume, tracks, export_c, c_name,
           float32):
    """Every check before reading the data (the ones of ``run_fit`` for this path)."""
    from ._fastrls_workflow import check_workflow
    from ._fit import NAN_WORDS, check_files

    structure.check()
    if nan not in NAN_WORDS:
        raise CLIError(f"--nan must be raise or skip (error: the same as raise), got {nan!r}")
    _refuse_options(structure, spec)
    check_workflow(structure, export_c=export_c)
    _check_values(spec, export_c=export_c, nk=structure.fir[1])
    check_files(data, structure, spec, out=out, save_state=save_state, resume=resume,
                tracks=tracks, export_c=export_c, c_name=c_name, float32=float32)


# ------------------------------------------------------------------ state
def _labels(structure, names, pending) -> dict:
    """The labels of ``adaptid fit`` plus the delay nk and the inputs not yet in the line."""
    return {"saved_by": "adaptid fit", "model": "fir", "output": str(structure.y),
            "regressors": [str(n) for n in names], "method": "fastrls",
            "delay_nk": str(structure.fir[1]),
            "pending_inputs": [float(x).hex() for x in pending]}


def _adopt(est, labels, structure, spec, names, nan_policy, resume):
    """Check the resumed FastRLS against the options; (estimator, pending inputs)."""
    from ._fit import _check_labels

    if type(est).__name__ != "FastRLS":
        raise CLIError(f"--method fastrls differs from the state file {resume} (a "
                       f"{type(est).__name__}); resume it without --method fastrls")
    nb, nk = structure.fir
    if est.n_taps != nb:
        raise CLIError(f"--resume {resume}: the state has {est.n_taps} taps, --fir gives {nb}")
    for opt, given, have in (("--forgetting", spec.forgetting, est.forgetting),
                             ("--delta", spec.delta, est.delta),
                             ("--fastrls-method", spec.fastrls_method, est.method)):
        if given is not None and given != have:
            raise CLIError(f"{opt} {given} differs from the state file {resume} ({have}); "
                           "the state fixes the filter's options")
    _check_labels(labels, {"saved_by": "adaptid fit", "model": "fir", "output": str(structure.y),
                           "regressors": names}, resume)
    if labels is None or labels.get("saved_by") != "adaptid fit":
        if nk:
            raise CLIError(f"--resume {resume}: the state was not saved by adaptid fit, so the "
                           f"{nk} delayed input(s) not yet in its line are unknown; use nk = 0")
        pending = np.zeros(0)
    else:
        if labels.get("delay_nk") != str(nk):
            raise CLIError(f"--resume {resume}: the state was saved with nk = "
                           f"{labels.get('delay_nk')}, this run has --fir {nb},{nk}")
        pending = np.array([float.fromhex(x) for x in labels.get("pending_inputs", [])])
    if est.nan_policy != nan_policy:
        st = est.get_state()
        st["options"]["nan_policy"] = nan_policy
        est = type(est).from_state(st)
    return est, pending


def _fresh(spec, nb, nan_policy):
    import adaptid

    kw = {k: v for k, v in (("forgetting", spec.forgetting), ("delta", spec.delta),
                            ("method", spec.fastrls_method)) if v is not None}
    try:
        return adaptid.FastRLS(nb, nan_policy=nan_policy, **kw)
    except ValueError as err:
        raise CLIError(f"--method fastrls: {err}") from None


# ------------------------------------------------------------------ statistics
def delay_rows(v_full, n, n_before):
    """The prewindowed regressors of this run, row k = φ_k (a read-only strided view).

    ``v_full``: the ``n_before`` inputs already in the line (oldest first),
    then the run's; zeros stand for the inputs before the soft start.
    """
    pad = np.concatenate([np.zeros(n - 1 - n_before), v_full]) if n_before < n - 1 \
        else v_full[n_before - (n - 1):]
    return np.lib.stride_tricks.sliding_window_view(pad, n)[:, ::-1]


def weighted_residuals(v_full, y, theta, *, n_before, lam):
    """``(r, c)``: the final θ's residuals on the run's regressors and c_k = λ^(N−k)."""
    from scipy.signal import lfilter

    N = y.shape[0]
    r = y - lfilter(theta, [1.0], v_full)[n_before:]
    return r, lam ** np.arange(N - 1, -1, -1, dtype=np.float64)


def fastrls_theory(v_full, y, theta, *, n_before, lam, delta, total, want_se=True):
    r"""σ̂² and standard errors of the final θ by the one rule (see the module docstring).

    ``v_full``: the delay-line inputs, the ``n_before`` ones already in the
    line first (oldest first), then the N of this run; ``y`` the N outputs;
    ``total`` the samples since the soft start (the prior's exponent).
    Returns ``(sigma2, stderr (n,))``; stderr NaN when ``want_se`` is False.
    """
    from scipy.linalg import qr, solve_triangular

    n, N = theta.shape[0], y.shape[0]
    r, c = weighted_residuals(v_full, y, theta, n_before=n_before, lam=lam)
    dof = float(c.sum()) - n
    sigma2 = float(np.sum(c * r * r) / dof) if dof > 0 else float("nan")
    se = np.full(n, np.nan)
    if not want_se or not math.isfinite(sigma2):
        return sigma2, se
    rows = delay_rows(v_full, n, n_before)
    R = np.diag(np.sqrt(delta * lam ** (total - np.arange(n, dtype=np.float64))))
    sw = np.sqrt(c)
    for a in range(0, N, QR_CHUNK):
        block = rows[a:a + QR_CHUNK] * sw[a:a + QR_CHUNK, None]
        R = qr(np.vstack([R, block]), mode="r", check_finite=False)[0][:n]
    try:
        with np.errstate(all="ignore"):
            Rinv = solve_triangular(R, np.eye(n), check_finite=False)
            se = np.sqrt(sigma2 * np.sum(Rinv * Rinv, axis=1))
    except np.linalg.LinAlgError:
        return sigma2, np.full(n, np.nan)
    return sigma2, np.where(np.isfinite(se), se, np.nan)


# ------------------------------------------------------------------ the run
def _fill(values, ok, start):
    """Rows for every record row from the complete rows' ``values``: skipped rows carry
    the previous row (``start`` before the first), as a skipped sample leaves θ."""
    N = ok.shape[0]
    pos = np.cumsum(ok) - 1                   # index of the last complete row at or before
    out = np.empty((N,) + values.shape[1:])
    out[pos >= 0] = values[pos[pos >= 0]]
    out[pos < 0] = start
    return out


def _filter(est, v, y, *, store):
    """run_fir over the line: ``(errors, θ rows, their positions in v, rescues)``.

    ``store="all"``: θ after every sample (``--tracks``, or a report small
    enough), positions None; ``"ends"``: θ read at up to
    :data:`REPORT_TRACK_POINTS` chunk ends (a record cut in chunks equals one
    pass), enough for the report's figure without an N × n array; None: no θ.
    """
    N = y.shape[0]
    if store != "ends":
        traj = est.run_fir(v, y, store_theta=store == "all")
        return (traj.error, traj.theta if store == "all" else None, None,
                int(traj.meta["n_rescues"]))
    edges = np.unique(np.linspace(0, N, min(REPORT_TRACK_POINTS, max(N, 1)) + 1)
                      .round().astype(np.int64))
    errors, thetas, rescues = [], [], 0
    for a, b in zip(edges[:-1], edges[1:]):
        tr = est.run_fir(v[a:b], y[a:b], store_theta=False)
        errors.append(tr.error)
        thetas.append(est.theta)
        rescues += int(tr.meta["n_rescues"])
    return np.concatenate(errors), np.array(thetas).reshape(-1, est.n_taps), edges[1:] - 1, rescues


def _stderr_warnings(fresh, work):
    if not fresh:
        return ["stderr is NaN after --resume: FastRLS holds no covariance and the samples "
                "before this run are not in this file"]
    if work > STDERR_MAX_WORK:
        return [f"stderr not computed: N·n² = {work:.3g} exceeds {STDERR_MAX_WORK:.0e} "
                "(a QR of the weighted regression, O(N n²)); θ and σ² are exact"]
    return []


def _fit(est, u, y, ok, pending, structure, names, *, tracks, report, fresh, output):
    """Run the filter; (EquationFit, new pending inputs, n_rescues of the run, the line).

    The line is what :mod:`._fastrls_workflow` needs of the run: the regressor
    rows (a strided view), y and the complete-row mask, the final θ's
    residuals r and factors c, and ``first_full``.
    """
    from ._engine import EquationFit

    nb, nk = structure.fir
    seq = np.concatenate([pending, u[ok]])
    v, new_pending = seq[: ok.sum()], seq[seq.shape[0] - nk:] if nk else np.zeros(0)
    before = est.delay_line[::-1].copy()      # oldest first
    n_before, total = min(est.n_updates, nb - 1), est.n_updates + int(ok.sum())
    theta_start = est.theta
    store = ("all" if tracks is not None or (report and ok.sum() * nb <= FULL_TRACK_VALUES)
             else "ends" if report else None)
    with output.progress(len(y), "fitting (fastrls)") as advance:
        e, th, at, rescues = _filter(est, v, y[ok], store=store)
        if advance is not None:
            advance(len(y))
    theta = est.theta
    err = np.full(len(y), np.nan)
    err[ok] = e
    work = float(ok.sum()) * nb * nb
    caught = _stderr_warnings(fresh, work)
    if rescues:
        caught.append(f"{rescues} rescue(s) of the fast transversal filter: θ is no longer the "
                      "exact weighted least-squares solution (use --fastrls-method lattice)")
    v_full = np.concatenate([before[len(before) - n_before:], v])
    sigma2, se = fastrls_theory(v_full, y[ok], theta, n_before=n_before, lam=est.forgetting,
                                delta=est.delta, total=total,
                                want_se=fresh and work <= STDERR_MAX_WORK)
    used = err[np.isfinite(err)]
    warm = min(10 * nb, used.shape[0] // 2) if fresh else 0
    rms = float(np.sqrt(np.mean(used[warm:] ** 2))) if used[warm:].size else float("nan")
    if th is None:   # an empty track without --tracks/--out: "a-priori error" in the title
        track = np.empty((0, nb))
    else:            # every record row, or θ at the chunk ends (the rows `ends`)
        track = _fill(th, ok, theta_start) if at is None else th
    label = f"FastRLS {est.method} λ={est.forgetting:g} δ={est.delta:g}"
    fit = EquationFit(title="FIR", method="fastrls", label=label, names=list(names),
                      theta=theta, stderr=se, cov=np.diag(se * se), sigma2=sigma2,
                      n_samples=len(y), n_skipped=int((~ok).sum()), error=err,
                      index=np.arange(len(y)), estimator=est, rms_error=rms,
                      track=track, ends=None if at is None else np.flatnonzero(ok)[at],
                      warnings=caught)
    r, c = weighted_residuals(v_full, y[ok], theta, n_before=n_before, lam=est.forgetting)
    # first_full: the first complete row whose regressor holds no zero of the prewindow
    line = types.SimpleNamespace(rows=delay_rows(v_full, nb, n_before), y=y[ok], ok=ok, r=r,
                                 c=c, first_full=max(0, nb - 1 - n_before) + (nk if fresh else 0))
    return fit, new_pending, rescues, line


def _result(table, fit, est, nan, rescues) -> dict:
    return {
        "file": str(table.path), "model": "fir", "method": "fastrls",
        "names": fit.names, "theta": [float(x) for x in fit.theta],
        "stderr": [float(x) for x in fit.stderr],
        "n_samples": int(fit.n_samples), "n_skipped": int(fit.n_skipped),
        "n_rows": int(fit.n_samples), "nan_policy": nan, "sigma2": fit.sigma2,
        "rms_error": fit.rms_error, "n_rescues": rescues,
        "warnings": [f"{fit.title}: {w}" for w in fit.warnings],
        "n_updates": int(est.n_updates),
        "options": {"forgetting": float(est.forgetting), "delta": float(est.delta),
                    "method": str(est.method)},
    }


def run_fastrls(data, structure, spec, *, nan, out=None, save_state=None, resume=None,
                output, tracks=None, summary=False, export_c=None, c_name="rls",
                float32=False) -> dict:
    """The whole ``fit --method fastrls`` command; returns the JSON-ready result."""
    from ._targets import state_lock

    t0 = _time.perf_counter()
    _check(data, structure, spec, nan=nan, out=out, save_state=save_state, resume=resume,
           tracks=tracks, export_c=export_c, c_name=c_name, float32=float32)
    with state_lock(save_state if save_state is not None else resume):
        return _run_locked(data, structure, spec, nan=nan, out=out, save_state=save_state,
                           resume=resume, output=output, tracks=tracks, summary=summary,
                           export_c=export_c, c_name=c_name, float32=float32, t0=t0)


def _run_locked(data, structure, spec, *, nan, out, save_state, resume, output, tracks,
                summary, export_c, c_name, float32, t0) -> dict:
    from ..io import read_table
    from ._fastrls_workflow import finish, record
    from ._fit import _load_resume, _print

    policy = "skip" if nan == "skip" else "raise"
    nb, _ = structure.fir
    table = read_table(data, columns=structure.columns())
    output.detail(f"read {table.path} ({table.kind}): columns {', '.join(table.names[:20])}")
    names = [f"b{j}" for j in range(nb)]  # the FIR model's names (ARX(0, nb, nk).names)
    problem, u, y, ok = record(table, structure, nan, names)
    if resume is not None:
        est, labels = _load_resume(resume)
        est, pending = _adopt(est, labels, structure, spec, names, policy, resume)
    else:
        est, pending = _fresh(spec, nb, policy), np.zeros(structure.fir[1])  # prewindowed
    fresh = resume is None
    fit, pending, rescues, line = _fit(est, u, y, ok, pending, structure, names, tracks=tracks,
                                       report=out is not None, fresh=fresh, output=output)
    for w in fit.warnings:
        output.warn(f"FIR: {w}")
    result = _result(table, fit, est, nan, rescues)
    result["elapsed_s"] = _time.perf_counter() - t0
    rep, summ = finish(result, table, problem, structure, fit, line, out=out, summary=summary)
    _outputs(result, fit, est, problem, structure, tracks=tracks, export_c=export_c,
             c_name=c_name, float32=float32, pending=pending)
    if rep is not None:
        rep.commit()  # after the other outputs: a failure there leaves no report
    _print(output, result, [fit], None, summ)
    output.print(f"rescues: {rescues} · samples since the soft start: {est.n_updates}")
    if output.json:
        output.emit_json(result)
    if save_state is not None:  # last (atomic), as run_fit
        from adaptid.estimators._statefile import save_state as _save

        try:
            _save(est, save_state, labels=_labels(structure, names, pending))
        except OSError as err:
            raise CLIError(f"--save-state {save_state}: cannot write ({err.strerror or err}); "
                           "the results above were not saved") from None
    return result


def _outputs(result, fit, est, problem, structure, *, tracks, export_c, c_name, float32,
             pending):
    """--tracks FILE (θ after every row, the a-priori error) and --export-c DIR (the filter,
    with the nk raw inputs ``pending`` in its input buffer)."""
    if tracks is not None:
        from ..io import write_table
        from ._modelfit import tracks_frame

        try:
            write_table(tracks_frame(problem, [fit]), tracks, index=False)
        except ValueError as err:
            raise CLIError(f"--tracks: {err}") from None
        result["tracks"] = str(tracks)
    if export_c is not None:
        from ._export import write_c

        result["export_c"] = [str(p) for p in write_c(est, export_c, c_name, float32,
                                                      option="--export-c", nk=structure.fir[1],
                                                      pending=pending)]
