"""From a table and the command-line options to the regression(s) to estimate."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ._errors import CLIError
from ..io import Table

__all__ = ["Structure", "Problem", "build_problem", "parse_orders", "split_names"]

DC_MOTOR_COLUMNS = ("time", "voltage", "current", "speed")


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


def polynomial_form(Phi, na: int, inputs, nb: int):
    r"""ARX/FIR regressors in the model objects' polynomial convention, and their names.

    :func:`adaptid.models.arx_regressors` puts :math:`+y_{k-j}` in the
    first ``na`` columns; :class:`adaptid.models.ARX` writes
    :math:`A(q) = 1 + a_1q^{-1} + \dots`, whose coefficient multiplies
    :math:`-y_{k-j}`. The columns are negated (exactly: a sign flip) so that
    θ holds :math:`a_1, \dots, a_{n_a}` as ``models.ARX`` reports them. Names:
    ``a1`` … ``a{na}``, then for each input column ``c`` (in ``--u`` order)
    ``b_c[0]`` … ``b_c[nb-1]``, :math:`b_j` being the model objects' ``bj``
    (coefficient of :math:`q^{-(n_k + j)}` in :math:`B(q)`).
    """
    Phi = np.array(Phi, dtype=np.float64, order="C")
    Phi[:, :na] *= -1.0
    names = [f"a{j}" for j in range(1, na + 1)]
    for col in inputs:
        names += [f"b_{col}[{j}]" for j in range(nb)]
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
    dc_motor: bool = False
    time: str | None = None
    voltage: str | None = None
    current: str | None = None
    speed: str | None = None
    cutoff: float | None = None
    speed_kind: str | None = None

    @property
    def kind(self) -> str:
        return ("phi" if self.phi is not None else "arx" if self.arx is not None
                else "fir" if self.fir is not None else "dc-motor" if self.dc_motor else "none")

    def check(self):
        chosen = [opt for opt, on in (("--phi", self.phi is not None), ("--arx", self.arx is not None),
                                      ("--fir", self.fir is not None), ("--dc-motor", self.dc_motor)) if on]
        if not chosen:
            raise CLIError("give the regressors: --y COL --phi COL,..., --arx na,nb,nk --u COL --y COL, "
                           "--fir nb,nk --u COL --y COL, or --dc-motor")
        if len(chosen) > 1:
            raise CLIError(f"{' and '.join(chosen)} cannot be combined: choose one model structure")
        kind = self.kind
        if kind in ("phi", "arx", "fir") and self.y is None:
            raise CLIError(f"{chosen[0]} needs --y COL (the output column)")
        if kind in ("arx", "fir") and self.u is None:
            raise CLIError(f"{chosen[0]} needs --u COL (the input column)")
        if kind == "phi" and self.u is not None:
            raise CLIError("--u applies to --arx or --fir, not --phi")
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
    if count and nan_policy == "error":
        rows = np.flatnonzero(bad)[:5] + 1
        col, at = min(first_col.items(), key=lambda kv: kv[1])
        more = ", …" if count > 5 else ""
        raise CLIError(f"{table.path}: {count} row(s) with missing values (empty, NA or NaN) in the "
                       f"columns used, rows {', '.join(map(str, rows))}{more} (first in column "
                       f"{col!r}, row {at + 1}); use --nan skip to skip them")
    return count


def _y_and_columns(table: Table, s: Structure, names, option: str, nan_policy: str):
    """The --y column, the columns ``names`` of ``option``, --time, and the NaN rows."""
    cols = table.expand(names, option)
    y = table.column(s.y, "--y")
    X = table.columns(cols, option)
    if len(y) != len(X):
        raise CLIError(f"{table.path}: --y column {s.y!r} has {len(y)} rows, {option} columns {len(X)}")
    time = table.column(s.time, "--time") if s.time is not None else None
    nan = _nan_check(table, {s.y: y, **{n: X[:, j] for j, n in enumerate(cols)}}, nan_policy)
    return cols, y, X, time, nan


def build_problem(table: Table, s: Structure, nan_policy: str) -> Problem:
    kind = s.kind
    if kind == "phi":
        phi_names, y, Phi, time, nan = _y_and_columns(table, s, s.phi, "--phi", nan_policy)
        return Problem(kind, [("regression", phi_names, Phi, y, np.arange(len(y)))], len(y),
                       time=time, columns=[s.y, *phi_names], nan_rows=nan)
    if kind in ("arx", "fir"):
        from adaptid import models

        u_names, y, U, time, nan = _y_and_columns(table, s, s.u, "--u", nan_policy)
        u = U[:, 0] if U.shape[1] == 1 else U
        try:
            if kind == "arx":
                na, nb, nk = s.arx
                reg = models.arx_regressors(y, u, na, nb, nk)
            else:
                nb, nk = s.fir
                reg = models.fir_regressors(y, u, nb, nk)
        except ValueError as e:
            raise CLIError(f"--{kind}: {e}") from None
        names, Phi = polynomial_form(reg.Phi, s.arx[0] if kind == "arx" else 0, u_names,
                                     s.arx[1] if kind == "arx" else s.fir[0])
        return Problem(kind, [(kind.upper(), names, Phi, np.asarray(reg.y, dtype=float),
                               np.asarray(reg.index))], len(y), time=time,
                       columns=[s.y, *u_names], nan_rows=nan)
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
