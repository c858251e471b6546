r"""Text of the diagnostics' results as R prints them (``print.htest``, ``format.pval``)."""

from __future__ import annotations

import numpy as np

__all__ = ["format_pval", "format_num", "htest_text", "short_repr", "frame"]

#: R's ``.Machine$double.eps``: p-values below it print as ``< 2.2e-16``.
EPS = float(np.finfo(float).eps)


def format_num(x, digits=5) -> str:
    """``x`` as R's ``format(x, digits = digits)`` prints one number.

    At most ``digits`` significant digits, trailing zeros dropped; fixed
    notation unless scientific is shorter (R's default ``scipen = 0``).
    """
    if x is None:
        return "NA"
    x = float(x)
    if np.isnan(x):
        return "NA"
    if np.isinf(x):
        return "Inf" if x > 0 else "-Inf"
    if x == 0:
        return "0"
    mant, exp = f"{x:.{digits - 1}e}".split("e")
    if "." in mant:
        mant = mant.rstrip("0").rstrip(".")
    e = int(exp)
    sci = f"{mant}e{'-' if e < 0 else '+'}{abs(e):02d}"
    sig = len(mant.lstrip("-").replace(".", ""))
    fixed = f"{x:.{max(0, sig - 1 - e)}f}"
    return fixed if len(fixed) <= len(sci) else sci


def format_pval(p, digits=4, eps=EPS) -> str:
    r"""A p-value as R's ``format.pval(p, digits, eps)`` prints it.

    Below ``eps`` (machine epsilon, 2.220446e-16) it is ``"< 2.2e-16"``
    (``eps`` with ``digits`` − 2 ≥ 1 significant digits, as R);
    otherwise ``p`` with ``digits`` significant digits (4 in
    ``print.htest``); NaN is ``"NA"``.

    Examples
    --------
    >>> format_pval(1e-20), format_pval(0.0123441), format_pval(0.5)
    ('< 2.2e-16', '0.01234', '0.5')
    """
    if p is None or np.isnan(float(p)):
        return "NA"
    p = float(p)
    if p < eps:
        return "< " + format_num(eps, max(1, digits - 2))
    return format_num(p, digits)


def htest_text(method, data=None, statistics=(), pvalue=None, extra=()) -> str:
    r"""A test's text in the layout of R's ``print.htest``.

    Parameters
    ----------
    method : str
        Title (``"OLS-based CUSUM test"``).
    data : str, optional
        The ``data:`` line.
    statistics : sequence of (name, value)
        Printed ``name = value`` (5 significant digits), comma separated.
    pvalue : float, optional
        Printed as :func:`format_pval` (``p-value < 2.2e-16`` or
        ``p-value = 0.01234``).
    extra : sequence of str
        Lines after the statistics (break dates, …).
    """
    out = ["", "\t" + method, ""]
    if data is not None:
        out.append("data:  " + str(data))
    parts = [f"{name} = {format_num(v)}" for name, v in statistics]
    if pvalue is not None:
        fp = format_pval(pvalue)
        parts.append("p-value " + (fp if fp.startswith("<") else "= " + fp))
    if parts:
        out.append(", ".join(parts))
    out.extend(extra)
    out.append("")
    return "\n".join(out)


def short_repr(cls, /, **fields) -> str:
    """``Cls(a=1.234, pvalue=0.01234)`` on one line: scalars only, never arrays."""
    items = []
    for k, v in fields.items():
        if k == "pvalue":
            fp = format_pval(v)
            items.append("pvalue" + (fp.replace(" ", "") if fp.startswith("<") else "=" + fp))
            continue
        if isinstance(v, (float, np.floating)):
            v = format_num(v)
        elif isinstance(v, str):
            v = repr(v)
        items.append(f"{k}={v}")
    return f"{cls}({', '.join(items)})"


def frame(rows, columns, index=None):
    """A pandas DataFrame of ``rows`` (list of tuples); a dict of columns without pandas."""
    try:
        import pandas as pd
    except ImportError:  # pragma: no cover - depends on the install
        cols = {c: [r[j] for r in rows] for j, c in enumerate(columns)}
        if index is not None:
            cols = {"index": list(index), **cols}
        return cols
    return pd.DataFrame(list(rows), columns=list(columns), index=index)
