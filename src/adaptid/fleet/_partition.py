r"""One Dask partition's work: its groups run, one result row per group, tracks.

:func:`_identify_partition` is the function ``map_partitions`` ships to the
workers: it orders the rows (:mod:`._layout`), runs the estimator's
``run_segments`` once, computes the statistics (:mod:`._changes`), assembles
the per-group table and writes the per-sample tracks (Parquet) if asked.
"""

from __future__ import annotations

import os
import threading
import uuid

import numpy as np

from .._kernels.recursions._parallel import parallel_guard
from ._changes import _statistics
from ._inputs import _check_label_texts, _time_key
from ._layout import _check_lengths, _layout, _raise_nonfinite, _regression_rows

_KERNEL_LOCK = threading.Lock()


def _identify_partition(part, *, group, y, phi, model, time, est, names, alpha_a,
                        change_test, burn_in, tracks, order_col):
    """One partition: order the rows, build (Φ, y), run the segments, one row per group."""
    t_key, t_missing = _time_key(part, time, group, est.nan_policy)
    if t_missing is not None and model is not None:  # the model sees only timed rows
        part, t_key, t_missing = part[~t_missing], t_key[~t_missing], None
    with parallel_guard():  # parallel kernels: under the workqueue layer one at a time
        idx, offsets, uniq, t = _layout(part, group, t_key, order_col)
        _check_label_texts(uniq)  # before any tracks are written
        Phi, Y, pos, row_t, offsets = _regression_rows(part, idx, offsets, uniq, t, t_missing,
                                                       y=y, phi=phi, model=model, names=names)
    _check_lengths(offsets, uniq, len(names))
    _limit_threads()
    with _KERNEL_LOCK, parallel_guard():
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

