r"""The summary table of a fit: text for the shell, HTML for notebooks (numpy only)."""

from __future__ import annotations

import html
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Summary"]

_PARAM_COLUMNS = ("estimate", "stderr", "t", "P>|t|", "lower", "upper")


def _fmt(v):
    if isinstance(v, str):
        return v
    if isinstance(v, (bool, np.bool_)):
        return "yes" if v else "no"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    v = float(v)
    if not np.isfinite(v):
        return str(v)
    return f"{v:.6g}" if v == 0 or 1e-4 <= abs(v) < 1e6 else f"{v:.4e}"


@dataclass(frozen=True, eq=False)
class Summary:
    r"""A fit's summary: a parameter table and a list of statistics.

    Attributes
    ----------
    title : str
    names : tuple of str, length n
        Parameter names.
    params : ndarray, shape (n, 6)
        Columns estimate, stderr, t, P>|t|, lower, upper (the (1 − α)
        confidence limits).
    stats : dict
        Label → value (N, dof, σ̂², log-likelihood, AIC, BIC, FPE, R², fit %,
        Ljung–Box p, …), in display order.
    alpha : float
        Level of the confidence limits.
    notes : tuple of str
        Lines printed under the tables (data names, the σ̂² rule, …).
    """

    title: str
    names: tuple
    params: np.ndarray
    stats: dict
    alpha: float = 0.05
    notes: tuple = field(default=())

    def __getitem__(self, label):
        """A statistic by its label, e.g. ``summary["AIC"]``."""
        return self.stats[label]

    def _param_header(self):
        lo = f"[{self.alpha / 2:.3g}"
        hi = f"{1 - self.alpha / 2:.3g}]"
        return ("", "estimate", "std err", "t", "P>|t|", lo, hi)

    def as_text(self) -> str:
        """The summary as fixed-width text."""
        head = self._param_header()
        rows = [head] + [(str(nm), *(_fmt(v) for v in row)) for nm, row in zip(self.names, self.params)]
        widths = [max(len(r[j]) for r in rows) for j in range(len(head))]
        lines = ["  ".join(c.ljust(w) if j == 0 else c.rjust(w) for j, (c, w) in
                           enumerate(zip(r, widths))) for r in rows]
        width = max(len(self.title), max(len(ln) for ln in lines))
        st = [(str(k), _fmt(v)) for k, v in self.stats.items()]
        kw = max((len(k) for k, _ in st), default=0)
        out = [self.title, "=" * width]
        out += [f"{k.ljust(kw)}  {v}" for k, v in st]
        out += ["-" * width, lines[0], "-" * width, *lines[1:], "=" * width]
        out += list(self.notes)
        return "\n".join(out)

    def __str__(self) -> str:
        return self.as_text()

    def __repr__(self) -> str:
        return self.as_text()

    def _repr_html_(self) -> str:
        esc = html.escape
        st = "".join(f"<tr><th style='text-align:left'>{esc(str(k))}</th><td>{esc(_fmt(v))}</td></tr>"
                     for k, v in self.stats.items())
        head = "".join(f"<th>{esc(h)}</th>" for h in self._param_header())
        body = "".join("<tr><th style='text-align:left'>" + esc(str(nm)) + "</th>" +
                       "".join(f"<td>{esc(_fmt(v))}</td>" for v in row) + "</tr>"
                       for nm, row in zip(self.names, self.params))
        notes = "".join(f"<p>{esc(n)}</p>" for n in self.notes)
        return (f"<div><strong>{esc(self.title)}</strong><table>{st}</table>"
                f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>{notes}</div>")

    def to_frame(self):
        """The parameter table as a pandas DataFrame (``pip install 'adaptid[pandas]'``)."""
        try:
            import pandas as pd
        except ImportError as err:  # pragma: no cover - depends on the extra
            raise ImportError("to_frame needs pandas: pip install 'adaptid[pandas]'") from err
        return pd.DataFrame(self.params, index=list(self.names), columns=list(_PARAM_COLUMNS))


def parameter_rows(theta, stderr, dof, alpha):
    """(n, 6) array of estimate, stderr, t, p, lower, upper."""
    from ._teststats import t_table

    t, p, lo, hi = t_table(theta, stderr, dof, alpha)
    return np.column_stack([theta, stderr, t, p, lo, hi])
