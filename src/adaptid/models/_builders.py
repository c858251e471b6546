r"""Regressor builders for the usual linear-in-the-parameters structures.

Each builder validates its input, builds the regressor matrix with numpy
indexing (no Python loop over samples) and returns a
:class:`~adaptid.models.Regression` with one name per column and the sample
index of each row.
"""

from __future__ import annotations

import numpy as np

from .._validation import as_float_array, check_int, param_error
from ._regression import Regression

__all__ = [
    "arx_regressors",
    "fir_regressors",
    "trend_regressors",
    "exponential_regressors",
]


# --------------------------------------------------------------------- helpers
def _as_inputs(u, N, name="u"):
    """u as an (N, m) float64 array, and whether it was one-dimensional."""
    arr = as_float_array(u, name, ndim=(1, 2), allow_nan=True)
    single = arr.ndim == 1
    arr2 = arr.reshape(-1, 1) if single else arr
    if arr2.shape[0] != N:
        raise param_error(name, f"of length N={N} (the length of y)", f"<{arr2.shape[0]} samples>")
    return np.ascontiguousarray(arr2), single


def _per_input(value, name, m, *, low):
    """An order given as one integer for every input or one per input."""
    if np.ndim(value) == 0:
        v = check_int(value, name, low=low)
        return [v] * m
    seq = list(np.asarray(value).ravel()) if isinstance(value, np.ndarray) else list(value)
    if len(seq) != m:
        raise param_error(name, f"an integer or a sequence of {m} integers (one per input)", value)
    return [check_int(v, f"{name}[{i}]", low=low) for i, v in enumerate(seq)]


def _input_names(m, single):
    return ["u"] if single else [f"u{i}" for i in range(m)]


def _lag_name(base, lag):
    return f"{base}[k]" if lag == 0 else f"{base}[k-{lag}]"


def _check_length(N, start, what):
    if N <= start:
        raise param_error("y", f"longer than {start} samples (the lags of {what} need "
                          f"{start} initial samples and leave no row otherwise)",
                          f"<{N} samples>")


# ------------------------------------------------------------------------ ARX
def arx_regressors(y, u, na, nb, nk=1, *, nan_policy="raise"):
    r"""Regressors of the ARX model :math:`A(q)y_k = B(q)u_k + e_k`.

    Row k (for every sample whose lags are all measured) is

    .. math::

        \varphi_k = \big[y_{k-1},\ \dots,\ y_{k-n_a},\
                    u^{(i)}_{k-n_k^{(i)}},\ \dots,\ u^{(i)}_{k-n_k^{(i)}-n_b^{(i)}+1},\
                    \dots\big]^T,

    input by input, so that :math:`y_k = \theta^T\varphi_k + e_k` with
    :math:`\theta = [-a_1, \dots, -a_{n_a}, b^{(i)}_0, \dots]`. Note the plain
    (positive) lagged outputs: the coefficients of the ``y[k-j]`` columns are
    :math:`-a_j` in the usual convention :math:`A(q) = 1 + a_1q^{-1} + \dots`
    (:class:`~adaptid.models.ARX` takes care of the sign).

    Several experiments (a merged :class:`~adaptid.IDData`, or lists of
    records) give the rows of each experiment, formed inside it, stacked:
    no row has a lag in another experiment.

    Parameters
    ----------
    y : array_like, shape (N,); IDData; or list of array_like
        Output record; or an IDData with one output (``u`` then None), whose
        experiments are kept apart; or a list of output records (one per
        experiment, ``u`` then the list of their inputs).
    u : array_like, shape (N,) or (N, m); list of array_like; or None
        Input record; m inputs as columns.
    na : int
        Number of lagged outputs, ``na >= 0``.
    nb : int or sequence of int, length m
        Number of lagged values of each input, ``>= 0`` (0 leaves an input out).
    nk : int or sequence of int, length m
        Input delay of each input in samples, ``>= 0`` (default 1; 0 means a
        direct feed-through term ``u[k]``).
    nan_policy : {"raise", "omit"}
        ``"raise"`` (default) refuses NaN samples; ``"omit"`` leaves out
        every row whose regressors or target touch a NaN (gaps).

    Returns
    -------
    Regression
        ``Phi`` of shape (N - s, na + sum(nb)) with rows for the samples
        k = s … N-1 (0-based, ``index``), where
        :math:`s = \max(n_a, \max_i(n_k^{(i)} + n_b^{(i)} - 1))` is the number
        of initial samples needed as lags. Columns are named ``"y[k-j]"`` and
        ``"u[k-j]"`` (one input) or ``"u0[k-j]"``, ``"u1[k-j]"``, … (several).
        ``meta`` holds ``na``, ``nb``, ``nk`` (as lists) and ``start`` = s;
        ``row_bounds`` (E + 1,), the first row of each of the E experiments
        (and the number of rows); ``n_dropped``, the rows left out for
        touching a NaN: :math:`\sum_e \max(N_e - s, 0)` minus the rows
        kept. ``index`` counts the samples of the experiments in turn
        (the rows of :meth:`IDData.merge`'s concatenated signals).

    Raises
    ------
    ValueError
        On negative orders, lengths that differ, non-finite data, or a record
        not longer than s.

    References
    ----------
    .. [1] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
       Prentice Hall, 1999, sec. 4.2 (ARX) and sec. 7.3 (least squares).

    Examples
    --------
    >>> import numpy as np
    >>> from adaptid.models import arx_regressors
    >>> y = np.arange(6.0); u = 10 * np.arange(6.0)
    >>> reg = arx_regressors(y, u, na=1, nb=2, nk=1)
    >>> reg.names
    ('y[k-1]', 'u[k-1]', 'u[k-2]')
    >>> reg.Phi[0], float(reg.y[0]), int(reg.index[0])
    (array([ 1., 10.,  0.]), 2.0, 2)
    """
    from ._segments import check_nan_policy

    nan_policy = check_nan_policy(nan_policy)
    ys, Us, single = _experiment_signals(y, u, nan_policy == "omit")
    m = Us[0].shape[1]
    na = check_int(na, "na", low=0)
    nbs = _per_input(nb, "nb", m, low=0)
    nks = _per_input(nk, "nk", m, low=0)
    start = max([na] + [k + b - 1 for b, k in zip(nbs, nks) if b > 0])
    if na + sum(nbs) == 0:
        raise param_error("na + sum(nb)", ">= 1 (at least one regressor)", 0)
    what = f"na={na}, nb={nbs}, nk={nks}"
    if len(ys) == 1:
        _check_length(ys[0].shape[0], start, what)
    Phis, targets, index, row_bounds, offset, possible = [], [], [], [0], 0, 0
    for ye, Ue in zip(ys, Us):
        if ye.shape[0] > start:
            Phi, target, rows = _arx_rows(ye, Ue, na, nbs, nks, start)
            possible += rows.size
            keep = np.isfinite(target) & np.isfinite(Phi).all(axis=1)
            if not keep.all():
                Phi, target, rows = Phi[keep], target[keep], rows[keep]
            Phis.append(Phi)
            targets.append(target)
            index.append(offset + rows)
        row_bounds.append(row_bounds[-1] + (index[-1].size if ye.shape[0] > start else 0))
        offset += ye.shape[0]
    n_rows = row_bounds[-1]
    if n_rows == 0:
        raise param_error("y", f"an experiment with a complete row (the lags of {what} need "
                          f"{start} initial samples, and rows that touch a NaN are left out)",
                          "<no row>")
    names = [_lag_name("y", j) for j in range(1, na + 1)]
    for b, k, base in zip(nbs, nks, _input_names(m, single)):
        names += [_lag_name(base, j) for j in range(k, k + b)]
    Phi = np.ascontiguousarray(np.concatenate(Phis) if len(Phis) > 1 else Phis[0])
    return Regression(Phi, np.concatenate(targets), tuple(names), np.concatenate(index),
                      {"structure": "arx", "na": na, "nb": nbs, "nk": nks,
                       "start": start, "n_inputs": m, "single_input": single,
                       "row_bounds": np.asarray(row_bounds, dtype=np.int64),
                       "n_dropped": int(possible - n_rows)})


def _experiment_signals(y, u, allow_nan):
    """([y_e (N_e,)], [U_e (N_e, m)], single) of one record, a merged IDData or lists."""
    from ._iddata import IDData

    if isinstance(y, IDData):
        if u is not None:
            raise param_error("u", "None when y is an IDData", "<an array>", exc=TypeError)
        if y.n_outputs != 1:
            raise param_error("y", "an IDData with one output", f"<{y.n_outputs} outputs>")
        b = y.bounds
        Y = y.outputs[:, 0]
        if not allow_nan:
            as_float_array(Y, "y", ndim=1)
            as_float_array(y.inputs, "u", ndim=2)
        ys = [Y[b[e]: b[e + 1]] for e in range(len(b) - 1)]
        return ys, [y.inputs[b[e]: b[e + 1]] for e in range(len(b) - 1)], y.n_inputs == 1
    if isinstance(y, list):
        if not isinstance(u, list) or len(u) != len(y) or not y:
            raise param_error("u", f"a list of {len(y)} input records (one per output record)",
                              u, exc=TypeError)
        ys = [as_float_array(ye, f"y[{e}]", ndim=1, allow_nan=allow_nan)
              for e, ye in enumerate(y)]
        pairs = [_as_inputs(ue, ye.shape[0], f"u[{e}]") for e, (ye, ue) in enumerate(zip(ys, u))]
        if not allow_nan:
            for e, (Ue, _) in enumerate(pairs):
                as_float_array(Ue, f"u[{e}]")
        if len({Ue.shape[1] for Ue, _ in pairs}) != 1:
            raise param_error("u", "records with the same number of inputs", u)
        return ys, [Ue for Ue, _ in pairs], pairs[0][1]
    y = as_float_array(y, "y", ndim=1, allow_nan=allow_nan)
    U, single = _as_inputs(u, y.shape[0])
    if not allow_nan:
        as_float_array(U, "u")
    return [y], [U], single


def _arx_rows(y, U, na, nbs, nks, start):
    """(Φ, target, rows) of one experiment: rows k = start … N-1, lags inside it."""
    rows = np.arange(start, y.shape[0])
    cols = []
    if na:
        lags = np.arange(1, na + 1)
        cols.append(y[rows[:, None] - lags[None, :]])
    for i, (b, k) in enumerate(zip(nbs, nks)):
        if b:
            lags = np.arange(k, k + b)
            cols.append(U[rows[:, None] - lags[None, :], i])
    return np.concatenate(cols, axis=1), y[start:].copy(), rows


def fir_regressors(y, u, nb, nk=1, *, nan_policy="raise"):
    r"""Regressors of the finite impulse response model :math:`y_k = B(q)u_k + e_k`.

    The ARX regressors with ``na = 0``: row k is
    :math:`[u_{k-n_k}, \dots, u_{k-n_k-n_b+1}]` for each input, so that θ
    holds the first ``nb`` impulse-response coefficients after the delay.

    Parameters
    ----------
    y : array_like, shape (N,)
    u : array_like, shape (N,) or (N, m)
    nb : int or sequence of int
        Number of impulse-response coefficients (per input), ``>= 0``.
    nk : int or sequence of int
        Delay (per input), ``>= 0`` (default 1).
    nan_policy : {"raise", "omit"}
        As :func:`arx_regressors` (which also describes several experiments).

    Returns
    -------
    Regression
        As :func:`arx_regressors` with ``na = 0``; ``meta["structure"]`` is
        ``"fir"``.

    References
    ----------
    .. [1] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
       1999, eq. 4.46 (FIR model).
    """
    reg = arx_regressors(y, u, 0, nb, nk, nan_policy=nan_policy)
    meta = dict(reg.meta, structure="fir")
    return Regression(reg.Phi, reg.y, reg.names, reg.index, meta)


# ---------------------------------------------------------------------- trend
def trend_regressors(t, y, degree, *, scale=True):
    r"""Regressors of a polynomial trend :math:`y_k = \sum_{j=0}^{r}\theta_j\tau_k^j + e_k`.

    Powers of the time :math:`t_k` are very badly conditioned (the columns
    1, t, t², … of a record at t = 1000 … 2000 are nearly collinear). By
    default time is therefore centred and scaled onto [-1, 1],

    .. math::

        \tau_k = \frac{t_k - c}{h},\qquad c = \tfrac12(t_{\max}+t_{\min}),\quad
        h = \tfrac12(t_{\max}-t_{\min}),

    and the columns are :math:`1, \tau, \dots, \tau^r` (names ``"1"``,
    ``"tau"``, ``"tau^2"``, …). The fitted *values* are the same as with raw
    powers of t; to get the coefficients of t itself, expand
    ``numpy.polynomial.Polynomial(theta).convert(domain=...)`` or pass
    ``scale=False`` (columns 1, t, …, named ``"1"``, ``"t"``, ``"t^2"``).
    ``meta["t_center"]`` and ``meta["t_scale"]`` hold c and h (0 and 1
    unscaled), so a new time t maps to τ = (t − c)/h.

    Parameters
    ----------
    t : array_like, shape (N,)
        Sample times (any spacing, not all equal when scaled).
    y : array_like, shape (N,) or (N, p)
        Observations.
    degree : int
        Polynomial degree r >= 0.
    scale : bool
        Centre and scale t (default True).

    Returns
    -------
    Regression
        ``Phi`` (N, r + 1), all N samples as rows.

    References
    ----------
    .. [1] G. H. Golub, C. F. Van Loan, *Matrix Computations*, 4th ed., 2013,
       sec. 5.3 (conditioning of polynomial least squares / Vandermonde
       matrices).
    """
    t = as_float_array(t, "t", ndim=1)
    y = as_float_array(y, "y", ndim=(1, 2))
    r = check_int(degree, "degree", low=0)
    N = t.shape[0]
    if y.shape[0] != N:
        raise param_error("y", f"of length N={N} (the length of t)", f"<{y.shape[0]} samples>")
    if N == 0:
        raise param_error("t", "non-empty", "<0 samples>")
    if scale:
        lo, hi = float(t.min()), float(t.max())
        c, h = 0.5 * (hi + lo), 0.5 * (hi - lo)
        if h == 0.0:
            if r > 0:
                raise param_error("t", "not constant (scale=True with degree >= 1)",
                                  "<a constant time vector>")
            h = 1.0
        tau, var = (t - c) / h, "tau"
    else:
        c, h, tau, var = 0.0, 1.0, t, "t"
    Phi = np.ascontiguousarray(np.vander(tau, r + 1, increasing=True))
    names = ("1",) + tuple(var if j == 1 else f"{var}^{j}" for j in range(1, r + 1))
    return Regression(Phi, y.copy(), names, np.arange(N),
                      {"structure": "trend", "degree": r, "t_center": c, "t_scale": h,
                       "scaled": bool(scale)})


# ---------------------------------------------------------------- exponentials
def exponential_regressors(t, y, rates, *, t0=0.0, constant=False):
    r"""Regressors of a sum of exponentials with given rates.

    .. math::

        y_k = \theta_0 + \sum_{i=1}^{q} \theta_i\, e^{-r_i (t_k - t_0)} + e_k,

    the constant term only with ``constant=True``. The rates :math:`r_i` are
    fixed (the model is linear in the amplitudes θ only).

    Parameters
    ----------
    t : array_like, shape (N,)
        Sample times.
    y : array_like, shape (N,) or (N, p)
        Observations.
    rates : array_like, shape (q,)
        Decay rates :math:`r_i` (finite, distinct; negative rates are growing
        exponentials).
    t0 : float
        Time origin (default 0). Shifting it rescales each amplitude by
        :math:`e^{r_i t_0}`; choose it near ``t[0]`` to avoid under/overflow
        on records that start late.
    constant : bool
        Add a constant column first (name ``"1"``).

    Returns
    -------
    Regression
        ``Phi`` (N, q [+1]), columns named ``"exp(-r*t)"`` with the rate
        written out (e.g. ``"exp(-0.5*t)"``); all N samples as rows.

    Raises
    ------
    ValueError
        On repeated rates (identical columns) or non-finite values.
    """
    t = as_float_array(t, "t", ndim=1)
    y = as_float_array(y, "y", ndim=(1, 2))
    rates = as_float_array(rates, "rates", ndim=1)
    N = t.shape[0]
    if y.shape[0] != N:
        raise param_error("y", f"of length N={N} (the length of t)", f"<{y.shape[0]} samples>")
    if rates.size == 0 and not constant:
        raise param_error("rates", "non-empty (or constant=True)", rates)
    if np.unique(rates).size != rates.size:
        raise param_error("rates", "distinct values", rates)
    t0 = float(as_float_array(t0, "t0", ndim=0))
    with np.errstate(over="raise"):
        try:
            E = np.exp(-np.outer(t - t0, rates))
        except FloatingPointError:
            raise param_error("t0", "close enough to t that exp(-rate*(t - t0)) does not overflow",
                              t0) from None
    names = tuple(f"exp({-r:g}*t)" if r < 0 else f"exp(-{r:g}*t)" for r in rates)
    if constant:
        E = np.column_stack([np.ones(N), E])
        names = ("1",) + names
    return Regression(np.ascontiguousarray(E), y.copy(), names, np.arange(N),
                      {"structure": "exponential", "rates": rates.copy(), "t0": t0,
                       "constant": bool(constant)})
