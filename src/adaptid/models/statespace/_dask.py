r"""n4sid on Dask: the R factor of the block-Hankel data matrix by a tall-skinny QR.

Records larger than memory come as Dask arrays (or Dask DataFrames): one
experiment or a list of them. One pass over the chunks finds the rows with
a NaN, which split a record into runs of complete samples (slices of the
Dask arrays, each an experiment, as in memory). The transposed data matrix
Hᵀ (one row per Hankel column) is formed chunk by chunk inside each
experiment: the Hankel rows q = s … e − 1 of a chunk need the samples
s … e + 2i − 2, i.e. the chunk and the first 2i − 1 samples after it (the
overlap). Dask's tall-skinny QR (``dask.array.linalg.tsqr``, as
:func:`adaptid.fleet.lstsq` uses) reduces the stacked blocks of all
experiments to the R factor of the stacked Hᵀ without forming Q, with one
block of Hᵀ per task in memory. dt comes from a Dask frame's time index,
read by Dask reductions. The rest of :func:`~adaptid.models.n4sid` (B, D,
x0, K, an order range's AIC, the covariance) reads the record chunk by
chunk in order (:mod:`._passes`).
"""

from __future__ import annotations

import numpy as np

from ..._validation import param_error
from ._signals import Experiments

__all__ = ["is_dask", "dask_experiments", "dask_sample_time", "lq_factor_dask"]


def is_dask(data) -> bool:
    """Whether ``data`` (or an item of a (y, u) pair or of a list) is a Dask collection."""
    if isinstance(data, (tuple, list)):
        return any(is_dask(d) for d in data)
    return type(data).__module__.split(".")[0] == "dask"


def _dask():
    try:
        import dask
        import dask.array as da
    except ImportError as err:  # pragma: no cover - depends on the extra
        raise ImportError("n4sid on Dask data needs dask: pip install 'adaptid[dask]'") from err
    return dask, da


def _as_columns(x, name, prefix, da):
    """A Dask (N, k) float64 array and the column names of a Dask array/Series/DataFrame."""
    names = None
    if hasattr(x, "to_dask_array"):
        cols = getattr(x, "columns", None)
        names = (tuple(str(c) for c in cols) if cols is not None
                 else (str(x.name),) if getattr(x, "name", None) is not None else None)
        x = x.to_dask_array(lengths=True)
    elif not isinstance(x, da.Array):
        x = da.from_array(np.asarray(x, dtype=np.float64))
    if x.ndim not in (1, 2) or any(np.isnan(c) for c in x.chunks[0]):
        raise param_error(name, "a Dask array of shape (N,) or (N, k) with known chunk sizes",
                          f"<shape {x.shape}>")
    X = x.reshape(x.shape[0], -1).astype(np.float64).rechunk({1: -1})
    k = X.shape[1]
    if names is None:
        names = (prefix,) if k == 1 else tuple(f"{prefix}{j + 1}" for j in range(k))
    return X, names


def _time_axis(x, da):
    """(elapsed seconds, the index's own step or None, the stamps as numbers or None for
    datetimes) of the index of a Dask Series / DataFrame when it is a time axis (as
    :class:`IDData` reads a pandas index), else None; the arrays are Dask arrays."""
    from .._iddata import _index_of

    meta = getattr(x, "_meta", None)
    if meta is None or not hasattr(x, "index"):
        return None
    values, freq = _index_of(meta)
    if values is None or freq == "rows":
        return None
    idx = x.index
    if getattr(meta.index, "tz", None) is not None:        # aware stamps: compare them in UTC
        idx = idx.map_partitions(lambda i: i.tz_convert("UTC").tz_localize(None))
    t = idx.to_dask_array(lengths=True)
    t0 = t[:1].compute()[0] if t.shape[0] else None
    if t0 is None:
        return None
    if values.dtype.kind in "Mm":           # as IDData: whole nanoseconds since the first stamp
        el = t.map_blocks(lambda b: (b - t0).astype("timedelta64[ns]").astype(np.int64) * 1e-9,
                          dtype=np.float64)
        return el, freq, None
    t = t.astype(np.float64)
    return t - float(t0), freq, t


def dask_sample_time(x, source):
    r"""dt of a Dask Series / DataFrame with a time index, read chunk by chunk, or None.

    The rule of :class:`~adaptid.IDData` for a pandas index (a regular axis:
    every stamp within 1e-4 of a step of :math:`t_0 + k\,\Delta t`, Δt the
    index's own frequency or the mean step), from Dask reductions over the
    index (its stamps are never all in memory). An irregular axis is refused:
    there is no ``dt`` argument to give its nominal step.
    """
    from .._iddata import _GRID_RTOL, _where

    dask, da = _dask()
    got = _time_axis(x, da)
    if got is None:
        return None
    el, freq, raw = got
    N = el.shape[0]
    if N < 2:
        return freq
    steps = da.diff(el)
    rising, last, span = dask.compute((steps > 0).all(), el[-1],
                                      0.0 if raw is None else abs(raw).max())
    where = _where(source)
    if not rising:
        k = int(da.argmax(~(steps > 0)).compute()) + 1
        raise param_error(where, "strictly increasing", f"<a step <= 0 at sample {k}>")
    step = freq if freq is not None else float(last) / (N - 1)
    off = float(da.max(abs(el - step * da.arange(N, chunks=el.chunks))).compute())
    if off > _GRID_RTOL * step + 8 * np.finfo(float).eps * float(span):
        lo, hi = dask.compute(steps.min(), steps.max())
        raise ValueError(f"{where} must be a regular time axis for Dask data (its steps go "
                         f"from {float(lo):.9g} to {float(hi):.9g} s; in memory IDData takes "
                         "the nominal dt of an irregular axis); resample it, or pass it "
                         "without its index (dt = 1)")
    return step


def _dask_pair(item, name, da):
    """(Y, U, y names, u names, dt or None) of one experiment given as Dask data."""
    from .._iddata import IDData

    if isinstance(item, IDData):              # in memory: its arrays as one-chunk Dask arrays
        return (da.from_array(item.outputs), da.from_array(item.inputs), item.y_names,
                item.u_names, item.dt)
    if isinstance(item, tuple):
        if len(item) != 2:
            raise param_error(name, "a (y, u) pair", f"<a tuple of {len(item)} items>",
                              exc=TypeError)
        y, u = item
    elif hasattr(item, "columns") and len(item.columns) >= 2:
        y, u = item[[item.columns[0]]], item[list(item.columns[1:])]
    else:
        raise param_error(name, "a (y, u) pair of Dask arrays or a Dask DataFrame (output "
                          "column first, the inputs after it)", item, exc=TypeError)
    Y, yn = _as_columns(y, f"{name} y", "y", da)
    U, un = _as_columns(u, f"{name} u", "u", da)
    if U.shape[0] != Y.shape[0]:
        raise param_error(f"{name} u", f"with N={Y.shape[0]} rows (as y)", f"<{U.shape[0]} rows>")
    dt = dask_sample_time(y, "y")
    if dt is None:
        dt = dask_sample_time(u, "u")
    return Y, U.rechunk({0: Y.chunks[0]}), yn, un, dt


def _runs(nan_rows, N):
    """(start, stop) of the runs of complete samples of a record of N samples."""
    stops = np.append(nan_rows, N)
    starts = np.insert(nan_rows + 1, 0, 0)
    return [(int(a), int(b)) for a, b in zip(starts, stops) if b > a]


def dask_experiments(data, name="data") -> Experiments:
    """Dask data as :class:`Experiments` of Dask arrays, split at their NaN gaps.

    ``data`` is one experiment — a (y, u) pair of Dask arrays / Series /
    DataFrames, or one Dask DataFrame whose first column is the output and
    the others the inputs — or a list of them (IDData items are taken as
    they are). The rows with a NaN are found by one pass over the chunks;
    the runs between them are slices of the Dask arrays (``cut`` marks them,
    as :func:`._signals.experiments` does in memory).
    """
    dask, da = _dask()
    items = list(data) if isinstance(data, list) else [data]
    if not items:
        raise param_error(name, "a non-empty list of experiments", "<an empty list>")
    from .._iddata import IDData

    items = [e for it in items for e in (it.experiments if isinstance(it, IDData) else [it])]
    parts = [_dask_pair(it, name if len(items) == 1 else f"{name}[{k}]", da)
             for k, it in enumerate(items)]
    p, m = parts[0][0].shape[1], parts[0][1].shape[1]
    for k, (Y, U, _, _, _) in enumerate(parts):
        if (Y.shape[1], U.shape[1]) != (p, m):
            raise param_error(f"{name}[{k}]", f"{p} output(s) and {m} input(s) as the first",
                              f"<{Y.shape[1]} outputs, {U.shape[1]} inputs>")
    if m == 0:
        raise param_error(name, "a record with at least one input", "<no inputs>")
    walls = [da.concatenate([Y, U], axis=1) for Y, U, _, _, _ in parts]
    found = dask.compute([(da.flatnonzero(da.isnan(W).any(axis=1)), da.isinf(W).any())
                          for W in walls])[0]
    Ys, Us, cut = [], [], []
    for k, ((Y, U, _, _, _), (nan_rows, inf)) in enumerate(zip(parts, found)):
        where = name if len(items) == 1 else f"{name}[{k}]"
        if inf:
            raise param_error(where, "finite or NaN (a gap)", "<infinite samples>")
        runs = _runs(np.asarray(nan_rows, dtype=np.int64), Y.shape[0])
        if not runs:
            raise param_error(where, "a record with complete samples", "<only NaN>")
        Ys += [Y[a:b] for a, b in runs]
        Us += [U[a:b] for a, b in runs]
        cut += [len(runs) > 1 or b - a < Y.shape[0] for a, b in runs]
    dt = next((d for _, _, _, _, d in parts if d is not None), 1.0)
    return Experiments(tuple(Ys), tuple(Us), float(dt), tuple(parts[0][2]), tuple(parts[0][3]),
                       tuple(cut))


def _hankel_block(hankel_chunk, m, i, exts, rows):
    """Rows of Hᵀ = [U_f | U_p | Y_p | Y_f], the pieces' rows stacked, from samples
    ``exts[k]`` = [U Y] (each piece inside one experiment)."""
    p = exts[0].shape[1] - m
    out = np.empty((sum(rows), 2 * i * (m + p)))
    q = 0
    for ext, r in zip(exts, rows):
        hankel_chunk(np.ascontiguousarray(ext[:, m:]), np.ascontiguousarray(ext[:, :m]), i, 0,
                     r, out[q:q + r])
        q += r
    return out


def _row_ranges(chunks, J, width):
    """Hankel-row ranges [s, e) following the record's chunks, none shorter than ``width``
    (unless the record has fewer rows)."""
    bounds = np.concatenate([[0], np.cumsum(chunks)]).astype(np.int64)
    ranges = []
    for s, e in zip(bounds[:-1], bounds[1:]):
        e = min(int(e), J)
        if e <= s:
            break
        if ranges and (ranges[-1][1] - ranges[-1][0] < width):
            ranges[-1][1] = e
        else:
            ranges.append([int(s), e])
    if len(ranges) > 1 and ranges[-1][1] - ranges[-1][0] < width:
        last = ranges.pop()
        ranges[-1][1] = last[1]
    return ranges


def _groups(pieces, width):
    """The pieces (ext, rows) in consecutive groups of at least ``width`` rows (the last
    group joins the one before it when it is shorter), one TSQR block each."""
    groups, cur = [], []
    for piece in pieces:
        cur.append(piece)
        if sum(r for _, r in cur) >= width:
            groups.append(cur)
            cur = []
    if cur:
        if groups:
            groups[-1] += cur
        else:
            groups.append(cur)
    return groups


def lq_factor_dask(ex, i, hankel_chunk):
    r"""L = Rᵀ/√j of the block-Hankel data matrix of Dask experiments, by one TSQR.

    The rows of Hᵀ of each experiment are formed inside it (chunk by chunk,
    each chunk with the first 2i − 1 samples after it), the experiments'
    rows stacked as in memory: the R factor of the stacked matrix is the
    TSQR of the stacked blocks, whose rows may come from several short
    experiments (a block has at least as many rows as Hᵀ has columns).
    ``hankel_chunk(Y, U, i, q0, rows, out)`` writes rows of Hᵀ (the in-memory
    builder of :mod:`._subspace`, so that both paths form the same rows).

    Equal to ``_lq_factor`` of the same records in memory up to the signs of
    the rows of R (which the projections of :func:`n4sid` do not see) and
    rounding.
    """
    dask, da = _dask()
    m, p = ex.m, ex.p
    c = 2 * i * (m + p)
    width = max(c, 1024)
    pieces, j_total = [], 0
    for Y, U in zip(ex.Y, ex.U):
        J = Y.shape[0] - 2 * i + 1
        W = da.concatenate([U, Y], axis=1).rechunk({1: -1})
        for s, e in _row_ranges(W.chunks[0], J, width):
            pieces.append((W[s: e + 2 * i - 1], e - s))    # the rows and 2i − 1 samples more
        j_total += J
    blocks = []
    for group in _groups(pieces, width):
        rows = [r for _, r in group]
        blocks.append(da.from_delayed(
            dask.delayed(_hankel_block)(hankel_chunk, m, i, [x for x, _ in group], rows),
            shape=(sum(rows), c), dtype=np.float64))
    _, R = da.linalg.tsqr(da.concatenate(blocks, axis=0))
    return np.asarray(R.compute()).T / np.sqrt(j_total), j_total
