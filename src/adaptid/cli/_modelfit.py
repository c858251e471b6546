r"""``adaptid fit`` with the model objects: model fits, validation, summary tables, tracks.

* A model option without ``--method`` (and without an option only a
  recursive run has, :data:`RECURSIVE_FLAGS`) is fitted by the model
  object's ``fit``, as MATLAB's ``arx``, ``armax``, ``oe``, ``bj`` do: least
  squares for ``--arx``/``--fir``/``--ar`` (:class:`adaptid.models.ARX`,
  :class:`~adaptid.models.AR`), prediction errors for ``--arma``,
  ``--armax``, ``--oe``, ``--bj``.
* ``--arma`` / ``--armax`` / ``--oe`` / ``--bj`` regress on signals filtered
  with the running estimate (pseudo-linear regression), so their recursive
  fit cannot be a fixed Φ run by an estimator: a recursive ``--method``
  runs the streaming object (:class:`adaptid.models.RecursiveARMA`,
  :class:`~adaptid.models.RecursiveARMAX`, :class:`~adaptid.models.RecursiveOE`,
  :class:`~adaptid.models.RecursiveBJ`, ``start="filled"``, so equal to the
  models' ``fit_recursive``; the estimator built by :func:`adaptid.estimator`
  is read for its algorithm and options, lms and nlms included).
* ``--arx`` / ``--fir`` / ``--ar`` with a recursive method run the streaming
  objects too (:func:`stream_runner`): :class:`~adaptid.models.RecursiveARX`
  (FIR: ``na = 0``) or :class:`~adaptid.models.RecursiveAR` with
  ``start="filled"``, on the estimator :func:`adaptid.estimator` built from
  the options (or the one ``--resume`` read), so equal to the models'
  ``fit_recursive`` and to that estimator run on the model's regressors.
  ``--intercept`` keeps the estimator on the regressor matrix with a column
  of ones (:func:`uses_stream`: the objects, as MATLAB's ``recursiveARX``,
  have no constant term).
* Parameter names are the model objects' (``a1``, ``b0``, ``b1_0``, ``c1``, ``f1``).
* ``--validate`` / the report's figures use :func:`adaptid.models.compare`
  (simulation for input–output models, one-step prediction for AR/ARMA) and
  :func:`adaptid.models.resid` on the held-out part, with the model at the
  estimate the command printed.
* ``--summary``: the model's ``summary()`` when the model object was
  fitted, or :func:`adaptid.models.recursive_summary` /
  :meth:`adaptid.lstsq`'s ``summary()`` of the fixed regression the
  estimator ran on.
"""

from __future__ import annotations

import warnings

import numpy as np

from ._engine import EquationFit, MethodSpec
from ._errors import CLIError

__all__ = ["fit_model_equation", "validation_model", "validate", "summaries", "tracks_frame",
           "default_method", "uses_model", "model_object", "n_params", "RECURSIVE_FLAGS",
           "uses_stream", "stream_runner", "arx_orders", "arx_stream"]

RESID_ALPHA = 0.01   # MATLAB's resid band (99 %), models.resid's default
MAX_LAG = 25         # MATLAB's resid default


#: what a recursive option asks for: with one of them and no --method, a model option runs RLS
RECURSIVE_FLAGS = ("--forgetting", "--window", "--process-cov", "--noise-var", "--P0", "--step",
                   "--eps", "--tracks", "--export-c", "--save-state", "--resume")


def default_method(structure, given) -> str:
    """The method when ``--method`` is not given.

    A model option (``--arx``, ``--armax``, ``--oe``, ``--bj``, ``--ar``,
    ``--arma``, ``--fir``) runs the model's batch fit, as MATLAB's ``arx``,
    ``armax``, ``oe``, ``bj`` do, unless an option that only a recursive run
    has is given (``given``: flag -> value, see :data:`RECURSIVE_FLAGS`):
    then, as for ``--phi`` and ``--dc-motor``, RLS.
    """
    if structure.is_model and not any(given.get(f) is not None for f in RECURSIVE_FLAGS):
        return "batch"
    return "rls"


def uses_model(problem, structure, spec) -> bool:
    """Whether the equation is fitted by the model object (not by an estimator on a fixed Φ).

    Always for the pseudo-linear models; for ARX/FIR/AR the batch fit on a
    complete record without ``--intercept`` (the model's ``fit``: the same
    least squares, with the model's summary and statistics).
    """
    from ._problem import PSEUDO_LINEAR

    if problem.kind in PSEUDO_LINEAR:
        return True
    return (structure.is_model and spec.resolved == "batch" and not structure.intercept
            and problem.nan_rows == 0 and problem.est_data is not None)


#: the model options whose recursive fit runs RecursiveARX / RecursiveAR (fixed regressors)
STREAM_KINDS = ("arx", "ar", "fir")


def uses_stream(problem, structure, spec) -> bool:
    """Whether ``--arx``/``--ar``/``--fir`` run the streaming object (a recursive method).

    Not with ``--intercept``: RecursiveARX, as MATLAB's ``recursiveARX``, has no
    constant term, so the estimator runs on the model's regressors and a
    column of ones. (A record with missing values never gets here: the
    model options need complete records, ``--nan skip`` or not; the last two
    conditions only say what the object needs.)
    """
    return (problem.kind in STREAM_KINDS and spec.resolved != "batch"
            and not structure.intercept and problem.nan_rows == 0
            and problem.est_data is not None)


def arx_orders(kind, s) -> tuple:
    """``(na, nb, nk)`` of ``--arx``, ``--ar`` (nb = 0) or ``--fir`` (na = 0)."""
    return s.arx if kind == "arx" else (s.ar[0], 0, 1) if kind == "ar" else (0, *s.fir)


def arx_stream(kind, s, est, *, n_inputs, dt=1.0):
    """The streaming object of ``--arx``/``--ar``/``--fir`` running on ``est`` itself.

    :class:`~adaptid.models.RecursiveAR` (``--ar``) or
    :class:`~adaptid.models.RecursiveARX` (FIR: ``na = 0``; the same nb, nk for
    every input), ``start="filled"`` with empty lag buffers: its first update
    is at the first sample whose lags are all measured, the first row of
    :func:`adaptid.models.arx_regressors`.
    """
    from adaptid import models

    na, nb, nk = arx_orders(kind, s)
    try:
        if kind == "ar":
            obj = models.RecursiveAR(na, start="filled", dt=dt)
        elif n_inputs == 1:
            obj = models.RecursiveARX(na, nb, nk, start="filled", dt=dt)
        else:
            obj = models.RecursiveARX(na, [nb] * n_inputs, [nk] * n_inputs, start="filled",
                                      dt=dt)
        return obj._run_on(est)
    except ValueError as e:
        raise CLIError(f"--{kind}: {e}") from None


def stream_runner(problem, s):
    """The runner of :func:`._engine.fit_equation` for ``--arx``/``--ar``/``--fir``.

    Runs :func:`arx_stream` over the estimation record in the chunks of
    :func:`._engine.run_chunked` (the same regression rows end each chunk, P is
    read there), each chunk one :meth:`~adaptid.models.RecursiveARX.run`
    (equal bit for bit to one run over the record). Returns what
    ``run_chunked`` returns; the errors are the object's ``y - yhat``.
    """
    data = problem.est_data
    y = np.ascontiguousarray(data.y, dtype=np.float64).reshape(-1)
    U = None if problem.kind == "ar" else np.ascontiguousarray(data.inputs, dtype=np.float64)
    dt = problem.data.dt if problem.data is not None else 1.0

    def run(est, *, n_chunks=200, advance=None):
        from ._engine import _cov_or_nan

        obj = arx_stream(problem.kind, s, est, n_inputs=0 if U is None else U.shape[1], dt=dt)
        first = min(obj._s, len(y))          # start="filled": no update before this sample
        N, n = len(y) - first, est.n_params
        K = max(1, min(int(n_chunks), N))
        edges = np.unique(np.linspace(0, N, K + 1).round().astype(np.int64))
        thetas, errors, Ps, ends = [], [], [], []
        lo = 0
        for a, b in zip(edges[:-1], edges[1:]):
            hi = first + int(b)
            res = obj.run(y[lo:hi]) if U is None else obj.run(y[lo:hi], U[lo:hi])
            keep = slice(max(first - lo, 0), None)
            thetas.append(res.theta[keep])
            errors.append(y[lo:hi][keep] - res.yhat[keep])
            Ps.append(_cov_or_nan(est))
            ends.append(int(b) - 1)
            lo = hi
            if advance is not None:
                advance(int(b - a))
        if not thetas:
            return (np.empty((0, n)), np.empty(0), np.zeros(0, bool), np.empty(0, np.int64),
                    np.empty((0, n, n)), 0)
        return (np.concatenate(thetas), np.concatenate(errors), np.zeros(N, dtype=bool),
                np.asarray(ends, dtype=np.int64), np.stack(Ps), 0)

    return run


def model_object(kind, s, dt):
    """The model object of the option ``--KIND`` with its orders (not fitted)."""
    from adaptid import models

    o = getattr(s, kind)
    make = {"arx": lambda: models.ARX(*o, dt=dt), "fir": lambda: models.ARX(0, *o, dt=dt),
            "ar": lambda: models.AR(*o, dt=dt), "arma": lambda: models.ARMA(*o, dt=dt),
            "armax": lambda: models.ARMAX(*o, dt=dt), "oe": lambda: models.OE(*o, dt=dt),
            "bj": lambda: models.BJ(*o, dt=dt)}
    try:
        return make[kind]()
    except ValueError as e:
        raise CLIError(f"--{kind}: {e}") from None


def _model_of(problem, s):
    dt = problem.data.dt if problem.data is not None else 1.0
    return model_object(problem.kind, s, dt)


def fit_model_equation(problem, s, spec: MethodSpec, *, nan_policy, advance=None) -> tuple:
    """Fit a model option on the estimation part by the model object's ``fit`` (batch) or
    ``fit_recursive``; returns (EquationFit, fitted model)."""
    est_data = problem.est_data
    y = np.ascontiguousarray(est_data.y, dtype=np.float64)
    U = est_data.u
    model = _model_of(problem, s)
    # the IDData (its names and dt go into summary()); ARMA the output array
    args = (y,) if problem.kind == "arma" else (est_data,)
    title = problem.equations[0][0]
    caught = []
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        try:
            if spec.resolved == "batch":
                model.fit(*args)
                track, error, index = None, np.asarray(model.residuals), np.asarray(model.index)
            else:
                d = n_params(problem.kind, s.orders, 0 if U is None else 1 if np.ndim(U) == 1
                             else U.shape[1])
                model, track, error, index = _stream_fit(problem, s, spec.make(d, nan_policy),
                                                         args)
        except (ValueError, FloatingPointError, np.linalg.LinAlgError) as e:
            raise CLIError(f"--{problem.kind}: {e}") from None
    for w in rec:
        msg = " ".join(str(w.message).split())
        if msg not in caught:
            caught.append(msg)
    if advance is not None:
        advance(len(y))
    if problem.kind == "arma":
        model.y_name = problem.columns[0]
    theta = np.asarray(model.theta, dtype=np.float64).copy()
    n = theta.size
    finite = np.isfinite(error)
    warm = min(10 * n, len(error) // 2) if track is not None else 0
    rms = float(np.sqrt(np.mean(error[warm:][finite[warm:]] ** 2))) if finite[warm:].any() \
        else float("nan")
    fit = EquationFit(
        title=title, method=spec.resolved, label=_label(problem.kind, spec), names=list(model.names),
        theta=theta, stderr=np.asarray(model.stderr, dtype=np.float64),
        cov=np.asarray(model.cov), sigma2=float(model.noise_variance), n_samples=len(error),
        n_skipped=0, error=error, index=index, track=track, rms_error=rms)
    fit.warnings = caught
    return fit, model


def _stream_fit(problem, s, est, args):
    """The streaming object (start="filled", the estimator's algorithm) over the record:
    (model as fit_recursive leaves it, tracks, a-priori errors, sample index)."""
    from adaptid import models

    cls = {"arma": models.RecursiveARMA, "armax": models.RecursiveARMAX,
           "oe": models.RecursiveOE, "bj": models.RecursiveBJ}[problem.kind]
    dt = problem.data.dt if problem.data is not None else 1.0
    obj = cls(*s.orders, start="filled", dt=dt)._use_core(est)
    res = obj.run(*args)
    first = min(obj._s, len(res.yhat))
    y = np.asarray(problem.est_data.y, dtype=np.float64).reshape(-1)
    error = y[first:] - res.yhat[first:]
    return (obj._fitted_model(*args), res.theta[first:], error,
            np.arange(first, len(res.yhat)))


def _label(kind, spec):
    """``batch LS`` for ARX/FIR/AR, ``batch PEM`` for the models fitted by prediction errors."""
    from ._problem import PSEUDO_LINEAR

    if spec.resolved == "batch" and kind in PSEUDO_LINEAR:
        return "batch PEM"
    return spec.label()


def n_params(kind, orders, m):
    """The number of parameters d of model ``kind`` with ``orders`` and m inputs."""
    o = orders
    return {"arx": lambda: o[0] + m * o[1], "fir": lambda: m * o[0], "ar": lambda: o[0],
            "arma": lambda: o[0] + o[1], "armax": lambda: o[0] + m * o[1] + o[2],
            "oe": lambda: m * (o[0] + o[1]), "bj": lambda: m * o[0] + o[1] + o[2] + m * o[3]}[kind]()


# ------------------------------------------------------------------ validation
class _Static:
    """A --phi regression y = φᵀθ as a model for compare/resid (its simulation is its prediction)."""

    fit_kind = "prediction (regression)"

    def __init__(self, theta, label):
        self.theta, self.index, self.label = np.asarray(theta), np.array([0]), label

    def predict(self, y, u, k=1):
        return np.asarray(u, dtype=np.float64).reshape(len(y), -1) @ self.theta

    def simulate(self, u):
        U = np.asarray(u, dtype=np.float64)
        return U.reshape(U.shape[0], -1) @ self.theta

    def __repr__(self):
        return self.label


class _WithIntercept:
    r"""ARX/FIR with a constant c (``--intercept``): :math:`A(q)y_k = B(q)u_k + c + e_k`.

    One-step prediction: the model's plus c; simulation (zero initial
    conditions): the model's plus the response of 1/A(q) to the constant c.
    """

    def __init__(self, model, c, label):
        self.model, self.c, self.label = model, float(c), label
        self.index = model.index

    def predict(self, y, u, k=1):
        if k != 1:  # pragma: no cover - the CLI asks for k = 1 only
            raise CLIError("--intercept: only the one-step prediction is available")
        return self.model.predict(y, u, k=1) + self.c

    def simulate(self, u):
        from scipy.signal import lfilter

        ys = np.asarray(self.model.simulate(u), dtype=np.float64)
        return ys + lfilter([self.c], self.model.A, np.ones(ys.shape[0]))

    def __repr__(self):
        return self.label


def validation_model(problem, s, fit: EquationFit, model=None):
    """The model at the printed estimate, for compare/resid; (model, k, label)."""
    from adaptid import models

    est = problem.est_data
    kind = problem.kind
    label = f"{_structure_label(kind, s)} ({fit.label})"
    k = 1 if kind in ("ar", "arma") else None
    if model is not None:   # fitted by the model object: validate that model
        return model, k, label
    if kind == "phi":
        return _Static(fit.theta, label), None, label
    theta = np.asarray(fit.theta, dtype=np.float64)
    if kind == "ar":
        m = models.AR(s.ar[0], dt=est.dt).fit(est.y)
        k = 1
    else:
        na, nb, nk = s.arx if kind == "arx" else (0, *s.fir)
        m = models.ARX(na, nb, nk).fit(est)  # the structure (orders, inputs, rows, names, dt)
        k = None
    # the model at the CLI's estimate (recursive, forgetting, --resume: not the batch one);
    # predict/simulate read only θ (the statistics of m.fit are not used here)
    m.theta = theta[:-1].copy() if s.intercept else theta.copy()
    if s.intercept:
        return _WithIntercept(m, theta[-1], label), k, label
    return m, k, label


def _structure_label(kind, s):
    orders = s.orders if s.is_model else None
    if orders is None:
        return "regression"
    return f"{kind.upper()}({','.join(map(str, orders))})" + (" + intercept" if s.intercept else "")


def validate(data, model, k, label, *, what):
    """compare + resid of ``model`` on ``data``; (dict for JSON/table, CompareResult, ResidResult)."""
    from adaptid import models

    try:
        cmp = models.compare(data, model, k=k, names=[label])
        start = int(np.asarray(model.index)[0]) if np.size(model.index) else 0
        lags = min(MAX_LAG, len(data) - start - 1)
        res = models.resid(data, model, max_lag=lags, alpha=RESID_ALPHA)
    except ValueError as e:
        raise CLIError(f"{what}: {e}") from None
    cc = {n: float(c["p_value"]) for n, c in zip(res.u_names, res.cross_correlation)}
    out = {
        "n_samples": len(data),
        "fit_percent": float(cmp.fit[0]),
        "fit_kind": getattr(model, "fit_kind", "simulation" if k is None else f"{k}-step prediction"),
        "ljung_box_p": float(res.autocorrelation["p_value"]),
        "max_lag": int(lags),
        "alpha": RESID_ALPHA,
        "white": res.white,
        "cross_correlation_p": cc,
        "independent": dict(zip(res.u_names, res.independent)),
    }
    return out, cmp, res


def validation_rows(v: dict) -> list:
    """Rows (quantity, value, verdict) of the validation table."""
    rows = [[f"fit % ({v['fit_kind']})", f"{v['fit_percent']:.2f}", ""],
            [f"Ljung-Box p (lags 1..{v['max_lag']})", f"{v['ljung_box_p']:.3g}",
             "white" if v["white"] else f"not white at {v['alpha']:g}"]]
    for name, p in v["cross_correlation_p"].items():
        rows.append([f"cross-corr. p ({name}, lags 0..{v['max_lag']})", f"{p:.3g}",
                     "independent" if v["independent"][name] else f"correlated at {v['alpha']:g}"])
    return rows


# --------------------------------------------------------------------- summary
def summaries(problem, fits, models_by_title) -> list:
    """One ``Summary`` per equation (see the module docstring)."""
    import adaptid
    from adaptid.models import recursive_summary

    out = []
    for (title, names, Phi, y, index), f in zip(problem.equations, fits):
        model = models_by_title.get(f.title)
        if model is not None:
            out.append(model.summary())
        elif f.estimator is None:   # batch on a fixed regression
            ok = np.isfinite(Phi).all(axis=1) & np.isfinite(y)
            out.append(adaptid.lstsq(Phi[ok], y[ok]).summary(names=f.names))
        else:
            used = np.isfinite(Phi).all(axis=1) & np.isfinite(y)   # the rows the estimator used
            with np.errstate(invalid="ignore"):
                out.append(recursive_summary(f.estimator, Phi, y, names=f.names, used=used))
    return out


def summary_json(summ) -> dict:
    cols = ["estimate", "stderr", "t", "p", "lower", "upper"]
    return {"title": summ.title, "names": list(summ.names),
            "params": {n: dict(zip(cols, map(float, row))) for n, row in zip(summ.names, summ.params)},
            "stats": {k: (float(v) if isinstance(v, (int, float, np.floating, np.integer)) else str(v))
                      for k, v in summ.stats.items()},
            "alpha": float(summ.alpha)}


# ---------------------------------------------------------------------- tracks
def tracks_frame(problem, fits):
    """Per-sample estimates (and a-priori errors) with the time column, one row per sample."""
    import pandas as pd

    frames = []
    for f in fits:
        prefix = f"{f.title}:" if len(fits) > 1 else ""
        cols = {prefix + n: f.track[:, j] for j, n in enumerate(f.names)}
        cols[prefix + "error"] = f.error
        frames.append(pd.DataFrame(cols, index=pd.Index(np.asarray(f.index), name="sample")))
    frame = frames[0] if len(frames) == 1 else pd.concat(frames, axis=1)
    frame = frame.sort_index()
    if problem.time is not None:
        frame.insert(0, problem.time_name or "time", np.asarray(problem.time)[frame.index.to_numpy()])
    return frame.reset_index()
