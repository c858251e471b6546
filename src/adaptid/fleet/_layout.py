r"""The per-group plan of one partition: row order, segments and (Φ, y).

Rows are ordered stably by (group, time, stored order) and cut into one
segment per group; the regressors are gathered into C-ordered rows (from
``phi`` columns, or from ``model(group_df)`` per group) and checked.
"""

from __future__ import annotations

import numpy as np

from .._validation import param_error
from ._inputs import _float_column, _group_values, _label, _readonly


def _sort_order(codes, t, order):
    """Stable order by (group code, time, stored order); None if already sorted."""
    N = codes.shape[0]
    if N < 2:
        return None
    dc = np.diff(codes)
    ok = bool((dc >= 0).all())
    same = dc == 0
    if ok and t is not None:
        dt = np.diff(t)
        ok = bool((dt[same] >= 0).all())
        same &= dt == 0
    if ok and order is not None:
        ok = bool((np.diff(order)[same] > 0).all())
    if ok:
        return None
    keys = [np.arange(N) if order is None else order]
    if t is not None:
        keys.append(t)
    keys.append(codes)
    return np.lexsort(keys)


def _layout(part, group, t, order_col):
    """Row order and segments of a partition: (idx or None, offsets, labels, sorted time).

    Rows are ordered stably by (group, time, stored order); ``idx`` is None
    when they already are (the common case of a frame sorted by device and
    time, detected in one compiled pass without hashing the labels).
    """
    import pandas as pd

    from .._kernels.layers._fleet import scan_runs
    gv = _group_values(part, group)
    N = gv.shape[0]
    tk = t if t is not None and t.dtype.kind in "if" else None
    if order_col is None and gv.dtype.kind in "iufM" and (t is None or tk is not None):
        gk = gv.view(np.int64) if gv.dtype.kind == "M" else gv
        starts = np.empty(N + 1, dtype=np.int64)
        m, increasing, tsorted, tnan = scan_runs(
            gk, tk if tk is not None else np.empty(1), tk is not None, starts)
        if tnan:
            raise param_error("time", "free of NaN",
                              f"<a NaN time in group {_label(gv[starts[N]])}>")
        if increasing and not (gv.dtype.kind == "f" and np.isnan(gv[starts[:m]]).any()):
            offsets = np.append(starts[:m], N)
            uniq = gv[starts[:m]]
            if t is None or tsorted:
                return None, offsets, uniq, t
            codes = np.repeat(np.arange(m), np.diff(offsets))
            idx = np.lexsort((np.arange(N), t, codes))
            return idx, offsets, uniq, t[idx]
    codes, uniq = pd.factorize(gv, sort=False)
    if N and codes.min() < 0:
        raise param_error("group", "free of missing labels", "<a missing group label>")
    if t is not None and t.dtype.kind == "f" and np.isnan(t).any():
        bad = uniq[codes[np.flatnonzero(np.isnan(t))[0]]]
        raise param_error("time", "free of NaN", f"<a NaN time in group {_label(bad)}>")
    order = part[order_col].to_numpy() if order_col is not None else None
    idx = _sort_order(codes, t, order)
    if idx is not None:
        codes = codes[idx]
        if t is not None:
            t = t[idx]
    offsets = np.zeros(len(uniq) + 1, dtype=np.int64)
    np.cumsum(np.bincount(codes, minlength=len(uniq)), out=offsets[1:])
    return idx, offsets, np.asarray(uniq), t


def _gather(part, names, idx):
    """Columns ``names`` of ``part`` as C-ordered float64 rows (N, n), in row order idx."""
    from .._kernels.layers._fleet import gather_columns
    cols = [np.ascontiguousarray(_float_column(part, c, "phi")) for c in names]
    if not all(c.flags.writeable for c in cols):  # one kind of array in the tuple
        cols = [_readonly(c) for c in cols]
    cols = tuple(cols)
    out = np.empty((len(part), len(names)))
    use = idx is not None
    gather_columns(cols, idx if use else np.empty(1, dtype=np.int64), use, out)
    return out


def _regression_rows(part, idx, offsets, uniq, t, t_missing, *, y, phi, model, names):
    """(Φ, y, positions or None, time of each row, offsets) in segment order."""
    if model is not None:
        lengths = np.diff(offsets)
        Phi, Y, pos, row_t, lengths = _model_rows(part, idx, lengths, uniq, t, model, names)
        offsets = np.zeros(len(uniq) + 1, dtype=np.int64)
        np.cumsum(lengths, out=offsets[1:])
        return Phi, Y, pos, row_t, offsets
    Phi = _gather(part, phi, idx)
    Y = _float_column(part, y, "y")
    Y = np.array(Y if idx is None else Y[idx], dtype=np.float64, order="C")  # own, writable
    if t_missing is not None:  # a missing time: the sample is skipped (or refused) as NaN
        Y[t_missing if idx is None else t_missing[idx]] = np.nan
    return Phi, Y, None, t, offsets


def _model_rows(part, idx, lengths, uniq, t, model, names):
    """Apply ``model(group_df) -> Regression`` to every group of the partition."""
    from ..models._regression import Regression
    sorted_part = part if idx is None else part.iloc[idx]
    starts = np.concatenate([[0], np.cumsum(lengths)])
    Phis, Ys, poss, ts, lens = [], [], [], [], []
    for g in range(len(uniq)):
        gdf = sorted_part.iloc[starts[g]:starts[g + 1]]
        reg = model(gdf)
        if not isinstance(reg, Regression):
            raise param_error("model", "a callable returning an adaptid.models.Regression",
                              f"<{type(reg).__name__} for group {_label(uniq[g])}>", exc=TypeError)
        if tuple(reg.names) != tuple(names):
            raise param_error("model", f"returning the same regressors {tuple(names)} for "
                              "every group", f"<{tuple(reg.names)} for group {_label(uniq[g])}>")
        if np.ndim(reg.y) != 1:
            raise param_error("model", "a single-output Regression (y of shape (N,))",
                              f"<y of shape {np.shape(reg.y)} for group {_label(uniq[g])}>")
        Phis.append(np.asarray(reg.Phi, dtype=np.float64))
        Ys.append(np.asarray(reg.y, dtype=np.float64))
        ix = np.asarray(reg.index, dtype=np.int64)
        poss.append(ix)
        if t is not None:
            ts.append(t[starts[g]:starts[g + 1]][ix])
        lens.append(reg.Phi.shape[0])
    Phi = np.ascontiguousarray(np.concatenate(Phis)) if Phis else np.empty((0, len(names)))
    Y = np.concatenate(Ys) if Ys else np.empty(0)
    pos = np.concatenate(poss) if poss else np.empty(0, dtype=np.int64)
    row_t = (np.concatenate(ts) if ts else np.empty(0)) if t is not None else None
    return Phi, Y, pos, row_t, np.asarray(lens, dtype=np.int64)


def _check_lengths(offsets, uniq, n):
    lengths = np.diff(offsets)
    short = np.flatnonzero(lengths < n)
    if short.size:
        g = short[0]
        raise param_error("data", f"at least n_params={n} samples in every group",
                          f"<{int(lengths[g])} samples in group {_label(uniq[g])}>")


def _raise_nonfinite(Phi, Y, offsets, uniq):
    """With nan_policy='raise': name the group of the first non-finite value, if any."""
    finite = np.isfinite(Phi).all(axis=1) & np.isfinite(Y)
    if finite.all():
        return
    bad = int(np.flatnonzero(~finite)[0])
    g = int(np.searchsorted(offsets, bad, side="right")) - 1
    raise param_error("data", "finite (no NaN or inf) in the regressors and output with "
                      "nan_policy='raise'", f"<a non-finite value in group {_label(uniq[g])}>")

