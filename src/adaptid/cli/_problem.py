"""From a table and the command-line options to the regression(s) to estimate."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ._errors import CLIError
from ..io import Table

__all__ = ["Structure", "Problem", "build_problem", "parse_orders", "split_names", "model_names",
           "MODEL_KINDS", "PSEUDO_LINEAR", "ORDER_LABELS"]

DC_MOTOR_COLUMNS = ("time", "voltage", "current", "speed")
#: the model options of ``fit`` and ``fleet`` (their order: the order of the messages)
MODEL_KINDS = ("arx", "fir", "ar", "arma", "armax", "oe", "bj")
#: the models with an input (``--u``)
INPUT_KINDS = ("arx", "fir", "armax", "oe", "bj")
#: the models whose regressors depend on the estimate (no fixed Φ): fitted by the model objects
PSEUDO_LINEAR = ("arma", "armax", "oe", "bj")
#: the orders of each model option, as ``--KIND`` takes them
ORDER_LABELS = {"arx": ("na", "nb", "nk"), "fir": ("nb", "nk"), "ar": ("na",),
                "arma": ("na", "nc"), "armax": ("na", "nb", "nc", "nk"), "oe": ("nb", "nf", "nk"),
                "bj": ("nb", "nc", "nd", "nf", "nk")}


def split_names(text: str | None, option: str) -> list | None:
    if text is None:
        return None
    names = [s.strip() for s in text.split(",")]
    if not names or any(not s for s in names):
        raise CLIError(f"{option} must be a comma-separated list of column names, got {text!r}")
    return names


def parse_orders(text: str | None, option: str, labels: tuple) -> tuple | None:
    """'2,2,1' → (2, 2, 1) for ``--arx na,nb,nk`` / ``--fir nb,nk``."""
    if text is None:
        return None
    parts = [s.strip() for s in text.split(",")]
    want = ",".join(labels)
    if len(parts) != len(labels):
        raise CLIError(f"{option} must be {want} ({len(labels)} integers), got {text!r}")
    try:
        values = tuple(int(p) for p in parts)
    except ValueError:
        raise CLIError(f"{option} must be {want} (integers), got {text!r}") from None
    for lab, v in zip(labels, values):
        if v < 0:
            raise CLIError(f"{option}: {lab} must be >= 0, got {v}")
    return values


def model_names(na: int, n_inputs: int, nb: int) -> list:
    """The model objects' parameter names of an ARX/AR/FIR regression.

    ``a1`` … ``a{na}``, then ``b0`` … ``b{nb-1}`` for one input, or
    ``b{i}_{j}`` (input i in ``--u`` order, 0-based) for several: the names
    :class:`adaptid.models.ARX` gives (``ARX(...).fit(...).names``).
    """
    names = [f"a{j}" for j in range(1, na + 1)]
    for i in range(n_inputs):
        names += [f"b{j}" if n_inputs == 1 else f"b{i}_{j}" for j in range(nb)]
    return names


def polynomial_form(Phi, na: int, inputs, nb: int):
    r"""ARX/FIR regressors in the model objects' polynomial convention, and their names.

    :func:`adaptid.models.arx_regressors` puts :math:`+y_{k-j}` in the
    first ``na`` columns; :class:`adaptid.models.ARX` writes
    :math:`A(q) = 1 + a_1q^{-1} + \dots`, whose coefficient multiplies
    :math:`-y_{k-j}`. The columns are negated (exactly: a sign flip) so that
    θ holds :math:`a_1, \dots, a_{n_a}` as ``models.ARX`` reports them. Names:
    :func:`model_names` (the model objects' own: ``a1``, ``b0``, ``b1_0``),
    :math:`b_j` being the coefficient of :math:`q^{-(n_k + j)}` in :math:`B(q)`.
    """
    Phi = np.array(Phi, dtype=np.float64, order="C")
    Phi[:, :na] *= -1.0
    names = model_names(na, len(inputs), nb)
    if len(names) != Phi.shape[1]:  # pragma: no cover - the builders' layout changed
        raise RuntimeError("ARX/FIR regressor layout does not match its names")
    return names, Phi


@dataclass
class Structure:
    """The model structure options of ``adaptid fit``."""

    y: str | None = None
    phi: list | None = None
    u: list | None = None
    arx: tuple | None = None
    fir: tuple | None = None
    ar: tuple | None = None
    arma: tuple | None = None
    bj: tuple | None = None
    armax: tuple | None = None
    oe: tuple | None = None
    dc_motor: bool = False
    time: str | None = None
    voltage: str | None = None
    current: str | None = None
    speed: str | None = None
    cutoff: float | None = None
    speed_kind: str | None = None
    intercept: bool = False
    detrend: str | None = None
    validate: float | None = None
    dt: float | None = None

    @property
    def kind(self) -> str:
        for kind in ("phi",) + MODEL_KINDS:
            if getattr(self, kind) is not None:
                return kind
        return "dc-motor" if self.dc_motor else "none"

    def columns(self) -> list:
        """Every column name the options use (the reader converts only these)."""
        names = [self.y, self.time, *(self.phi or ()), *(self.u or ())]
        if self.dc_motor:
            names += [self.time or "time", self.voltage or "voltage",
                      self.current or "current", self.speed or "speed"]
        return [n for n in dict.fromkeys(names) if n is not None]

    @property
    def is_model(self) -> bool:
        """An input-output or time-series model (not a plain regression, not --dc-motor)."""
        return self.kind in MODEL_KINDS

    @property
    def orders(self) -> tuple | None:
        """The orders of the model option given (None for --phi / --dc-motor)."""
        return getattr(self, self.kind) if self.is_model else None

    def check(self):
        chosen = [opt for opt, on in [("--phi", self.phi is not None)]
                  + [(f"--{k}", getattr(self, k) is not None) for k in MODEL_KINDS]
                  + [("--dc-motor", self.dc_motor)] if on]
        if not chosen:
            raise CLIError("give the regressors: --y COL --phi COL,..., --arx na,nb,nk --u COL --y COL, "
                           "--fir nb,nk --u COL --y COL, --ar na --y COL, --arma na,nc --y COL, "
                           "--armax na,nb,nc,nk --u COL --y COL, --oe nb,nf,nk --u COL --y COL, "
                           "--bj nb,nc,nd,nf,nk --u COL --y COL, or --dc-motor")
        if len(chosen) > 1:
            raise CLIError(f"{' and '.join(chosen)} cannot be combined: choose one model structure")
        kind = self.kind
        if kind != "dc-motor" and self.y is None:
            raise CLIError(f"{chosen[0]} needs --y COL (the output column)")
        if kind in INPUT_KINDS and self.u is None:
            raise CLIError(f"{chosen[0]} needs --u COL (the input column)")
        if kind in ("phi", "ar", "arma") and self.u is not None:
            raise CLIError(f"--u applies to --arx, --fir, --armax, --oe or --bj, not {chosen[0]}"
                           + (" (a time-series model has no input)" if kind != "phi" else ""))
        for opt, lab, orders in (("--ar", "na", self.ar), ("--arma", "na", self.arma)):
            if orders is not None and orders[0] < 1:
                raise CLIError(f"{opt}: {lab} must be >= 1, got {orders[0]}")
        for opt, orders, at in (("--bj", self.bj, 0), ("--oe", self.oe, 0)):
            if orders is not None and orders[at] < 1:
                raise CLIError(f"{opt}: nb must be >= 1, got {orders[at]}")
        if self.dt is not None and not (np.isfinite(self.dt) and self.dt > 0):
            raise CLIError(f"--dt must be a sample time in seconds > 0, got {self.dt:g}")
        if self.intercept and kind not in ("arx", "fir"):
            raise CLIError(f"--intercept applies to --arx or --fir, not {chosen[0]}"
                           + (" (add a column of ones to --phi)" if kind == "phi" else ""))
        if self.detrend is not None and self.detrend not in ("constant", "linear"):
            raise CLIError(f"--detrend must be constant or linear, got {self.detrend!r}")
        if self.validate is not None and not (0.0 < self.validate < 1.0):
            raise CLIError(f"--validate must be a fraction in (0, 1) (the part of the record used "
                           f"for estimation), got {self.validate:g}")
        if kind == "dc-motor":
            for opt, val in (("--detrend", self.detrend), ("--validate", self.validate),
                             ("--dt", self.dt)):
                if val is not None:
                    raise CLIError(f"{opt} does not apply to --dc-motor (its regressors are "
                                   "physical signals and filtered derivatives)")
        if kind == "dc-motor":
            for opt, val in (("--y", self.y), ("--u", self.u)):
                if val is not None:
                    raise CLIError(f"{opt} does not apply to --dc-motor (use --voltage, --current, "
                                   "--speed, --time to name its columns)")
        else:
            for opt, val in (("--voltage", self.voltage), ("--current", self.current),
                             ("--speed", self.speed), ("--cutoff", self.cutoff),
                             ("--speed-kind", self.speed_kind)):
                if val is not None:
                    raise CLIError(f"{opt} applies to --dc-motor only")
        if self.speed_kind is not None and self.speed_kind not in ("sampled", "interval_mean"):
            raise CLIError(f"--speed-kind must be 'sampled' or 'interval_mean', got {self.speed_kind!r}")
        if self.cutoff is not None and not self.cutoff > 0:
            raise CLIError(f"--cutoff must be a frequency > 0 (Hz), got {self.cutoff:g}")


@dataclass
class Problem:
    """The regression(s) of one ``adaptid fit`` run."""

    kind: str
    equations: list                 # of (title, names, Phi, y, index)
    n_rows: int
    time: np.ndarray | None = None  # abscissa of the record (time column) if any
    regs: object = None             # DCMotorRegressors for --dc-motor
    columns: list = field(default_factory=list)
    nan_rows: int = 0
    data: object = None             # IDData of the whole record (detrended as a whole without --validate)
    est_data: object = None         # the estimation part (all of data without --validate)
    val_data: object = None         # the held-out part (--validate)
    time_name: str | None = None    # the --time column's name
    datetime: bool = False          # the time column holds date-times (time is datetime64)
    dt_source: str | None = None    # where the sample time came from (JSON "dt_source")
    offsets: dict | None = None     # --detrend: what was removed from each part (JSON)


def _nan_check(table: Table, cols: dict, nan_policy: str) -> int:
    """Count rows with a missing value in the columns used; raise for --nan error."""
    N = len(next(iter(cols.values())))
    bad = np.zeros(N, dtype=bool)
    first_col = {}
    for name, x in cols.items():
        m = np.isnan(x) if x.ndim == 1 else np.isnan(x).any(axis=1)
        if m.any():
            first_col[name] = int(np.argmax(m))
        bad |= m
    count = int(bad.sum())
    if count and nan_policy != "skip":
        rows = np.flatnonzero(bad)[:5] + 1
        col, at = min(first_col.items(), key=lambda kv: kv[1])
        more = ", …" if count > 5 else ""
        raise CLIError(f"{table.path}: {count} row(s) with missing values (empty, NA or NaN) in the "
                       f"columns used, rows {', '.join(map(str, rows))}{more} (first in column "
                       f"{col!r}, row {at + 1}); use --nan skip to skip them")
    if count and count == N:
        empty = [name for name, x in cols.items() if np.isnan(x).all()]
        why = f" (column {empty[0]!r} is all missing)" if empty else ""
        raise CLIError(f"{table.path}: no samples left after --nan skip: all {N} rows have a "
                       f"missing value in the columns used{why}")
    return count


def _time_axis(table: Table, s: Structure):
    """The --time column: (values for axes and files, is_datetime); datetime64 for date-times."""
    if s.time is None:
        return None, False
    t = table.column(s.time, "--time")   # checks the column (present, numeric or date-time)
    stamps = table.datetimes(s.time)
    if stamps is not None:
        return stamps, True
    return t, False


def _sample_time(time, is_dt) -> float:
    """dt for the models (to_control): the median step of the time column, else 1."""
    if time is None or len(time) < 2:
        return 1.0
    steps = np.diff(time).astype("timedelta64[ns]").astype(np.int64) * 1e-9 if is_dt \
        else np.diff(time)
    steps = steps[np.isfinite(steps)]
    dt = float(np.median(steps)) if steps.size else 1.0
    return dt if dt > 0 else 1.0


class _Raw:
    """The columns of a record with missing values (no IDData: that needs finite samples)."""

    def __init__(self, y, X):
        self.y, self.inputs = y, X

    def __len__(self):
        return len(self.y)


def _record(table: Table, s: Structure, nan_policy: str):
    """The IDData of the columns used (split, detrended), the column names and the NaN rows."""
    kind = s.kind
    in_names = s.phi if kind == "phi" else s.u if kind in INPUT_KINDS else []
    cols = table.expand(in_names, "--phi" if kind == "phi" else "--u") if in_names else []
    opt = "--phi" if kind == "phi" else "--u"
    seen = set()
    for name in cols:
        if name in seen:  # the same regressor twice: Φ rank-deficient, the state ambiguous
            raise CLIError(f"{opt} must name each column once, got {name!r} twice")
        seen.add(name)
    y = table.column(s.y, "--y")
    X = table.columns(cols, "--phi" if kind == "phi" else "--u") if cols else np.zeros((len(y), 0))
    if cols and len(y) != len(X):
        raise CLIError(f"{table.path}: --y column {s.y!r} has {len(y)} rows, the other columns {len(X)}")
    time, is_dt = _time_axis(table, s)
    if time is not None and len(time) != len(y):
        raise CLIError(f"{table.path}: --time column {s.time!r} has {len(time)} rows, --y {len(y)}")
    nan = _nan_check(table, {s.y: y, **{n: X[:, j] for j, n in enumerate(cols)}}, nan_policy)
    if nan:
        for opt, on in (("--detrend", s.detrend is not None), ("--validate", s.validate is not None),
                        (f"--{kind}", kind in PSEUDO_LINEAR)):
            if on:
                raise CLIError(f"{table.path}: {nan} row(s) with missing values; {opt} needs a "
                               "complete record (a gap breaks the "
                               + ("filtered signals of the recursion" if opt == f"--{kind}"
                                  else "trend and the held-out simulation") + ")")
    if nan:  # --nan skip: the estimators skip the incomplete rows; IDData holds complete records
        raw = _Raw(y, X)
        return None, raw, None, cols, time, is_dt, nan, None
    data, source = _iddata(table, s, y, X if cols else None, time, is_dt, cols)
    est, val = data, None
    if s.validate is not None:
        try:
            est, val = data.split(s.validate)
        except ValueError as e:
            raise CLIError(f"--validate {s.validate:g}: {e}") from None
    if s.detrend is not None:   # each part on its own (MATLAB practice), or the whole record
        if val is None:
            data = est = data.detrend(s.detrend)
        else:
            est, val = est.detrend(s.detrend), val.detrend(s.detrend)
    return data, est, val, cols, time, is_dt, nan, source


def _iddata(table, s, y, X, time, is_dt, cols):
    """The IDData of the record and where its ``dt`` came from.

    ``--dt`` if given (IDData refuses one that contradicts the time column);
    else IDData's own rule: the step of a regular time column, 1 without one;
    an irregular time column without ``--dt`` takes its median step (IDData
    accepts that as the nominal sample time).
    """
    from adaptid import IDData

    def make(dt):
        return IDData(y, X, dt=dt, time=time, y_names=s.y, u_names=cols or None)

    try:
        if s.dt is not None:
            return make(s.dt), "--dt"
        try:
            return make(None), "time column" if time is not None else "default (no time column)"
        except ValueError as e:
            if "irregular" not in str(e):
                raise
            return make(_sample_time(time, is_dt)), "median step of the irregular time column"
    except (ValueError, TypeError) as e:
        raise CLIError(f"{table.path}: " + (f"--dt {s.dt:g}: " if s.dt is not None else "")
                       + str(e)) from None


def detrend_offsets(problem) -> dict | None:
    """``--detrend``: what was removed from each part, per signal.

    ``constant``: the mean; ``linear``: the line's values at the part's first
    and last sample. Keys ``estimation`` (and ``validation`` with --validate).
    """
    def part(d):
        names = list(d.y_names) + list(d.u_names)
        trend = np.column_stack([d.y_trend, d.u_trend])
        if trend.shape[0] == 0:
            return {}
        return {n: (float(trend[0, j]) if np.all(trend[:, j] == trend[0, j])
                    else [float(trend[0, j]), float(trend[-1, j])]) for j, n in enumerate(names)}

    if problem.est_data is None or getattr(problem.est_data, "y_trend", None) is None:
        return None
    out = {"estimation": part(problem.est_data)}
    if problem.val_data is not None:
        out["validation"] = part(problem.val_data)
    return out


def build_problem(table: Table, s: Structure, nan_policy: str) -> Problem:
    kind = s.kind
    if kind != "dc-motor":
        from adaptid import models

        data, est, val, cols, time, is_dt, nan, source = _record(table, s, nan_policy)
        y = np.ascontiguousarray(est.y, dtype=np.float64)
        n_rows = len(data) if data is not None else len(est)
        common = dict(time=time, columns=[s.y, *cols], nan_rows=nan, data=data, est_data=est,
                      val_data=val, time_name=s.time, datetime=is_dt, dt_source=source)
        if kind == "phi":
            return Problem(kind, [("regression", list(cols), np.array(est.inputs), y,
                                   np.arange(len(y)))], n_rows, **common)
        if kind in PSEUDO_LINEAR:  # pseudo-linear: no fixed regressors (models' fit_recursive)
            return Problem(kind, [(kind.upper(), None, None, y, None)], n_rows, **common)
        u = None if not cols else est.inputs[:, 0] if len(cols) == 1 else est.inputs
        try:
            if kind == "arx":
                na, nb, nk = s.arx
                reg = models.arx_regressors(y, u, na, nb, nk)
            elif kind == "ar":
                na, nb = s.ar[0], 0
                reg = models.arx_regressors(y, np.zeros(len(y)), na, 0, 1)
            else:
                na, (nb, nk) = 0, s.fir
                reg = models.fir_regressors(y, u, nb, nk)
        except ValueError as e:
            raise CLIError(f"--{kind}: {e}") from None
        names, Phi = polynomial_form(reg.Phi, na, cols, nb)
        if s.intercept:
            names, Phi = names + ["intercept"], np.column_stack([Phi, np.ones(len(Phi))])
        return Problem(kind, [(kind.upper(), names, np.ascontiguousarray(Phi),
                               np.asarray(reg.y, dtype=float), np.asarray(reg.index))],
                       n_rows, **common)
    # dc-motor
    from adaptid import models

    names = {"time": s.time or "time", "voltage": s.voltage or "voltage",
             "current": s.current or "current", "speed": s.speed or "speed"}
    cols = {role: table.column(col, "--dc-motor" if getattr(s, role) is None else f"--{role}")
            for role, col in names.items()}
    if len({len(c) for c in cols.values()}) > 1:
        raise CLIError(f"{table.path}: the --dc-motor columns have different lengths")
    nan = _nan_check(table, {names[r]: c for r, c in cols.items()}, nan_policy)
    try:
        regs = models.dc_motor_regressors(cols["time"], cols["voltage"], cols["current"],
                                          cols["speed"], cutoff=s.cutoff,
                                          speed_kind=s.speed_kind or "sampled")
    except ValueError as e:
        raise CLIError(f"--dc-motor: {e}") from None
    eqs = []
    for title, reg in (("electrical", regs.electrical), ("mechanical", regs.mechanical)):
        eqs.append((title, list(reg.names), reg.Phi, np.asarray(reg.y, dtype=float),
                    np.asarray(reg.index)))
    return Problem("dc-motor", eqs, len(cols["time"]), time=cols["time"], regs=regs,
                   columns=list(names.values()), nan_rows=nan)
