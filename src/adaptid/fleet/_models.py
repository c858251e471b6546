r"""Model objects per device on Dask: batch fits, and the streaming pseudo-linear models.

:func:`fit_models` is the model-object counterpart of :func:`adaptid.fleet.identify`:
the same partitions holding whole devices (:mod:`._graph`), the same row
order (:mod:`._layout`), one Dask task per partition; in each task a loop
over its devices calls the model object's ``fit`` (a copy per device), or
the streaming object's ``run`` (a copy, from its start state).
"""

from __future__ import annotations

import copy

import numpy as np

from .._validation import check_choice, check_int, check_scalar, param_error
from ._changes import _MULTIPLE, _PVALUE_TESTS, _bde_a, _bde_tests, _fleet_verdict, _pvalue_tests
from ._graph import _close_client, _compute, _open_client, _partitioned, _result_meta
from ._inputs import (_as_frame, _check_column, _check_label_texts, _check_tracks, _float_column,
                      _group_values, _label, _need, _time_key)
from ._layout import _layout

__all__ = ["fit_models"]

#: the change tests of a streaming model (``"a-priori"``: its own a-priori errors)
_STREAM_TESTS = _PVALUE_TESTS + ("a-priori", "recursive")
_STAT_COLUMNS = ("n_samples", "n_skipped", "sigma2", "rms")


def _kind_of(model):
    """("batch" | "stream", time series?) of ``model``, or TypeError."""
    from ..models._ar import _TimeSeries
    from ..models._polymodel import _PolyModel
    from ..models.streaming._plr import _PseudoLinearStream

    if isinstance(model, _PseudoLinearStream):
        return "stream", model._m == 0
    if isinstance(model, _PolyModel) and callable(getattr(model, "fit", None)):
        return "batch", isinstance(model, _TimeSeries)
    raise param_error("model", "a model object of adaptid.models (ARX, AR, ARMA, ARMAX, OE, BJ) "
                      "or a streaming RecursiveARMA, RecursiveARMAX, RecursiveOE or RecursiveBJ "
                      "(fleet.identify runs ARX regressors)", f"<{type(model).__name__}>",
                      exc=TypeError)


def _param_names(model, kind, n_inputs):
    """The parameter names the fitted model will carry (without fitting it)."""
    if kind == "stream":
        return tuple(model.names)
    m = copy.deepcopy(model)
    m._set_inputs(max(n_inputs, 1), n_inputs <= 1)
    return tuple(m._names())


def _inputs_arg(u, time_series):
    """``u`` as a list of column names (empty for AR/ARMA), checked against the model."""
    if u is None:
        names = []
    elif isinstance(u, str):
        names = [u]
    else:
        names = list(u)
    if time_series and names:
        raise param_error("u", "None for a time-series model (AR, ARMA)", names)
    if not time_series and not names:
        raise param_error("u", "the input column(s) of the model", u)
    return names


def fit_models(data, model, *, group, y, u=None, time=None, client=None, tracks=None,
               alpha=0.05, change_test="supF", multiple="bh", npartitions=None,
               progress=False):
    r"""Fit the same model object to every device of a fleet, one Dask task per partition.

    Each device's rows, in ``time`` order, form one record
    :math:`(y_k, u_k)`. For a model object (:class:`~adaptid.models.ARX`,
    :class:`~adaptid.models.AR`, :class:`~adaptid.models.ARMA`,
    :class:`~adaptid.models.ARMAX`, :class:`~adaptid.models.OE`,
    :class:`~adaptid.models.BJ`) a copy per device runs its batch ``fit``
    (least squares for ARX/AR; prediction errors, Ljung (1999), ch. 7,
    for the others) on ``IDData(y, u, model.dt)``. For a streaming object
    (:class:`~adaptid.models.RecursiveARMA`,
    :class:`~adaptid.models.RecursiveARMAX`, :class:`~adaptid.models.RecursiveOE`,
    :class:`~adaptid.models.RecursiveBJ`) a copy per device, reset to its
    prior, runs ``run`` over the record (extended least squares
    or pseudo-linear regression, Söderström & Stoica (1989), sec. 9.4):

    .. math::

        \hat y_k = \varphi_k^T\hat\theta_{k-1},\quad
        \hat\theta_k = \hat\theta_{k-1} + K_k(y_k - \hat y_k),

    :math:`\varphi_k` holding the signals formed with the running
    estimate; built with ``start="filled"`` this equals the model's
    ``fit_recursive`` (the model ``adaptid fit --armax … --method rls`` reports).

    Parameters
    ----------
    data : pandas.DataFrame, dask.dataframe.DataFrame, str or path-like
        Long-format table (one row per sample and device), or a path / glob /
        list of Parquet files, as :func:`adaptid.fleet.identify` takes it.
    model : model object or streaming object
        Not fitted or run itself: copies are.
    group : str
        The device-id column.
    y : str
        The output column.
    u : str or list of str, optional
        The input column(s) (in the model's input order); None for AR/ARMA.
    time : str, optional
        Ordering column (stable sort within each device); None: stored order.
    client : None, "local", str or distributed.Client
        As in :func:`adaptid.fleet.identify`.
    tracks : str or path-like, optional
        Streaming objects only: a Parquet data set of the per-sample
        estimates (group, time, ``sample``, θ columns, the a-priori
        ``error`` :math:`y_k - \hat y_k`, ``skipped``), partitioned by group,
        as :func:`adaptid.fleet.identify` writes it; the samples before the
        first update of ``start="filled"`` are not written.
    alpha, multiple : float, str
        Level of the change test and the control across devices, as in
        :func:`adaptid.fleet.identify` (streaming objects only).
    change_test : {"supF", "re", "cusum", "cusum2", "a-priori", "recursive"}
        Streaming objects only (see Notes).
    npartitions : int, optional
        Partitions of a pandas input (default twice the cores), or of the
        shuffled dask input.
    progress : bool
        Show Dask's progress bar.

    Returns
    -------
    pandas.DataFrame
        One row per device, indexed by ``group`` (sorted): the model's
        parameters (its ``names``), ``stderr_<name>``, ``n_samples``,
        ``n_skipped`` (0), ``sigma2``, ``rms``; streaming objects add
        ``change``, ``change_stat``, ``change_pvalue``, ``change_at``.

    Raises
    ------
    ValueError
        A missing column (names the argument), a device with missing values
        or a failing fit (names the device), bad options.
    TypeError
        ``model`` of another kind; ``u`` given to a time-series model.

    Notes
    -----
    **Statistics.** Batch: the fitted model's ``theta``, ``stderr``,
    ``noise_variance`` (``sigma2``), ``rms`` = :math:`\sqrt{\sum_k
    \varepsilon_k^2/N}` of its residuals, ``n_samples`` = N of them.
    Streaming: the model at the final estimate as ``fit_recursive`` leaves
    it (roots of C, F reflected into the unit circle; the prediction-error
    covariance at that θ, Ljung (1999), eq. 9.17), ``n_samples`` the
    number of updates.

    **Change test** (streaming objects). ``"a-priori"``: the
    Brown–Durbin–Evans CUSUM crossing of the stream's a-priori errors
    (after the ``burn_in`` of :func:`adaptid.fleet.identify`). The others
    (:func:`adaptid.diagnostics.change_tests`, or BDE on the recursive
    residuals for ``"recursive"``) run on the regression the recursion
    formed, :math:`y_k = \varphi_k^T\theta + e_k` with the regressor rows of
    ``fit_recursive`` (``Trajectory.meta["regressors"]``: one more compiled
    pass per device). The verdict across devices as in
    :func:`adaptid.fleet.identify`.

    References
    ----------
    .. [1] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
       Prentice Hall, 1999, ch. 7, 9 and 11.
    .. [2] T. Söderström, P. Stoica, *System Identification*, Prentice
       Hall, 1989, sec. 9.4.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from scipy.signal import lfilter
    >>> from adaptid import fleet, models
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal((3, 300))
    >>> df = pd.DataFrame({"device": np.repeat(["a", "b", "c"], 300), "u": u.ravel(),
    ...                    "y": np.concatenate([lfilter([0, 1.0], [1, -0.5], x) for x in u])})
    >>> res = fleet.fit_models(df, models.ARX(1, 1, 1), group="device", y="y", u="u")
    >>> bool(np.allclose(res[["a1", "b0"]], [[-0.5, 1.0]] * 3))
    True
    """
    _need("dask")
    kind, time_series = _kind_of(model)
    u = _inputs_arg(u, time_series)
    change_test = check_choice(change_test, "change_test", _STREAM_TESTS)
    multiple = check_choice(multiple, "multiple", _MULTIPLE)
    alpha = check_scalar(alpha, "alpha", low=0.0, high=1.0, low_open=True, high_open=True)
    if tracks is not None and kind == "batch":
        raise param_error("tracks", "None for a batch model fit (no per-sample estimates; "
                          "give a streaming object)", tracks)
    fkind, frame = _as_frame(data)
    _check_column(frame, group, "group", allow_index=fkind == "dask")
    for name, arg in [(y, "y"), *((c, "u") for c in u), *([(time, "time")] if time else [])]:
        _check_column(frame, name, arg)
    _check_tracks(data, tracks)
    if fkind == "pandas" and _group_values(frame, group).dtype.kind == "O":
        import pandas as pd
        _check_label_texts(pd.unique(_group_values(frame, group)))
    if npartitions is not None:
        npartitions = check_int(npartitions, "npartitions", low=1)
    names = _param_names(model, kind, len(u))
    meta = _result_meta(names, group, frame, fkind)
    if kind == "batch":
        meta = meta.drop(columns=["change", "change_stat", "change_pvalue", "change_at"])
    client, own_cluster = _open_client(client)
    try:
        ddf, _, order_col = _partitioned(fkind, frame, group=group, y=y, phi=u, model=None,
                                         time=time, client=client, npartitions=npartitions)
        if tracks is not None:
            import os
            os.makedirs(os.fspath(tracks), exist_ok=True)
        result = ddf.map_partitions(
            _models_partition, enforce_metadata=False, meta=meta, group=group, y=y, u=u,
            time=time, model=model, kind=kind, names=names, tracks=tracks, order_col=order_col,
            test=(change_test, _bde_a(alpha), alpha))
        out = _compute(result, client, progress)
    finally:
        _close_client(client, own_cluster)
    out = out[list(meta.columns)]
    try:
        out = out.sort_index(kind="stable")
    except TypeError:  # pragma: no cover - unorderable group labels
        pass
    out.index.name = group
    _check_label_texts(out.index.to_numpy(), " (in two partitions)")
    if kind == "stream" and change_test in _PVALUE_TESTS:
        _fleet_verdict(out, alpha, multiple)
    return out


def _device_records(part, group, y, u, time, order_col):
    """(labels, Y, U or None, offsets, sorted time or None) of a partition, rows ordered by
    (group, time, stored order)."""
    t_key, _ = _time_key(part, time, group, "raise")
    idx, offsets, uniq, t = _layout(part, group, t_key, order_col)
    _check_label_texts(uniq)
    rows = part if idx is None else part.iloc[idx]
    Y = _float_column(rows, y, "y")
    U = np.column_stack([_float_column(rows, c, "u") for c in u]) if u else None
    return uniq, Y, U, offsets, t   # t: the sortable time key, as identify reports it


def _device_data(model, label, yg, Ug, u, y):
    """IDData of one device (complete record), or ValueError naming the device."""
    from ..models import IDData

    if not np.isfinite(yg).all() or (Ug is not None and not np.isfinite(Ug).all()):
        raise ValueError(f"device {_label(label)}: missing values in the columns used "
                         f"({', '.join([y, *u])}); a model fit per device needs a complete "
                         "record")
    return IDData(yg, Ug, dt=getattr(model, "dt", 1.0), y_names=y, u_names=u or None)


def _models_partition(part, *, group, y, u, time, model, kind, names, tracks, order_col, test):
    """One partition: every device's model fitted (or streamed), one row per device."""
    import pandas as pd

    from ..models import ARMA

    uniq, Y, U, offsets, row_t = _device_records(part, group, y, u, time, order_col)
    rows, streams = [], []
    for g, label in enumerate(uniq):
        a, b = int(offsets[g]), int(offsets[g + 1])
        data = _device_data(model, label, Y[a:b], None if U is None else U[a:b], u, y)
        try:
            if kind == "batch":
                m = copy.deepcopy(model)
                m.fit(data.y if isinstance(m, ARMA) else data)   # ARMA takes its output alone
                res = np.asarray(m.residuals, dtype=np.float64)
                n_used, extra = int(res.size), None
            else:
                m, n_used, extra = _stream_device(model, data, test[0])
                res = np.asarray(m.residuals, dtype=np.float64)
        except (ValueError, FloatingPointError, np.linalg.LinAlgError) as e:
            raise ValueError(f"device {_label(label)}: {e}") from None
        if tuple(m.names) != names:  # pragma: no cover - a model's naming changed
            raise RuntimeError(f"fleet: names {tuple(m.names)} differ from {names}")
        row = dict(zip(names, map(float, m.theta)))
        row.update({f"stderr_{n}": float(se) for n, se in zip(names, m.stderr)})
        row.update(n_samples=n_used, n_skipped=0, sigma2=float(m.noise_variance),
                   rms=float(np.sqrt(np.mean(res ** 2))) if res.size else float("nan"))
        rows.append(row)
        streams.append(extra)
    out = pd.DataFrame(rows, columns=[*names, *(f"stderr_{n}" for n in names), *_STAT_COLUMNS],
                       index=pd.Index(uniq, name=group))
    if kind == "stream":
        _add_change_columns(out, streams, offsets, row_t, test, len(names))
        if tracks is not None:
            _stream_tracks(tracks, group, uniq, streams, names, offsets, row_t, time)
    return out


def _stream_device(proto, data, change_test):
    """Run a copy of the streaming object over one device: (model at the final estimate,
    number of updates, dict of the track, a-priori errors and the test's regression)."""
    obj = copy.deepcopy(proto)
    obj.reset()   # every device from the prior, zero lag buffers
    args = (data.y,) if obj._m == 0 else (data,)
    run = obj.run(*args)
    N = len(run.yhat)
    pos = np.arange(min(obj._s, N) if obj.start == "filled" else 0, N)   # the updates
    y = np.asarray(data.y, dtype=np.float64).reshape(-1)
    extra = {"theta": run.theta[pos], "error": y[pos] - run.yhat[pos], "pos": pos}
    if change_test != "a-priori":   # the regression the recursion formed (fit_recursive's)
        rec = copy.deepcopy(obj._model)
        traj = rec.fit_recursive(*args, estimator=proto._est)
        extra["Phi"] = np.ascontiguousarray(traj.meta["regressors"], dtype=np.float64)
        extra["y"] = np.ascontiguousarray(y[np.asarray(traj.meta["index"])], dtype=np.float64)
        extra["index"] = np.asarray(traj.meta["index"], dtype=np.int64)
    return obj._fitted_model(*args), int(pos.size), extra


def _add_change_columns(out, streams, offsets, row_t, test, n):
    """``change``, ``change_stat``, ``change_pvalue``, ``change_at`` of every device."""
    from types import SimpleNamespace

    change_test, bde_a, alpha = test
    G = len(streams)
    if G == 0:   # an empty partition (a shuffle may leave one)
        out["change"] = np.zeros(0, dtype=bool)
        for c in ("change_stat", "change_pvalue", "change_at"):
            out[c] = np.zeros(0)
        return
    key = "error" if change_test == "a-priori" else "y"
    lens = np.array([s[key].shape[0] for s in streams], dtype=np.int64)
    offs = np.zeros(G + 1, dtype=np.int64)
    np.cumsum(lens, out=offs[1:])
    if change_test == "a-priori":
        E = np.concatenate([s["error"] for s in streams])
        res = SimpleNamespace(error=E, n_samples=lens)
        ratio, first = _bde_tests(res, np.empty((E.shape[0], n)), E, np.ones(E.shape[0], bool),
                                  offs, bde_a, "a-priori", None)
        pval, at_pos = np.full(G, np.nan), [s["pos"] for s in streams]
    else:
        Phi = np.ascontiguousarray(np.concatenate([s["Phi"] for s in streams]))
        Yr = np.concatenate([s["y"] for s in streams])
        used = np.ones(Yr.shape[0], dtype=bool)
        if change_test in _PVALUE_TESTS:
            ratio, pval, first = _pvalue_tests(Phi, Yr, used, offs, change_test, alpha)
        else:
            ratio, first = _bde_tests(None, Phi, Yr, used, offs, bde_a, change_test, None)
            pval = np.full(G, np.nan)
        at_pos = [s["index"] for s in streams]
    at = np.full(G, np.nan)
    for g in np.flatnonzero(first >= 0):
        p = int(at_pos[g][first[g] - offs[g]])
        at[g] = p if row_t is None else float(row_t[offsets[g] + p])
    out["change"] = first >= 0
    out["change_stat"] = ratio
    out["change_pvalue"] = pval
    out["change_at"] = at


def _stream_tracks(path, group, uniq, streams, names, offsets, row_t, time):
    """The per-sample estimates, written as :func:`adaptid.fleet.identify` writes them."""
    from types import SimpleNamespace

    from ._partition import _write_tracks

    lengths = np.array([s["pos"].shape[0] for s in streams], dtype=np.int64)
    pos = np.concatenate([s["pos"] for s in streams]) if streams else np.empty(0, np.int64)
    n = len(names)
    theta = np.concatenate([s["theta"] for s in streams]) if streams else np.empty((0, n))
    error = np.concatenate([s["error"] for s in streams]) if streams else np.empty(0)
    res = SimpleNamespace(theta_track=theta, error=error, skipped=np.zeros(error.shape, bool))
    t = None if row_t is None else row_t[np.repeat(offsets[:-1], lengths) + pos]
    _write_tracks(path, group, uniq, lengths, res, names, pos, t, time)
