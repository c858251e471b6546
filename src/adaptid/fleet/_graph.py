r"""The Dask side of the fleet: client, partitions holding whole groups, compute.

A pandas frame is cut at group boundaries into delayed partitions; a dask
frame gets a column of stored order and is shuffled on the group column
(unless indexed by it with known divisions). The result's metadata, the
model's names learnt on one group, and the computation (in-process or on a
cluster, with a progress bar if asked).
"""

from __future__ import annotations

import os

import numpy as np

from .._validation import param_error
from ._inputs import _group_values, _need

_ORDER = "__adaptid_order__"


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


def _pandas_partitions(df, group, n_parts):
    """Split a pandas frame into ≤ n_parts row slices, each holding whole groups."""
    import pandas as pd

    from .._kernels.layers._fleet import scan_runs
    from .._kernels.recursions._parallel import parallel_guard
    gv = _group_values(df, group)
    N = gv.shape[0]
    starts = np.empty(N + 1, dtype=np.int64)
    if gv.dtype.kind in "iuM":  # one compiled pass: sorted labels need no hashing
        with parallel_guard():  # a parallel kernel (the workqueue layer: one at a time)
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

