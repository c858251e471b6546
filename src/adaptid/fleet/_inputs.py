r"""The fleet's input: the table, its column arguments and the columns as arrays.

Validation of ``data``, ``group``, ``y``, ``phi``, ``model`` and ``time``
(:func:`adaptid.fleet.identify`), and the readers of one partition's columns:
numbers as float64, the time as a sortable key, group labels for messages.
"""

from __future__ import annotations

import glob
import os

import numpy as np

from .._validation import param_error


def _need(module):
    import importlib
    try:
        return importlib.import_module(module)
    except ImportError as err:  # pragma: no cover - depends on the install
        raise ImportError(f"adaptid.fleet needs {module.split('.')[0]}: "
                          "pip install 'adaptid[dask]'") from err


def _data_paths(data):
    """The paths of ``data`` (a path, glob or list of them) as strings, or None."""
    if isinstance(data, (str, os.PathLike)):
        return [os.fspath(data)]
    if isinstance(data, (list, tuple)) and data and \
            all(isinstance(d, (str, os.PathLike)) for d in data):
        return [os.fspath(d) for d in data]
    return None


def _as_frame(data):
    """(kind, frame): a pandas DataFrame, a dask DataFrame, or Parquet read lazily."""
    import pandas as pd
    if isinstance(data, pd.DataFrame):
        return "pandas", data
    paths = _data_paths(data)
    if paths is not None:
        for p in paths:  # else dask reads an empty frame: "group must be a column (columns: )"
            if glob.has_magic(p) and not glob.glob(p, recursive=True):
                raise param_error("data", "a path or glob that names Parquet files",
                                  f"<no files match {p!r}>")
        dd = _need("dask.dataframe")
        return "dask", dd.read_parquet(paths[0] if isinstance(data, (str, os.PathLike))
                                       else paths)
    dd = _need("dask.dataframe")
    if isinstance(data, dd.DataFrame):
        return "dask", data
    raise param_error("data", "a pandas or dask DataFrame, or a path or glob to Parquet "
                      "files", f"<{type(data).__name__}>", exc=TypeError)


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


def _check_column(frame, name, arg, *, allow_index=False):
    if not isinstance(name, str):
        raise param_error(arg, "a column name (str)", name, exc=TypeError)
    if name in frame.columns or (allow_index and frame.index.name == name):
        return
    cols = ", ".join(map(str, list(frame.columns)[:12]))
    raise param_error(arg, f"a column of data (columns: {cols})", name)


def _check_tracks(data, tracks):
    """``tracks`` must not lie inside a folder of the input (nor be it): the next run
    over that folder would read the per-sample tracks as data. For a glob, its
    fixed leading folder counts when the pattern is recursive (``**``)."""
    paths = _data_paths(data)
    if tracks is None or paths is None:
        return
    t = os.path.realpath(os.fspath(tracks))
    for p in paths:
        if glob.has_magic(p):
            if "**" not in p:
                continue
            p = p[:min(p.index(c) for c in "*?[" if c in p)]
            p = p if p.endswith(os.sep) else os.path.dirname(p)
            p = p or os.curdir
        if not os.path.isdir(p):
            continue
        root = os.path.realpath(p)
        if os.path.commonpath([root, t]) == root:
            raise param_error("tracks", "a folder outside the input data (the next run "
                              "over the input would read the tracks as data)",
                              f"<{os.fspath(tracks)!r} inside the input folder {p!r}>")


def _check_label_texts(labels, where=""):
    """Distinct group labels must have distinct texts: ``1`` and ``"1"`` would share
    one tracks partition (``device=1``) and one name in a CSV of the results."""
    if getattr(labels, "dtype", None) is not None and labels.dtype.kind != "O":
        return  # one type: distinct values print differently
    seen = {}
    for v in labels:
        key = str(v.item() if isinstance(v, np.generic) else v)
        other = seen.setdefault(key, v)
        if other is not v:
            raise param_error("group", "labels whose texts differ (they name the tracks "
                              "partitions and the result rows)",
                              f"<{_label(other)} and {_label(v)}{where}>")


def _group_values(part, group):
    return part[group].to_numpy() if group in part.columns else part.index.to_numpy()


def _label(value) -> str:
    """A group label for messages: 13, 'pump-7' (numpy scalars shown as Python ones)."""
    return repr(value.item() if isinstance(value, np.generic) else value)


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

