r"""n4sid on Dask: the R factor of the block-Hankel data matrix by a tall-skinny QR.

A record larger than memory comes as Dask arrays (or a Dask DataFrame).
The transposed data matrix Hᵀ (one row per Hankel column) is formed chunk
by chunk of the record: the Hankel rows q = s … e − 1 of a chunk need the
samples s … e + 2i − 2, i.e. the chunk and the first 2i − 1 samples of the
next one (the overlap). Dask's tall-skinny QR (``dask.array.linalg.tsqr``,
as :func:`adaptid.fleet.lstsq` uses) reduces the blocks of Hᵀ to its R
factor without forming Q, with one block of Hᵀ per task in memory. The rest
of :func:`~adaptid.models.n4sid` (B, D, x0 and K) reads the record chunk by
chunk in order.
"""

from __future__ import annotations

import numpy as np

from ..._validation import param_error
from ._signals import Experiments

__all__ = ["is_dask", "dask_experiments", "lq_factor_dask"]


def is_dask(data) -> bool:
    """Whether ``data`` (or one item of a (y, u) pair) is a Dask collection."""
    items = data if isinstance(data, tuple) else (data,)
    return any(type(d).__module__.split(".")[0] == "dask" for d in items)


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


def dask_experiments(data, name="data") -> Experiments:
    """A (y, u) pair of Dask arrays / Series / DataFrames, or one Dask DataFrame whose first
    column is the output and the others the inputs, as one experiment of Dask arrays."""
    _, da = _dask()
    if isinstance(data, tuple):
        if len(data) != 2:
            raise param_error(name, "a (y, u) pair", f"<a tuple of {len(data)} items>",
                              exc=TypeError)
        y, u = data
    elif hasattr(data, "columns") and len(data.columns) >= 2:
        y, u = data[[data.columns[0]]], data[list(data.columns[1:])]
    else:
        raise param_error(name, "a (y, u) pair of Dask arrays or a Dask DataFrame (output "
                          "column first, the inputs after it)", data, exc=TypeError)
    Y, yn = _as_columns(y, f"{name} y", "y", da)
    U, un = _as_columns(u, f"{name} u", "u", da)
    if U.shape[0] != Y.shape[0]:
        raise param_error(f"{name} u", f"with N={Y.shape[0]} rows (as y)", f"<{U.shape[0]} rows>")
    if U.shape[1] == 0:
        raise param_error(name, "a record with at least one input", "<no inputs>")
    U = U.rechunk({0: Y.chunks[0]})
    return Experiments((Y,), (U,), 1.0, yn, un, (False,))


def _hankel_block(hankel_chunk, ext, i, m, rows):
    """Rows 0 … rows−1 of Hᵀ = [U_f | U_p | Y_p | Y_f] from samples ``ext`` = [U Y]."""
    p = ext.shape[1] - m
    out = np.empty((rows, 2 * i * (m + p)))
    hankel_chunk(np.ascontiguousarray(ext[:, m:]), np.ascontiguousarray(ext[:, :m]), i, 0,
                  rows, out)
    return out


def _row_ranges(chunks, J, width):
    """Hankel-row ranges [s, e) following the record's chunks, none shorter than ``width``."""
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


def lq_factor_dask(ex, i, hankel_chunk):
    r"""L = Rᵀ/√j of the block-Hankel data matrix of one Dask experiment, by TSQR.

    ``hankel_chunk(Y, U, i, q0, rows, out)`` writes rows of Hᵀ (the in-memory
    builder of :mod:`._subspace`, so that both paths form the same rows).

    Equal to ``_lq_factor`` of the same record in memory up to the signs of
    the rows of R (which the projections of :func:`n4sid` do not see) and
    rounding.
    """
    dask, da = _dask()
    Y, U = ex.Y[0], ex.U[0]
    m, p = ex.m, ex.p
    c = 2 * i * (m + p)
    J = Y.shape[0] - 2 * i + 1
    W = da.concatenate([U, Y], axis=1).rechunk({1: -1})
    blocks = []
    for s, e in _row_ranges(W.chunks[0], J, max(c, 1024)):
        ext = W[s: e + 2 * i - 1]                   # the chunk and 2i − 1 samples of overlap
        blocks.append(da.from_delayed(dask.delayed(_hankel_block)(hankel_chunk, ext, i, m, e - s),
                                      shape=(e - s, c), dtype=np.float64))
    H = da.concatenate(blocks, axis=0)
    _, R = da.linalg.tsqr(H)
    R, bad = dask.compute(R, ~da.isfinite(W).all())
    if bad:
        raise param_error("data", "finite on Dask (no NaN gaps: merge the runs between them "
                          "as experiments in memory)", "<NaN or infinite samples>")
    return np.asarray(R).T / np.sqrt(J), J
