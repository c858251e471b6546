r"""Table-driven regressor builder: columns, lags, products and sign() of a DataFrame."""

from __future__ import annotations

import re
from collections.abc import Mapping

import numpy as np

from .._validation import as_float_array, param_error
from ._regression import Regression

__all__ = ["table_regressors"]

_FUNCS = {"sign": np.sign, "abs": np.abs}
_FUNC_RE = re.compile(r"^\s*(sign|abs)\s*\((.*)\)\s*$")
_LAG_RE = re.compile(r"^(.*?)\s*\[\s*k\s*(?:-\s*(\d+)\s*)?\]\s*$")


def _split_product(text):
    """Split ``a*b*c`` at the top level (not inside parentheses or brackets)."""
    parts, depth, cur = [], 0, []
    for ch in text:
        if ch in "([":
            depth += 1
        elif ch in ")]":
            depth -= 1
        if ch == "*" and depth == 0:
            parts.append("".join(cur))
            cur = []
        else:
            cur.append(ch)
    parts.append("".join(cur))
    return [p.strip() for p in parts]


class _Factor:
    __slots__ = ("column", "lag", "funcs")

    def __init__(self, column, lag=0, funcs=()):
        self.column, self.lag, self.funcs = column, lag, tuple(funcs)

    def name(self):
        text = self.column if self.lag == 0 else f"{self.column}[k-{self.lag}]"
        for f in reversed(self.funcs):
            text = f"{f}({text})"
        return text


def _parse_factor_str(text, columns, where):
    text = text.strip()
    if text in columns:                         # exact column name wins
        return _Factor(text)
    m = _FUNC_RE.match(text)
    if m:
        inner = _parse_factor_str(m.group(2), columns, where)
        return _Factor(inner.column, inner.lag, (m.group(1),) + inner.funcs)
    m = _LAG_RE.match(text)
    if m:
        col = m.group(1).strip()
        lag = int(m.group(2) or 0)
        if col in columns:
            return _Factor(col, lag)
        text = col
    if not text:
        raise param_error(where, "a term such as 'x', 'x[k-2]', 'x*z', 'sign(x[k-1])' or '1'",
                          "<an empty factor>")
    avail = ", ".join(repr(c) for c in columns)
    raise param_error(where, f"built from columns of df ({avail})", f"<no column {text!r}>")


def _parse_factor_tuple(spec, columns, where):
    if not (2 <= len(spec) <= 3) or not isinstance(spec[0], str):
        raise param_error(where, "a factor tuple (column, lag) or (column, lag, 'sign'|'abs')", spec)
    col = spec[0]
    try:
        lag = int(spec[1])
    except (TypeError, ValueError):
        raise param_error(where, "a factor tuple with an integer lag", spec) from None
    if lag < 0 or lag != spec[1]:
        raise param_error(where, "a factor tuple with an integer lag >= 0", spec)
    funcs = ()
    if len(spec) == 3 and spec[2] is not None:
        if spec[2] not in _FUNCS:
            raise param_error(where, "a factor tuple whose function is 'sign', 'abs' or None", spec)
        funcs = (spec[2],)
    if col not in columns:
        avail = ", ".join(repr(c) for c in columns)
        raise param_error(where, f"built from columns of df ({avail})", f"<no column {col!r}>")
    return _Factor(col, lag, funcs)


def _is_factor_tuple(spec):
    return (isinstance(spec, tuple) and len(spec) >= 2 and isinstance(spec[0], str)
            and isinstance(spec[1], (int, np.integer)) and not isinstance(spec[1], bool))


def _parse_term(spec, columns, where):
    """A term → list of factors (empty list: the constant 1)."""
    if isinstance(spec, str):
        if spec.strip() == "1":
            return []
        if spec.strip() in columns:
            return [_Factor(spec.strip())]
        return [_parse_factor_str(p, columns, where) for p in _split_product(spec)]
    if _is_factor_tuple(spec):
        return [_parse_factor_tuple(spec, columns, where)]
    if isinstance(spec, (tuple, list)) and len(spec) > 0:
        out = []
        for j, f in enumerate(spec):
            if isinstance(f, str):
                out.append(_parse_factor_str(f, columns, f"{where}[{j}]"))
            elif isinstance(f, tuple):
                out.append(_parse_factor_tuple(f, columns, f"{where}[{j}]"))
            else:
                raise param_error(f"{where}[{j}]", "a factor string or (column, lag) tuple", f)
        return out
    raise param_error(where, "a term string, a (column, lag) tuple or a list of factors", spec)


def _columns_of(df):
    if hasattr(df, "columns") and hasattr(df, "__getitem__"):
        return list(df.columns)
    if isinstance(df, Mapping):
        return list(df.keys())
    raise param_error("df", "a pandas DataFrame (or a mapping of column name to array)", df,
                      exc=TypeError)


def _column(df, col, cache, N):
    if col not in cache:
        values = df[col]
        values = values.to_numpy() if hasattr(values, "to_numpy") else values
        arr = as_float_array(values, f"df[{col!r}]", ndim=1)
        if arr.shape[0] != N:
            raise param_error(f"df[{col!r}]", f"of length {N}", f"<{arr.shape[0]} values>")
        cache[col] = arr
    return cache[col]


def _evaluate(factors, df, cache, N, rows):
    out = np.ones(rows.size)
    for f in factors:
        v = _column(df, f.column, cache, N)[rows - f.lag]
        for fn in reversed(f.funcs):
            v = _FUNCS[fn](v)
        out = out * v
    return out


def table_regressors(df, y, terms):
    r"""Regressors built from the columns of a table, with lags, products and sign().

    Each term is one column of Φ: a product of factors, each factor a column
    of ``df`` at sample k or lagged, optionally through ``sign`` or ``abs``.
    Row k is

    .. math::

        \varphi_k = \Big[\prod_{f \in \text{term}_1} g_f(x_{f,\,k-\ell_f}),\ \dots\Big]^T,

    for the samples k = s … N-1 whose lags are all present,
    s = the largest lag of any term (and of ``y``).

    **Term specification** (small and explicit):

    ==================================  ============================================
    ``"x"`` or ``"x[k]"``               column ``x`` at sample k
    ``"x[k-2]"``                        column ``x`` two samples back
    ``"x*z[k-1]"``                      product of factors (any number)
    ``"sign(x)"``, ``"abs(v[k-1])"``    sign / absolute value of a factor
    ``"1"``                             the constant 1 (an intercept)
    ``("x", 2)``                        tuple form of ``"x[k-2]"``, for column
                                        names with special characters
    ``("x", 0, "sign")``                tuple form of ``"sign(x)"``
    ``["x", ("z", 1)]``                 a list (or tuple) of factors: their product
    ==================================  ============================================

    A string that is exactly a column name is always that column (so names
    such as ``"i*R"`` can be used as they are). Leads (``x[k+1]``) are not
    allowed.

    Parameters
    ----------
    df : pandas.DataFrame or mapping of str to array_like, shape (N,)
        The record; rows are samples in time order (its index is not used
        for alignment).
    y : str, term or array_like, shape (N,)
        The regressand: a term as above (usually a column name) or an array.
    terms : sequence of terms, length n
        One regressor per term, in order.

    Returns
    -------
    Regression
        ``Phi`` (N - s, n); ``names`` the canonical term names (``"x[k-2]"``,
        ``"sign(v[k-1])"``, ``"i*v"``, ``"1"``); ``index`` the row positions
        k = s … N-1; ``meta["df_index"]`` the matching labels of ``df.index``
        (pandas only) and ``meta["start"]`` = s.

    Raises
    ------
    ValueError
        A term naming a column that ``df`` does not have (the message names
        the term and the missing column), a malformed term, non-finite values
        in a used column, or a record not longer than the largest lag.

    Examples
    --------
    >>> import pandas as pd
    >>> from adaptid.models import table_regressors
    >>> df = pd.DataFrame({"i": [1.0, 2, 3, 4], "w": [0.5, -1, 2, -3]})
    >>> reg = table_regressors(df, "i", ["i[k-1]", "sign(w)", "i*w[k-1]", "1"])
    >>> reg.names
    ('i[k-1]', 'sign(w)', 'i*w[k-1]', '1')
    >>> reg.Phi[0]
    array([ 1., -1.,  1.,  1.])
    """
    columns = _columns_of(df)
    if isinstance(terms, (str, bytes)) or not hasattr(terms, "__len__") or len(terms) == 0:
        raise param_error("terms", "a non-empty sequence of terms", terms)
    parsed = [_parse_term(t, columns, f"terms[{i}]") for i, t in enumerate(terms)]
    N = len(df[columns[0]]) if columns else 0
    cache = {}
    y_is_term = isinstance(y, str) or _is_factor_tuple(y) or (
        isinstance(y, (list, tuple)) and len(y) > 0
        and all(isinstance(e, (str, tuple)) for e in y))
    if y_is_term:
        y_factors = _parse_term(y, columns, "y")
        y_arr = None
    else:
        y_factors = None
        y_arr = as_float_array(y, "y", ndim=1)
        if y_arr.shape[0] != N:
            raise param_error("y", f"of length N={N} (the rows of df)", f"<{y_arr.shape[0]} samples>")
    lags = [f.lag for fs in parsed for f in fs] + [f.lag for f in (y_factors or [])]
    start = max(lags, default=0)
    if N <= start:
        raise param_error("df", f"longer than {start} rows (the largest lag in terms)",
                          f"<{N} rows>")
    rows = np.arange(start, N)
    Phi = np.empty((rows.size, len(parsed)))
    for j, fs in enumerate(parsed):
        Phi[:, j] = _evaluate(fs, df, cache, N, rows)
    if y_factors is not None:
        target = _evaluate(y_factors, df, cache, N, rows)
        y_name = "*".join(f.name() for f in y_factors) or "1"
    else:
        target = y_arr[start:].copy()
        y_name = None
    names = tuple("*".join(f.name() for f in fs) or "1" for fs in parsed)
    meta = {"structure": "table", "start": start, "y_name": y_name}
    if hasattr(df, "index") and not isinstance(df, Mapping):
        meta["df_index"] = np.asarray(df.index)[start:]
    return Regression(np.ascontiguousarray(Phi), target, names, rows, meta)
