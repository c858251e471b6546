r"""The same identification for every device of a fleet, as one Dask computation.

The entry point :func:`identify`; its parts: the input (:mod:`._inputs`), the
per-group plan of a partition (:mod:`._layout`), the statistics and change
tests (:mod:`._changes`), one partition's work (:mod:`._partition`) and the
Dask graph (:mod:`._graph`).
"""

from __future__ import annotations

import os

from .._validation import check_choice, check_int, check_scalar, param_error
from ..estimators._factory import METHODS
from ._changes import _CHANGE_TESTS, _MULTIPLE, _PVALUE_TESTS, _bde_a, _fleet_verdict
from ._graph import (_close_client, _compute, _model_names, _open_client, _partitioned,
                     _result_meta)
from ._inputs import (_as_frame, _check_columns, _check_label_texts, _check_tracks,
                      _group_values, _need)
from ._partition import _identify_partition

__all__ = ["identify"]

_STAT_COLUMNS = ("n_samples", "n_skipped", "sigma2", "rms", "change", "change_stat",
                 "change_pvalue", "change_at")


def _make_estimator(method, n, nan_policy, options):
    """The prototype estimator of every group, from :func:`adaptid.estimator`."""
    from ..estimators import estimator
    if "n_outputs" in options:
        raise param_error("n_outputs", "not given (the fleet identifies single-output "
                          "models)", options["n_outputs"], exc=TypeError)
    return estimator(method, n, nan_policy=nan_policy, **options)


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
    _check_tracks(data, tracks)
    if kind == "pandas" and _group_values(frame, group).dtype.kind == "O":
        import pandas as pd
        _check_label_texts(pd.unique(_group_values(frame, group)))
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
    _check_label_texts(out.index.to_numpy(), " (in two partitions)")
    if change_test in _PVALUE_TESTS:
        _fleet_verdict(out, alpha, multiple)
    return out

