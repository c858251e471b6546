r"""Experiments and gaps: the pieces of a record inside which regressors are formed.

A record is one or more experiments (:meth:`IDData.merge`); NaN samples are
gaps. Least-squares structures (ARX, AR, FIR) keep every row whose
regressors and target are all measured; filter-based structures (ARMAX, OE,
BJ, ARMA, state space) run their filters on the runs of complete samples
between gaps, each run a separate experiment. These helpers give the
sample bounds of both and apply a filter or a lag matrix segment by segment.
"""

from __future__ import annotations

import numpy as np

from .._lazy import lazy
from .._validation import check_choice, param_error

signal = lazy("scipy.signal")

__all__ = ["NAN_POLICIES", "check_nan_policy", "record_bounds", "complete_runs",
           "lfilter_segments", "lagmat_segments", "per_segment", "segment_record"]

#: ``nan_policy`` of the models' ``fit``: leave out the rows that touch a NaN, or refuse it
NAN_POLICIES = ("omit", "raise")


def check_nan_policy(nan_policy):
    """``nan_policy`` validated against :data:`NAN_POLICIES`."""
    return check_choice(nan_policy, "nan_policy", NAN_POLICIES)


def refuse_nan(arrays, names):
    """ValueError naming the first of ``arrays`` (named ``names``) that holds a NaN."""
    for arr, name in zip(arrays, names):
        bad = np.isnan(arr)
        if bad.any():
            n = int(bad.reshape(bad.shape[0], -1).any(axis=1).sum())
            raise param_error(name, "without NaN (nan_policy='raise'; the default 'omit' "
                              "leaves out the rows that touch a gap)",
                              f"<{n} sample(s) with NaN>")


def record_bounds(data, N):
    """Sample offsets of the experiments of ``data`` (an IDData or None: one experiment)."""
    if data is not None and getattr(data, "n_experiments", 1) > 1:
        b = np.asarray(data.bounds, dtype=np.int64)
        if b[-1] == N:
            return b
    return np.array([0, N], dtype=np.int64)


def complete_runs(ok, bounds):
    """Sample offsets of the runs of ``ok`` samples inside each experiment.

    Parameters
    ----------
    ok : ndarray of bool, shape (N,)
        Samples whose every signal is measured.
    bounds : ndarray of int, shape (E + 1,)
        Experiment offsets.

    Returns
    -------
    list of (int, int)
        ``(start, stop)`` of each run (a run never crosses an experiment's end).
    """
    runs = []
    for a, b in zip(bounds[:-1], bounds[1:]):
        seg = np.r_[False, ok[a:b], False].astype(np.int8)
        d = np.diff(seg)
        starts, stops = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
        runs += [(int(a + s), int(a + e)) for s, e in zip(starts, stops)]
    return runs


def lfilter_segments(b, a, X, row_bounds):
    """:func:`scipy.signal.lfilter` along axis 0, restarted (zero state) at each bound."""
    if row_bounds is None or len(row_bounds) <= 2:
        return signal.lfilter(b, a, X, axis=0)
    out = np.empty(np.shape(X), dtype=np.float64)
    for s, e in zip(row_bounds[:-1], row_bounds[1:]):
        if e > s:
            out[s:e] = signal.lfilter(b, a, X[s:e], axis=0)
    return out


def lagmat_segments(x, n, row_bounds):
    """Columns x[t-1], …, x[t-n], zeros before the start of each segment."""
    N = x.shape[0]
    out = np.zeros((N, n))
    bounds = [0, N] if row_bounds is None else row_bounds
    for s, e in zip(bounds[:-1], bounds[1:]):
        for j in range(1, min(n, e - s - 1) + 1):
            out[s + j: e, j - 1] = x[s: e - j]
    return out


def per_segment(fn, runs, N, *arrays):
    """``fn(*pieces)`` on each run ``(start, stop)`` of the arrays, NaN between the runs."""
    out = np.full(N, np.nan)
    for s, e in runs:
        out[s:e] = np.asarray(fn(*(a[s:e] for a in arrays)), dtype=np.float64).reshape(-1)
    return out


def segment_record(y, U, runs, data=None):
    """The runs of (y, U) as one merged IDData (names and dt of ``data``)."""
    from ._iddata import IDData

    kw = {} if data is None else {"dt": data.dt, "y_names": data.y_names[:1],
                                  "u_names": data.u_names if U.shape[1] else None}
    parts = [IDData(y[s:e], U[s:e] if U.shape[1] else None, **kw) for s, e in runs]
    return parts[0].merge(*parts[1:])


def split_at_gaps(Y, U):
    """The runs of complete rows of (Y (N, p), U (N, m)): a list of (Y_r, U_r)."""
    ok = ~(np.isnan(Y).any(axis=1) | np.isnan(U).any(axis=1))
    if ok.all():
        return [(Y, U)]
    return [(Y[a:b], U[a:b]) for a, b in complete_runs(ok, np.array([0, Y.shape[0]]))]


def record_pieces(data):
    """The experiments of an IDData, each split at its NaN gaps: a list of IDData."""
    out = []
    for part in data.experiments:
        ok = ~(np.isnan(part.outputs).any(axis=1) | np.isnan(part.inputs).any(axis=1))
        if ok.all():
            out.append(part)
        else:
            out += [part[a:b] for a, b in complete_runs(ok, np.array([0, len(part)]))]
    return out


def record_runs(data):
    """(start, stop) of the runs of complete samples inside each experiment of an IDData."""
    ok = ~(np.isnan(data.outputs).any(axis=1) | np.isnan(data.inputs).any(axis=1))
    return complete_runs(ok, data.bounds)


def pooled_ljung_box(pieces, max_lag, alpha):
    r""":func:`adaptid._teststats.ljung_box` of residuals in pieces, no product across two.

    .. math::

        r(\tau) = \frac{\sum_{p}\sum_{t>\tau}\tilde e^{(p)}_t\tilde e^{(p)}_{t-\tau}}
                       {\sum_p\sum_t (\tilde e^{(p)}_t)^2},

    :math:`\tilde e = e - \bar e` with the mean of all pieces, N the total
    number of residuals in Q and the band; one piece gives ``ljung_box``.
    """
    from scipy import stats

    from .._teststats import ljung_box

    if len(pieces) == 1:
        return ljung_box(pieces[0], max_lag, alpha)
    mean = np.mean(np.concatenate(pieces))
    ec = [p - mean for p in pieces]
    ss = float(sum(p @ p for p in ec))
    N = sum(p.size for p in ec)
    acf = np.array([sum(p[tau:] @ p[:p.size - tau] for p in ec if p.size > tau) / ss
                    for tau in range(max_lag + 1)])
    taus = np.arange(1, max_lag + 1)
    q = float(N * (N + 2) * np.sum(acf[1:] ** 2 / (N - taus)))
    return {"acf": acf, "band": float(stats.norm.ppf(1 - alpha / 2) / np.sqrt(N)), "q_stat": q,
            "dof": max_lag, "p_value": float(stats.chi2.sf(q, max_lag))}


def pooled_cross_correlation(u_pieces, e_pieces, max_lag, alpha):
    """:func:`adaptid._teststats.cross_correlation` in pieces, no product across two."""
    from scipy import stats

    from .._teststats import cross_correlation

    if len(e_pieces) == 1:
        return cross_correlation(u_pieces[0], e_pieces[0], max_lag, alpha)
    mu, me = np.mean(np.concatenate(u_pieces)), np.mean(np.concatenate(e_pieces))
    uc, ec = [u - mu for u in u_pieces], [e - me for e in e_pieces]
    den = np.sqrt(sum(u @ u for u in uc) * sum(e @ e for e in ec))
    N = sum(e.size for e in ec)
    lags = np.arange(-max_lag, max_lag + 1)

    def at(t):
        return sum((e[t:] @ u[:e.size - t]) if t >= 0 else (e[:e.size + t] @ u[-t:])
                   for u, e in zip(uc, ec) if e.size > abs(t)) / den

    ccf = np.array([at(int(t)) for t in lags])
    q = float(N * np.sum(ccf[max_lag:] ** 2))
    return {"lags": lags, "ccf": ccf, "band": float(stats.norm.ppf(1 - alpha / 2) / np.sqrt(N)),
            "q_stat": q, "dof": max_lag + 1, "p_value": float(stats.chi2.sf(q, max_lag + 1))}
