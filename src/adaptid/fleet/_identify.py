r"""The same identification for every device of a fleet, as one Dask computation."""

from __future__ import annotations

import numbers
import os
import threading
import uuid

import numpy as np

from .._validation import check_choice, check_int, check_scalar, param_error
from ..estimators import METHODS

__all__ = ["identify"]

#: tests with a p-value (adaptid.diagnostics.change_tests), and BDE's CUSUM crossing
_PVALUE_TESTS = ("supF", "re", "cusum", "cusum2")
_CHANGE_TESTS = _PVALUE_TESTS + ("a-priori", "recursive")
_MULTIPLE = ("bh", "bonferroni", "none")
_STAT_COLUMNS = ("n_samples", "n_skipped", "sigma2", "rms", "change", "change_stat",
                 "change_pvalue", "change_at")
_ORDER = "__adaptid_order__"
_KERNEL_LOCK = threading.Lock()


def _need(module):
    import importlib
    try:
        return importlib.import_module(module)
    except ImportError as err:  # pragma: no cover - depends on the install
        raise ImportError(f"adaptid.fleet needs {module.split('.')[0]}: "
                          "pip install 'adaptid[dask]'") from err


def _make_estimator(method, n, nan_policy, options):
    """The prototype estimator of every group, from :func:`adaptid.estimator`."""
    from ..estimators import estimator
    if "n_outputs" in options:
        raise param_error("n_outputs", "not given (the fleet identifies single-output "
                          "models)", options["n_outputs"], exc=TypeError)
    return estimator(method, n, nan_policy=nan_policy, **options)


def _constant_forgetting(est):
    """The estimator's constant λ (1 for Kalman and for a forgetting strategy).

    A strategy's λₖ are not returned by ``run_segments``, so its factors are
    taken as 1, as :func:`adaptid.recursive_fit_stats` does without
    ``forgetting=``.
    """
    lam = getattr(est, "forgetting", None)
    if isinstance(lam, numbers.Real) and not isinstance(lam, bool):
        return float(lam)
    return 1.0


def _bde_a(alpha):
    from ..diagnostics._cusum import _bde_critical_value
    return _bde_critical_value(alpha)


# --------------------------------------------------------------- one partition
def _group_values(part, group):
    return part[group].to_numpy() if group in part.columns else part.index.to_numpy()


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


def _float_column(part, name, arg):
    """Column ``name`` as float64 (N,): any numeric or bool dtype, pandas nullable ones
    (``pd.NA`` → NaN) and read-only arrays; anything else is refused naming the column."""
    import pandas as pd
    s = part[name]
    dt = s.dtype
    if isinstance(dt, np.dtype) and dt.kind in "fiub":
        a = s.to_numpy()
        return a if dt == np.float64 else a.astype(np.float64)
    if not isinstance(dt, np.dtype) and (pd.api.types.is_numeric_dtype(dt)
                                         or pd.api.types.is_bool_dtype(dt)):
        return s.to_numpy(dtype=np.float64, na_value=np.nan)
    raise param_error(arg, "a numeric column", f"<column {name!r} of dtype {dt}>")


def _readonly(a):
    """A read-only view (one compiled signature for a tuple of columns of mixed origin)."""
    v = a.view()
    v.flags.writeable = False
    return v


def _time_key(part, time, group, nan_policy):
    """The ``time`` column as a sortable numeric key, and its missing rows (or None).

    Numbers stay as they are (unsigned as int64 or float64); datetime64 (naive,
    or tz-aware: converted to UTC) and timedelta become int64 nanoseconds. A
    missing time (NaN, NaT, ``pd.NA``) follows ``nan_policy``: "raise" names
    its group, "skip" sorts the row last in its group and skips the sample.
    Strings and other dtypes are refused naming the column.
    """
    import pandas as pd
    if time is None:
        return None, None
    s = part[time]
    dt = s.dtype
    if pd.api.types.is_datetime64_any_dtype(dt) or pd.api.types.is_timedelta64_dtype(dt):
        vals = s.to_numpy(dtype="timedelta64[ns]" if pd.api.types.is_timedelta64_dtype(dt)
                          else "datetime64[ns]")
        missing = np.isnat(vals)
        key = vals.view(np.int64)
        fill = np.iinfo(np.int64).max
    elif pd.api.types.is_bool_dtype(dt) or not pd.api.types.is_numeric_dtype(dt):
        raise param_error("time", "a numeric, datetime64 or timedelta64 column",
                          f"<column {time!r} of dtype {dt}>")
    else:
        key = _float_column(part, time, "time") if not (
            isinstance(dt, np.dtype) and dt.kind in "iu") else s.to_numpy()
        if key.dtype.kind == "u":
            key = key.astype(np.int64 if key.dtype.itemsize < 8 else np.float64)
        missing = np.isnan(key) if key.dtype.kind == "f" else None
        fill = np.inf
    if missing is None or not missing.any():
        return key, None
    if nan_policy == "raise":
        g = _group_values(part, group)[int(np.argmax(missing))]
        raise param_error("time", "free of NaN and NaT with nan_policy='raise'",
                          f"<a missing time in group {_label(g)}>")
    key = key.copy()
    key[missing] = fill
    return key, missing


def _label(value) -> str:
    """A group label for messages: 13, 'pump-7' (numpy scalars shown as Python ones)."""
    return repr(value.item() if isinstance(value, np.generic) else value)


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


def _identify_partition(part, *, group, y, phi, model, time, est, names, alpha_a,
                        change_test, burn_in, tracks, order_col):
    """One partition: order the rows, build (Φ, y), run the segments, one row per group."""
    t_key, t_missing = _time_key(part, time, group, est.nan_policy)
    if t_missing is not None and model is not None:  # the model sees only timed rows
        part, t_key, t_missing = part[~t_missing], t_key[~t_missing], None
    idx, offsets, uniq, t = _layout(part, group, t_key, order_col)
    Phi, Y, pos, row_t, offsets = _regression_rows(part, idx, offsets, uniq, t, t_missing,
                                                   y=y, phi=phi, model=model, names=names)
    _check_lengths(offsets, uniq, len(names))
    _limit_threads()
    with _KERNEL_LOCK:
        try:
            res = est.run_segments(Phi, Y, offsets, store=tracks is not None)
        except ValueError:
            _raise_nonfinite(Phi, Y, offsets, uniq)
            raise
        stats = _statistics(est, res, Phi, Y, offsets, alpha_a, change_test, burn_in)
    out = _result_frame(res, stats, names, uniq, group, offsets, row_t, pos)
    if tracks is not None:
        lengths = np.diff(offsets)
        if pos is None:
            pos = np.arange(len(Y)) - np.repeat(offsets[:-1], lengths)
        _write_tracks(tracks, group, uniq, lengths, res, names, pos, row_t, time)
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


def _check_lengths(offsets, uniq, n):
    lengths = np.diff(offsets)
    short = np.flatnonzero(lengths < n)
    if short.size:
        g = short[0]
        raise param_error("data", f"at least n_params={n} samples in every group",
                          f"<{int(lengths[g])} samples in group {_label(uniq[g])}>")


def _result_frame(res, stats, names, uniq, group, offsets, row_t, pos):
    """The per-group table: θ, standard errors, counts, σ̂², RMS and the change flag."""
    import pandas as pd
    G = len(uniq)
    cols = {c: res.theta[:, j] for j, c in enumerate(names)}
    cols.update({f"stderr_{c}": stats["stderr"][:, j] for j, c in enumerate(names)})
    first = stats["first"]
    has = first >= 0
    at = np.full(G, np.nan)
    if has.any():
        rows = first[has]
        if row_t is not None:
            at[has] = np.asarray(row_t[rows], dtype=np.float64)
        elif pos is not None:
            at[has] = pos[rows]
        else:
            at[has] = rows - offsets[:-1][has]
    cols.update(n_samples=res.n_samples, n_skipped=res.n_skipped, sigma2=stats["sigma2"],
                rms=stats["rms"], change=has, change_stat=stats["ratio"],
                change_pvalue=stats["pvalue"], change_at=at)
    return pd.DataFrame(cols, index=pd.Index(uniq, name=group))


def _raise_nonfinite(Phi, Y, offsets, uniq):
    """With nan_policy='raise': name the group of the first non-finite value, if any."""
    finite = np.isfinite(Phi).all(axis=1) & np.isfinite(Y)
    if finite.all():
        return
    bad = int(np.flatnonzero(~finite)[0])
    g = int(np.searchsorted(offsets, bad, side="right")) - 1
    raise param_error("data", "finite (no NaN or inf) in the regressors and output with "
                      "nan_policy='raise'", f"<a non-finite value in group {_label(uniq[g])}>")


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


def _limit_threads():
    """Inside a dask.distributed worker, use as many numba threads as it has threads."""
    try:
        from distributed import get_worker
        worker = get_worker()
    except Exception:  # not on a worker (or distributed not installed)
        return
    import numba
    nthreads = getattr(getattr(worker, "state", worker), "nthreads", None)
    if nthreads:
        numba.set_num_threads(max(1, min(int(nthreads), numba.config.NUMBA_NUM_THREADS)))


def _statistics(est, res, Phi, Y, offsets, alpha_a, change_test, burn_in):
    """σ̂², residual RMS, standard errors and the CUSUM flag of every segment."""
    from .._kernels.layers._fleet import residual_ss_kernel
    G = offsets.shape[0] - 1
    n = Phi.shape[1]
    used = ~res.skipped
    window = int(getattr(est, "window", 0) or 0)
    ss, wss, neff = np.empty(G), np.empty(G), np.empty(G)
    count = np.empty(G, dtype=np.int64)
    residual_ss_kernel(Phi, Y, used, offsets, np.ascontiguousarray(res.theta), window,
                       _constant_forgetting(est), ss, wss, neff, count)
    # the rule of adaptid.recursive_fit_stats, per segment
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        dof = neff - n
        sigma2 = np.where(dof > 0, wss / np.where(dof > 0, dof, 1.0), np.nan)
        rms = np.sqrt(ss / count)
        noise_var = float(getattr(est, "noise_var", 1.0))
        if res.P is None:  # gradient methods (lms, nlms): no covariance, NaN stderr
            stderr = np.full((G, n), np.nan)
        else:
            diagP = np.clip(np.diagonal(res.P, axis1=1, axis2=2), 0.0, None)
            stderr = np.sqrt(diagP * (sigma2 / noise_var)[:, None])

    pvalue = np.full(G, np.nan)
    if change_test in _PVALUE_TESTS:
        ratio, pvalue, first = _pvalue_tests(Phi, Y, used, offsets, change_test, alpha_a[1])
    else:
        ratio, first = _bde_tests(res, Phi, Y, used, offsets, alpha_a[0], change_test, burn_in)
    return {"sigma2": sigma2, "rms": rms, "stderr": stderr, "ratio": ratio, "first": first,
            "pvalue": pvalue}


def _pvalue_tests(Phi, Y, used, offsets, change_test, alpha):
    """Per group: the statistic, p-value and break sample of one test of
    :func:`adaptid.diagnostics.change_tests` on the group's used samples
    (each test one compiled pass; a loop over groups, not over samples)."""
    from ..diagnostics import change_tests
    G = offsets.shape[0] - 1
    stat, pval = np.full(G, np.nan), np.full(G, np.nan)
    first = np.full(G, -1, dtype=np.int64)
    for g in range(G):
        rows = np.flatnonzero(used[offsets[g]:offsets[g + 1]]) + offsets[g]
        try:
            t = change_tests(Phi[rows], Y[rows], alpha=alpha, tests=(change_test,))[change_test]
        except ValueError:  # too few samples for the test: no verdict
            continue
        stat[g], pval[g] = t.statistic, t.pvalue
        if t.break_index is not None and t.pvalue < alpha:
            first[g] = rows[t.break_index]
    return stat, pval, first


def _bde_tests(res, Phi, Y, used, offsets, alpha_a, change_test, burn_in):
    """Brown–Durbin–Evans CUSUM crossing of every segment (compiled): (ratio, first)."""
    from .._kernels.layers._fleet import cusum_errors_kernel, recursive_residuals_segments
    G = offsets.shape[0] - 1
    n = Phi.shape[1]
    ratio = np.empty(G)
    first = np.empty(G, dtype=np.int64)
    if change_test == "a-priori":
        if burn_in is None:  # 10 % of the used samples, at least 10·n
            burn = np.maximum(10 * n, np.ceil(0.1 * res.n_samples)).astype(np.int64)
        else:
            burn = np.full(G, burn_in, dtype=np.int64)
        cusum_errors_kernel(res.error, used, offsets, burn, alpha_a, ratio, first)
        return ratio, first
    if used.all():
        Pc, Yc, oc, rows = Phi, Y, offsets, None
    else:
        rows = np.flatnonzero(used)
        Pc, Yc = np.ascontiguousarray(Phi[rows]), np.ascontiguousarray(Y[rows])
        oc = np.zeros_like(offsets)
        np.cumsum(res.n_samples, out=oc[1:])
    w = np.empty(Pc.shape[0])
    recursive_residuals_segments(Pc, Yc, oc, w)
    ok = np.isfinite(w)
    cusum_errors_kernel(np.where(ok, w, 0.0), ok, oc, np.zeros(G, dtype=np.int64),
                        alpha_a, ratio, first)
    if rows is not None:
        first = np.where(first >= 0, rows[np.maximum(first, 0)], -1)
    return ratio, first


def _benjamini_hochberg(p, alpha):
    """Rejections of the Benjamini–Hochberg (1995) step-up procedure at FDR α (NaN: none)."""
    p = np.asarray(p, dtype=float)
    ok = np.flatnonzero(np.isfinite(p))
    reject = np.zeros(p.shape, dtype=bool)
    if ok.size:
        order = ok[np.argsort(p[ok], kind="stable")]
        m = ok.size
        below = p[order] <= alpha * np.arange(1, m + 1) / m
        if below.any():
            reject[order[: int(np.flatnonzero(below)[-1]) + 1]] = True
    return reject


def _write_tracks(path, group, uniq, lengths, res, names, pos, row_t, time):
    import pandas as pd
    import pyarrow as pa
    import pyarrow.parquet as pq
    th = res.theta_track
    data = {group: np.repeat(uniq, lengths)}
    if time is not None:
        data[time] = row_t
    data["sample"] = pos
    for j, c in enumerate(names):
        data[c] = th[:, j]
    data["error"] = res.error
    data["skipped"] = res.skipped
    table = pa.Table.from_pandas(pd.DataFrame(data), preserve_index=False)
    pq.write_to_dataset(table, root_path=os.fspath(path), partition_cols=[group],
                        basename_template=f"part-{uuid.uuid4().hex}-{{i}}.parquet")


# ------------------------------------------------------------------ the entry
def _as_frame(data):
    """(kind, frame): a pandas DataFrame, a dask DataFrame, or Parquet read lazily."""
    import pandas as pd
    if isinstance(data, pd.DataFrame):
        return "pandas", data
    if isinstance(data, (str, os.PathLike)) or (
            isinstance(data, (list, tuple)) and data and
            all(isinstance(d, (str, os.PathLike)) for d in data)):
        dd = _need("dask.dataframe")
        paths = os.fspath(data) if isinstance(data, os.PathLike) else data
        return "dask", dd.read_parquet(paths)
    dd = _need("dask.dataframe")
    if isinstance(data, dd.DataFrame):
        return "dask", data
    raise param_error("data", "a pandas or dask DataFrame, or a path or glob to Parquet "
                      "files", f"<{type(data).__name__}>", exc=TypeError)


def _check_column(frame, name, arg, *, allow_index=False):
    if not isinstance(name, str):
        raise param_error(arg, "a column name (str)", name, exc=TypeError)
    if name in frame.columns or (allow_index and frame.index.name == name):
        return
    cols = ", ".join(map(str, list(frame.columns)[:12]))
    raise param_error(arg, f"a column of data (columns: {cols})", name)


def _pandas_partitions(df, group, n_parts):
    """Split a pandas frame into ≤ n_parts row slices, each holding whole groups."""
    import pandas as pd

    from .._kernels.layers._fleet import scan_runs
    gv = _group_values(df, group)
    N = gv.shape[0]
    starts = np.empty(N + 1, dtype=np.int64)
    if gv.dtype.kind in "iuM":  # one compiled pass: sorted labels need no hashing
        m, increasing, _, _ = scan_runs(gv.view(np.int64) if gv.dtype.kind == "M" else gv,
                                        np.empty(1), False, starts)
        starts = starts[:m]
    else:
        increasing = False
    if not increasing:
        codes, _ = pd.factorize(gv, sort=False)
        if N and (np.diff(codes) < 0).any():
            order = np.argsort(codes, kind="stable")
            df = df.iloc[order]
            codes = codes[order]
        starts = np.flatnonzero(np.diff(codes, prepend=-1)) if N else np.empty(0, np.int64)
    starts = np.append(starts, N)
    cuts = np.unique(starts[np.searchsorted(starts, np.linspace(0, N, n_parts + 1)[1:-1])])
    bounds = np.concatenate([[0], cuts[(cuts > 0) & (cuts < N)], [N]]).astype(np.int64)
    return [df.iloc[a:b] for a, b in zip(bounds[:-1], bounds[1:])]


def _default_partitions(client):
    if client is not None:
        try:
            return max(1, 2 * sum(client.nthreads().values()))
        except Exception:  # pragma: no cover
            pass
    return max(1, 2 * (os.cpu_count() or 1))


def _add_order(part, partition_info=None):
    number = 0 if partition_info is None else int(partition_info["number"])
    out = part.copy(deep=False)
    out[_ORDER] = (np.int64(number) << np.int64(40)) + np.arange(len(part), dtype=np.int64)
    return out


def identify(data, *, group, y, phi=None, model=None, method="rls", time=None, client=None,
             tracks=None, nan_policy="raise", alpha=0.05, change_test="supF", multiple="bh",
             burn_in=None, npartitions=None, progress=False, **estimator_options):
    r"""Identify the same linear-in-parameters model on every group (device) of a fleet.

    Each group's rows, in ``time`` order, form one record
    :math:`y_k = \theta^T\varphi_k + e_k` that one recursive estimator
    (``method``, with ``estimator_options``) runs through from its prior;
    all groups run in one compiled, parallel call per Dask partition
    (``run_segments`` of the estimator), and the partitions in one Dask
    computation.

    Parameters
    ----------
    data : pandas.DataFrame, dask.dataframe.DataFrame, str or path-like
        Long-format table (one row per sample and device), or a path / glob /
        list of Parquet files (read with ``dask.dataframe.read_parquet``).
    group : str
        The device-id column (or the index name of a dask frame indexed by
        it with known divisions).
    y : str
        The output column (single output).
    phi : sequence of str, optional
        Regressor columns, in the order of θ. Give ``phi`` or ``model``.
    model : callable, optional
        ``model(group_df) -> adaptid.models.Regression``: builds (Φ, y) from
        one group's rows (sorted by ``time``), e.g. ARX regressors with lags
        (see :mod:`adaptid.models`). It must return the same ``names`` for
        every group; if it has an attribute ``names`` they are used for the
        result columns, otherwise it is evaluated once on the first group of
        the first partition to learn them. ``Regression.index`` maps rows to
        positions in the group's record (used for ``change_at`` and tracks).
        ``y`` is then ignored (pass ``y=None``).
    method : {"rls", "window", "kalman", "lms", "nlms"}
        :class:`~adaptid.RLS` (options ``forgetting``, ``theta0``, ``P0``),
        :class:`~adaptid.SlidingWindowRLS` (``window`` required,
        ``forgetting``, ``theta0``, ``P0``), :class:`~adaptid.KalmanRLS`
        (``process_cov`` required, ``noise_var``, ``theta0``, ``P0``),
        :class:`~adaptid.LMS` (``step`` required, ``theta0``) or
        :class:`~adaptid.NLMS` (``step`` required, ``eps``, ``theta0``).
        The gradient methods keep no covariance: their ``stderr_<name>``
        columns are NaN (σ̂² is computed as for the Kalman filter, every
        used sample with factor 1).
    time : str, optional
        Ordering column: each group is sorted by it (stable: equal times keep
        their stored order). ``None``: rows are taken in their stored order.
    client : None, "local", str or distributed.Client
        ``None``: Dask's synchronous local scheduler in this process (the
        kernel itself runs in parallel over the groups with numba threads).
        A ``distributed.Client`` or a scheduler address (``"tcp://…"``): that
        cluster. ``"local"``: start a ``LocalCluster`` with one
        single-threaded worker process per core, and close it afterwards.
        No cluster is ever started otherwise.
    tracks : str or path-like, optional
        Also write the per-sample estimates (group, time, ``sample``, θ
        columns, a-priori ``error``, ``skipped``) to a Parquet data set at
        this path, partitioned by group (hive layout, pyarrow). On a cluster
        the path must be shared by the workers.
    nan_policy : {"raise", "skip"}
        ``"raise"``: a non-finite regressor or output raises ValueError naming
        the group; ``"skip"``: such samples are skipped.
    alpha : float
        Per-group level of the CUSUM test, in (0, 1). For a family-wise
        level over G devices use ``alpha / G`` (Bonferroni).
    change_test : {"supF", "re", "cusum", "cusum2", "a-priori", "recursive"}
        The per-device test of constant parameters (see Notes). Default
        ``"supF"``: it sees a change of any coefficient and dates it.
    multiple : {"bh", "bonferroni", "none"}
        Control across the devices for the tests with a p-value:
        Benjamini–Hochberg at false discovery rate ``alpha`` (default),
        Bonferroni (family-wise level ``alpha``: each device at α/G), or
        none (each device at α).
    burn_in : int, optional
        Used samples dropped at the start of each group before the
        ``"a-priori"`` CUSUM; default max(10·n, ⌈0.1·n_samples⌉) of that
        group.
    npartitions : int, optional
        Number of partitions of a pandas input (default: twice the number
        of cores or worker threads) or, for a dask input that needs a
        shuffle, of the shuffled frame (default: unchanged).
    progress : bool
        Show Dask's progress bar (``dask.diagnostics.ProgressBar`` locally,
        ``distributed.progress`` on a cluster).
    **estimator_options
        Passed to the estimator (see ``method``); ``forgetting`` may be a
        float or a strategy of :mod:`adaptid.forgetting`.

    Returns
    -------
    pandas.DataFrame
        One row per group, indexed by group (sorted): the θ columns (named
        from ``phi`` or the model's names), ``stderr_<name>``, ``n_samples``
        (used), ``n_skipped``, ``sigma2``, ``rms``, ``change`` (bool),
        ``change_stat`` and ``change_at`` (see Notes).

    Raises
    ------
    ValueError
        A missing column (names the argument and the column), a group
        shorter than n (names the group), a non-finite value with
        ``nan_policy="raise"`` (names the group), bad options.
    TypeError
        Wrong types, or an option that ``method`` does not take.

    Notes
    -----
    **Standard errors.** The rule of :func:`adaptid.recursive_fit_stats`,
    per group: with :math:`\hat\theta_N` the final estimate, :math:`r_k =
    y_k - \varphi_k^T\hat\theta_N` and :math:`c_k` the factor with which
    sample k enters the estimator's cost (:math:`\lambda^{m_k}`, m_k the
    number of used samples after k, for ``"rls"`` and ``"window"`` —
    the latter only over its last ``window`` used samples, 0 before —
    and 1 for ``"kalman"``),

    .. math::

        \hat\sigma^2 = \frac{\sum_k c_k r_k^2}{\sum_k c_k - n},
        \qquad \operatorname{stderr}_i = \sqrt{\hat\sigma^2 P_{ii}/R_2},

    ``sigma2`` is :math:`\hat\sigma^2` (NaN when :math:`\sum_k c_k \le n`)
    and ``rms`` :math:`\sqrt{\sum_S r_k^2/m}` over the m samples S with
    :math:`c_k > 0`. :math:`R_2` is ``noise_var`` for ``"kalman"`` and 1
    otherwise; with λ = 1 and a diffuse prior these are the ordinary
    least-squares standard errors of :func:`adaptid.lstsq`. A forgetting
    strategy's λₖ are not available per segment: its factors are taken
    as 1.

    **Change flag, tests with a p-value** (``change_test`` = ``"supF"``,
    ``"re"``, ``"cusum"``, ``"cusum2"``): each device's test of
    :func:`adaptid.diagnostics.change_tests` on its used samples (the
    ordinary least-squares regression of the group, whatever ``method``):
    Andrews' supF with Hansen's p-value, the fluctuation of recursive
    estimates, the recursive CUSUM (strucchange's scale and p-value) or the
    CUSUM of squares. ``change_stat`` is the statistic, ``change_pvalue``
    its p-value, ``change`` the verdict after the control across devices
    (``multiple``), and ``change_at`` the break date for a flagged device
    (supF: the last sample before the break that maximises F; RE: the peak
    of the process), as ``time`` or the 0-based position. The recursive
    CUSUM has no power against a change of the coefficient of a zero-mean
    regressor (its residuals keep mean zero): supF, RE have.

    **Change flag, BDE crossing** (``"a-priori"``, ``"recursive"``; no
    p-value, so no control across devices): the CUSUM test of Brown, Durbin & Evans (1975, §2.3),
    :func:`adaptid.diagnostics.cusum` with ``scale="ols"``: on m residuals
    :math:`e_j`,
    :math:`W_j = \sum_{i\le j} e_i/\hat\sigma`,
    :math:`\hat\sigma^2 = \sum_j e_j^2/m`, and ``change`` is True when
    :math:`|W_j| > a\sqrt m + 2a\,j/\sqrt m` for some j, *a* solving BDE's
    crossing equation at level ``alpha`` (0.948 for 0.05). ``change_stat``
    is :math:`\max_j |W_j|/(a\sqrt m + 2aj/\sqrt m)` (> 1 means a change)
    and ``change_at`` the ``time`` (or the 0-based position in the group
    when ``time`` is None) of the first crossing, NaN if none.

    * ``change_test="a-priori"`` (fast): :math:`e_j` are the
      estimator's own a-priori errors :math:`\varepsilon_k = y_k -
      \varphi_k^T\hat\theta_{k-1}` after the first ``burn_in`` used samples.
      For RLS with λ = 1 and a diffuse prior,
      :math:`\varepsilon_k = w_k\sqrt{1 + \varphi_k^T P_{k-1}\varphi_k}` where
      :math:`w_k` are BDE's recursive residuals and
      :math:`\varphi_k^TP_{k-1}\varphi_k = O(n/k)`; dropping the start makes
      the two tests agree up to that factor, at no extra pass over the data.
      With forgetting, a window or a random walk the estimator tracks a
      change, so the errors drift only for a while: the test is then less
      powerful.
    * ``change_test="recursive"`` (exact, about three times the cost of the
      RLS run): :math:`e_j` are the recursive residuals of the group's
      ordinary least-squares regression (same compiled step as
      :func:`adaptid.diagnostics.recursive_residuals`), whatever ``method``.

    Under constant parameters each group is flagged with probability about
    α, so a fleet of G healthy devices has about αG false alarms: use
    ``alpha / G`` to bound the chance of any. Measured on 2000 healthy
    devices of :func:`adaptid.datasets.fleet` at α = 0.05: ``"recursive"``
    4.5 %; ``"a-priori"`` 5.1 % with N = 1000 samples per device, 8 % with
    N = 300 (the start-up transient weighs more in short records: raise
    ``burn_in`` or use ``"recursive"`` there).

    **Computation.** A pandas frame is cut into partitions at group
    boundaries (groups made contiguous by a stable sort if they are not);
    a dask frame (or Parquet) gets a column of stored order and is shuffled
    on ``group`` so that every group lies in one partition (skipped when it
    is indexed by ``group`` with known divisions). ``map_partitions`` then
    sorts each partition stably by (group, time, stored order), builds the
    segment offsets and calls the estimator's ``run_segments`` once.

    References
    ----------
    .. [1] R. L. Brown, J. Durbin, J. M. Evans, "Techniques for testing the
       constancy of regression relationships over time", J. R. Statist.
       Soc. B 37(2):149–192, 1975.

    Examples
    --------
    >>> from adaptid import fleet
    >>> from adaptid.datasets import fleet as make_fleet
    >>> df = make_fleet(n_devices=20, n_samples=400, seed=0)
    >>> res = fleet.identify(df, group="device", time="time", y="v",
    ...                      phi=["i", "di_dt", "omega", "sign_i"])
    >>> res.shape[0]
    20
    """
    _need("dask")
    method = check_choice(method, "method", METHODS)
    check_choice(nan_policy, "nan_policy", ("raise", "skip"))
    change_test = check_choice(change_test, "change_test", _CHANGE_TESTS)
    multiple = check_choice(multiple, "multiple", _MULTIPLE)
    alpha = check_scalar(alpha, "alpha", low=0.0, high=1.0, low_open=True, high_open=True)
    kind, frame = _as_frame(data)
    phi, names = _check_columns(frame, kind, group=group, y=y, phi=phi, model=model, time=time)
    if npartitions is not None:
        npartitions = check_int(npartitions, "npartitions", low=1)
    if burn_in is not None:
        burn_in = check_int(burn_in, "burn_in", low=0)
    client, own_cluster = _open_client(client)
    try:
        ddf, sample, order_col = _partitioned(kind, frame, group=group, y=y, phi=phi,
                                              model=model, time=time, client=client,
                                              npartitions=npartitions)
        if names is None:
            names = _model_names(ddf, sample, model, group, time)
        bad = [c for c in names if c in _STAT_COLUMNS or c.startswith("stderr_")]
        if bad:
            raise param_error("phi", "names that do not collide with the result columns "
                              f"{_STAT_COLUMNS}", bad[0])
        est = _make_estimator(method, len(names), nan_policy, estimator_options)
        if tracks is not None:
            os.makedirs(os.fspath(tracks), exist_ok=True)
        kwargs = dict(group=group, y=y, phi=phi, model=model, time=time, est=est,
                      names=names, alpha_a=(_bde_a(alpha), alpha), change_test=change_test,
                      burn_in=burn_in, tracks=tracks, order_col=order_col)
        result = ddf.map_partitions(_identify_partition, enforce_metadata=False,
                                    meta=_result_meta(names, group, frame, kind), **kwargs)
        out = _compute(result, client, progress)
    finally:
        _close_client(client, own_cluster)
    try:
        out = out.sort_index(kind="stable")
    except TypeError:  # pragma: no cover - unorderable group labels
        pass
    out.index.name = group
    if change_test in _PVALUE_TESTS:
        _fleet_verdict(out, alpha, multiple)
    return out


def _fleet_verdict(out, alpha, multiple):
    """``change`` from the p-values of every device, with multiple-testing control;
    ``change_at`` kept only for the devices flagged."""
    p = out["change_pvalue"].to_numpy(dtype=float)
    if multiple == "bh":
        flag = _benjamini_hochberg(p, alpha)
    else:
        level = alpha / max(int(np.isfinite(p).sum()), 1) if multiple == "bonferroni" else alpha
        flag = np.isfinite(p) & (p <= level)
    out["change"] = flag
    out.loc[~flag, "change_at"] = np.nan


# ---------------------------------------------------------------- the steps
def _check_columns(frame, kind, *, group, y, phi, model, time):
    """Validate the column arguments; returns (phi as a list or None, names or None)."""
    if (phi is None) == (model is None):
        raise param_error("phi", "given, or model given (exactly one of them)",
                          "<both>" if phi is not None else "<neither>", exc=TypeError)
    _check_column(frame, group, "group", allow_index=kind == "dask")
    if time is not None:
        _check_column(frame, time, "time")
    if model is not None:
        if not callable(model):
            raise param_error("model", "a callable group_df -> Regression", model,
                              exc=TypeError)
        names = getattr(model, "names", None)
        return None, (tuple(names) if names is not None else None)
    _check_column(frame, y, "y")
    phi = [phi] if isinstance(phi, str) else list(phi)
    if not phi:
        raise param_error("phi", "a non-empty list of column names", phi)
    for c in phi:
        _check_column(frame, c, "phi")
    return phi, tuple(phi)


def _open_client(client):
    """(client, what to close afterwards): None, "local", an address or a Client."""
    if isinstance(client, str):
        distributed = _need("distributed")
        if client == "local":
            ncores = os.cpu_count() or 1
            cluster = distributed.LocalCluster(n_workers=ncores, threads_per_worker=1,
                                               processes=True)
            return distributed.Client(cluster), cluster
        client = distributed.Client(client)
        return client, client  # a connection we opened: close it afterwards
    if client is not None and not hasattr(client, "compute"):
        raise param_error("client", "None, 'local', a scheduler address or a "
                          "distributed.Client", client, exc=TypeError)
    return client, None


def _close_client(client, own):
    if own is not None:
        own.close()
        if client is not own:
            client.close()


def _partitioned(kind, frame, *, group, y, phi, model, time, client, npartitions):
    """(dask frame whose partitions hold whole groups, a pandas sample or None, order column)."""
    dask = _need("dask")
    dd = _need("dask.dataframe")
    keep = None if model is not None else list(dict.fromkeys(
        c for c in [group, time, y] + list(phi) if c is not None))
    if kind == "pandas":
        frame = frame.copy(deep=False)
        frame.attrs = {}  # pandas deep-copies attrs on every slice: not needed here
        if keep is not None:
            frame = frame[keep]
        parts = _pandas_partitions(frame, group, npartitions or _default_partitions(client))
        ddf = dd.from_delayed([dask.delayed(p, pure=False) for p in parts],
                              meta=frame.iloc[:0], verify_meta=False)
        return ddf, (parts[0] if parts else frame.iloc[:0]), None
    ddf = frame
    if keep is not None:
        ddf = ddf[[c for c in keep if c in ddf.columns]]
    if group not in ddf.columns and ddf.index.name == group and ddf.known_divisions:
        return ddf, None, None  # indexed by group with known divisions: no shuffle
    if group not in ddf.columns:
        ddf = ddf.reset_index()
    ddf = ddf.map_partitions(_add_order, meta=ddf._meta.assign(**{_ORDER: np.int64(0)}))
    # in-process: a task shuffle (p2p needs the distributed scheduler)
    how = {} if client is not None else {"shuffle_method": "tasks"}
    ddf = ddf.shuffle(on=group, npartitions=npartitions or ddf.npartitions, **how)
    return ddf, None, _ORDER


def _model_names(ddf, sample, model, group, time):
    """Learn the model's regressor names on the first group of the first partition."""
    probe = sample if sample is not None else ddf.partitions[0].compute()
    if len(probe) == 0:
        raise param_error("data", "non-empty", "<no rows>")
    gv = _group_values(probe, group)
    first = probe[gv == gv[0]]
    if time is not None:
        first = first.sort_values(time, kind="stable")
    return tuple(model(first).names)


def _result_meta(names, group, frame, kind):
    import pandas as pd
    cols = {c: pd.Series(dtype="float64") for c in names}
    cols.update({f"stderr_{c}": pd.Series(dtype="float64") for c in names})
    cols.update(n_samples=pd.Series(dtype="int64"), n_skipped=pd.Series(dtype="int64"),
                sigma2=pd.Series(dtype="float64"), rms=pd.Series(dtype="float64"),
                change=pd.Series(dtype="bool"), change_stat=pd.Series(dtype="float64"),
                change_pvalue=pd.Series(dtype="float64"), change_at=pd.Series(dtype="float64"))
    if group in frame.columns:
        idx_dtype = frame[group].dtype if kind == "pandas" else frame._meta[group].dtype
    else:
        idx_dtype = frame._meta.index.dtype
    return pd.DataFrame(cols, index=pd.Index([], dtype=idx_dtype, name=group))


def _compute(result, client, progress):
    if client is None:
        if progress:
            from dask.diagnostics import ProgressBar
            with ProgressBar():
                return result.compute(scheduler="synchronous")
        return result.compute(scheduler="synchronous")
    fut = client.compute(result)
    if progress:
        from distributed import progress as dprogress
        dprogress(fut)
    return fut.result()
