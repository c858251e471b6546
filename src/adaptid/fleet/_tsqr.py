r"""Least squares of tall dask arrays by a tall-skinny QR (TSQR)."""

from __future__ import annotations

import numpy as np

from .._validation import param_error

__all__ = ["lstsq"]


def lstsq(Phi, y, *, weights=None):
    r"""Weighted least squares of a tall (possibly larger than memory) dask array.

    Minimises :math:`\sum_k w_k (y_k - \varphi_k^T\theta)^2` like
    :func:`adaptid.lstsq`, from the triangular factor of the augmented
    matrix :math:`W^{1/2}[\Phi\ \ Y]` computed by Dask's tall-skinny QR
    (``dask.array.linalg.tsqr``: a QR per block of rows, then a QR of the
    stacked R factors), so only (n + p)² numbers per block meet in memory
    and Q is never formed. With

    .. math::

        \operatorname{qr}\bigl(W^{1/2}[\Phi\ \ Y]\bigr) =
        Q\begin{bmatrix} R & z \\ 0 & T \end{bmatrix},\qquad
        \hat\theta = R^{-1}z,\qquad
        \hat\sigma^2_j = \frac{\|T_{:,j}\|^2}{N - n},

        \operatorname{cov} = \hat\sigma^2 R^{-1}R^{-T}

    (the residual sum of squares of output j is the squared norm of column
    j of T, because Q is orthogonal). Never forms ΦᵀΦ.

    Parameters
    ----------
    Phi : dask.array.Array or array_like, shape (N, n)
        Regressors, chunked along rows (any column chunking is merged);
        chunk sizes must be known.
    y : dask.array.Array or array_like, shape (N,) or (N, p)
        Outputs, p outputs share Φ.
    weights : dask.array.Array or array_like, shape (N,), optional
        wₖ ≥ 0 (default 1).

    Returns
    -------
    adaptid.LSResult
        ``theta``, ``sigma2``, ``dof``, ``rank``, ``cov``, ``stderr``,
        ``conf_int`` as from :func:`adaptid.lstsq`; ``residuals`` is a lazy
        dask array :math:`y - \Phi\hat\theta` (call ``.compute()``).

    Raises
    ------
    ValueError
        On wrong shapes, unknown chunk sizes, non-finite data, negative
        weights or a rank-deficient design (checked in the same pass over
        the data as the factorisation).

    Notes
    -----
    One pass over the data with Dask's current scheduler (an active
    ``distributed.Client`` is used). Blocks with fewer rows than max(n + p, 1024)
    are merged with their neighbours by rechunking.

    References
    ----------
    .. [1] J. Demmel, L. Grigori, M. Hoemmen, J. Langou, "Communication-optimal
       parallel and sequential QR and LU factorizations", SIAM J. Sci.
       Comput. 34(1):A206–A239, 2012.
    .. [2] A. R. Benson, D. F. Gleich, J. Demmel, "Direct QR factorizations
       for tall-and-skinny matrices in MapReduce architectures", IEEE Big
       Data 2013.

    Examples
    --------
    >>> import numpy as np, dask.array as da, adaptid
    >>> rng = np.random.default_rng(0)
    >>> Phi = rng.standard_normal((1000, 3)); y = Phi @ [1.0, -2.0, 0.5] + rng.standard_normal(1000)
    >>> res = adaptid.fleet.lstsq(da.from_array(Phi, chunks=(250, 3)), da.from_array(y, chunks=250))
    >>> bool(np.allclose(res.theta, adaptid.lstsq(Phi, y).theta, rtol=0, atol=1e-10))
    True
    """
    import dask
    import dask.array as da
    from scipy import linalg

    from .._lstsq import LSResult

    A = _as_dask(Phi, "Phi", da)
    Y = _as_dask(y, "y", da)
    if A.ndim != 2 or A.shape[1] == 0:
        raise param_error("Phi", "2-dimensional of shape (N, n), n >= 1", f"<shape {A.shape}>")
    if Y.ndim not in (1, 2):
        raise param_error("y", "1- or 2-dimensional", f"<shape {Y.shape}>")
    N, n = A.shape
    if any(np.isnan(c) for c in A.chunks[0]) or any(np.isnan(c) for c in Y.chunks[0]):
        raise param_error("Phi", "a dask array with known chunk sizes "
                          "(call .compute_chunk_sizes())", "<unknown chunk sizes>")
    if Y.shape[0] != N:
        raise param_error("y", f"of length N={N} (rows of Phi)", f"<shape {Y.shape}>")
    single = Y.ndim == 1
    Y2 = Y.reshape(N, 1) if single else Y
    p = Y2.shape[1]
    if N < n:
        raise param_error("Phi", f"with at least n={n} rows", f"<{N} rows>")
    A = A.astype(np.float64)
    Y2 = Y2.astype(np.float64)

    M = da.concatenate([A, Y2.rechunk({0: A.chunks[0]})], axis=1)
    checks = [~da.isfinite(M).all()]
    if weights is not None:
        w = _as_dask(weights, "weights", da).astype(np.float64)
        if w.shape != (N,):
            raise param_error("weights", f"of shape ({N},)", f"<shape {w.shape}>")
        w = w.rechunk(M.chunks[0])
        checks += [~da.isfinite(w).all(), (w < 0).any()]
        M = M * da.sqrt(da.maximum(w, 0.0))[:, None]
    M = M.rechunk({1: -1})
    M = _tall_blocks(M, n + p)
    _, Raug = da.linalg.tsqr(M)
    Raug, *flags = dask.compute(Raug, *checks)
    if flags[0]:
        raise param_error("Phi", "finite (no NaN or inf), and y too", "<non-finite entries>")
    if weights is not None:
        if flags[1]:
            raise param_error("weights", "finite (no NaN or inf)", "<non-finite entries>")
        if flags[2]:
            raise param_error("weights", "non-negative", "<negative entries>")
    Raug = np.asarray(Raug)
    R = Raug[:n, :n]
    z = Raug[:n, n:]
    T = Raug[n:, n:]
    d = np.abs(np.diag(R))
    tol = max(N, n) * np.finfo(float).eps * (d.max() if d.size else 0.0)
    rank = int(np.count_nonzero(d > tol))
    if rank < n:
        raise param_error("Phi", f"of full column rank n={n}",
                          f"<a design of numerical rank {rank}>")
    # a positive diagonal, as a Householder QR of LAPACK may give either sign
    s = np.sign(np.diag(R))
    s[s == 0] = 1.0
    R = s[:, None] * R
    z = s[:, None] * z
    theta = linalg.solve_triangular(R, z, lower=False)
    dof = N - n
    rss = np.einsum("ij,ij->j", T, T) if T.size else np.zeros(p)
    sigma2 = rss / dof if dof > 0 else np.full(p, np.nan)
    if single:
        resid = Y - A @ theta[:, 0]
        return LSResult(theta=theta[:, 0], residuals=resid, sigma2=float(sigma2[0]),
                        dof=dof, rank=rank, _R=R, _single=True)
    resid = Y2 - A @ theta
    return LSResult(theta=theta, residuals=resid, sigma2=sigma2, dof=dof, rank=rank, _R=R,
                    _single=False)


def _as_dask(x, name, da):
    if isinstance(x, da.Array):
        return x
    try:
        arr = np.asarray(x)
    except Exception as err:
        raise param_error(name, "a dask array or array_like", x, exc=TypeError) from err
    if arr.dtype.kind not in "biuf":
        raise param_error(name, "a real numeric array", arr, exc=TypeError)
    return da.from_array(arr, chunks=(max(1, min(arr.shape[0], 100_000)),) + arr.shape[1:]
                         if arr.ndim else arr.shape)


def _tall_blocks(M, width):
    """Merge row blocks shorter than max(width, 1024) rows with their neighbours.

    TSQR needs blocks at least as tall as wide; tiny blocks also cost more in
    scheduling than in arithmetic.
    """
    width = max(width, 1024)
    rows = list(M.chunks[0])
    if all(r >= width for r in rows):
        return M
    merged = []
    acc = 0
    for r in rows:
        acc += r
        if acc >= width:
            merged.append(acc)
            acc = 0
    if acc:
        if merged:
            merged[-1] += acc
        else:
            merged.append(acc)
    return M.rechunk({0: tuple(merged)})
