r"""compare, resid and select_order on records with several outputs: the numbers.

:func:`adaptid.models.compare`, :func:`~adaptid.models.resid` and
:func:`~adaptid.models.select_order` hand a record with several outputs to
these functions: the same numbers as for one output, computed for each
output; the callers wrap them in one result per output (a tuple), so each
result keeps its one-output meaning, table and figure.
"""

from __future__ import annotations

import itertools

import numpy as np

from ..._teststats import cross_correlation, fit_percent, ljung_box
from ..._validation import check_int, check_scalar, param_error

__all__ = ["compare_outputs", "resid_outputs", "select_order_outputs", "fit_start"]


def _outputs_of(model, yh, p):
    Y = np.asarray(yh, dtype=np.float64)
    Y = Y.reshape(Y.shape[0], -1)
    if Y.shape[1] != p:
        raise param_error("models", f"models with {p} outputs (as the record)",
                          f"<{type(model).__name__} with {Y.shape[1]} outputs>")
    return Y


def compare_outputs(data, models, *, k):
    """Per output: ``dict(fit, y_hat, y, y_name)`` for a CompareResult (one per output)."""
    Y, U, p = data.outputs, data.inputs, data.n_outputs
    outs = []
    for m in models:
        yh = m.simulate(U) if k is None else m.predict((Y, U), k=k)
        outs.append(_outputs_of(m, yh, p))
    res = []
    for i, name in enumerate(data.y_names):
        if not np.ptp(Y[:, i]) > 0:
            raise param_error("data", "a record whose outputs are not constant",
                              f"<a constant output {name}>")
        fit = np.array([fit_percent(Y[:, i], o[:, i]) for o in outs])
        res.append(dict(fit=fit, y_hat=[o[:, i] for o in outs], y=Y[:, i].copy(), y_name=name))
    return res


def resid_outputs(data, model, *, max_lag, alpha, start):
    """Per output: the keyword arguments of a ResidResult (one per output).

    Each output's one-step prediction errors (the model's joint predictor),
    their autocorrelation and their cross-correlation with every input.
    """
    alpha = check_scalar(alpha, "alpha", low=0.0, high=1.0, low_open=True, high_open=True)
    if start is None:
        idx = getattr(model, "index", None)
        start = int(np.min(idx)) if idx is not None and np.size(idx) else 0
    start = check_int(start, "start", low=0, high=len(data) - 3)
    N = len(data) - start
    max_lag = check_int(max_lag, "max_lag", low=1, high=N - 1)
    Y, U = data.outputs, data.inputs
    E = (Y - _outputs_of(model, model.predict((Y, U), k=1), data.n_outputs))[start:]
    Us = U[start:]
    keep = [j for j in range(data.n_inputs) if np.ptp(Us[:, j]) > 0]
    res = []
    for i, name in enumerate(data.y_names):
        e = E[:, i]
        if not np.ptp(e) > 0:
            raise param_error("model", "a model whose residuals on data are not constant",
                              f"<constant residuals of {name}>")
        res.append(dict(e=e, start=start, autocorrelation=ljung_box(e, max_lag, alpha),
                        cross_correlation=[cross_correlation(Us[:, j], e, max_lag, alpha)
                                           for j in keep],
                        alpha=alpha, y_name=name, u_names=tuple(data.u_names[j] for j in keep)))
    return res


def fit_start(order, ny, nu):
    """(na, nb, nk) matrices of ``order`` and their first row s (for ``OrderSelection.model``)."""
    from ._orders import resolve

    o = resolve(*(np.asarray(v) for v in order), ny, nu)
    return (o.na, o.nb, o.nk), o.start


def _structure_rows(Y, U, a, b, k, s):
    """Shared regressors of the structure na = a, nb = b, nk = k in every entry."""
    from ._orders import equation_rows, resolve

    o = resolve(a, b, k, Y.shape[1], U.shape[1])
    return equation_rows(Y, U, o, 0, s)


def select_order_outputs(data, nas, nbs, nks, *, criterion, validation):
    r"""``arxstruc`` per output: each output's row of the order matrices from a grid.

    A structure (a, b, k) of the grid ``na × nb × nk`` sets every entry of
    an equation's rows: na[i, :] = a, nb[i, :] = b, nk[i, :] = k. Its
    regressors are then the same for every output, so one QR gives every
    output's fit over the common rows :math:`k = s … N − 1`,
    :math:`s = \max(\max n_a, \max n_k + \max n_b - 1)`. Per output, with
    n rows, d = a·ny + b·nu parameters and the loss :math:`V_i` (SSR/n;
    with ``validation``, the mean square of the one-step errors on it):
    AIC = n log V_i + 2d + n(log 2π + 1), FPE = V_i(1 + d/n)/(1 − d/n).
    For each output the structure with the smallest criterion gives row i
    of the result's (na, nb, nk).

    Returns
    -------
    (dict of ndarray, tuple of three int matrices, int)
        The table's columns (with ``output``), the best (na, nb, nk) and s.
    """
    from ..._lstsq import lstsq
    from ._data import records

    if criterion == "validation":
        raise param_error("criterion", "'aic', 'fpe' or 'loss' (with validation: the "
                          "validation loss) for a record with several outputs", criterion)
    Y, U, p = data.outputs, data.inputs, data.n_outputs
    s = max(max(nas), max(nks) + max(nbs) - 1)
    d_max = max(nas) * p + max(nbs) * U.shape[1]
    if Y.shape[0] - s <= d_max:
        raise param_error("data", f"longer than the largest structure needs (> {s + d_max} "
                          "samples)", f"<{Y.shape[0]} samples>")
    val = None
    if validation is not None:
        ex = records(validation, name="validation")
        val = (ex.Y[0], ex.U[0])
        if val[0].shape[0] <= s or val[0].shape[1] != p:
            raise param_error("validation", f"a record of {p} outputs longer than {s} samples",
                              f"<shape {val[0].shape}>")
    rows = {key: [] for key in ("output", "na", "nb", "nk", "n_params", "loss", "aic", "fpe")}
    n = Y.shape[0] - s
    for a, b, k in itertools.product(nas, nbs, nks):
        res = lstsq(_structure_rows(Y, U, a, b, k, s), Y[s:])
        E = np.asarray(res.residuals).reshape(n, p)
        d = a * p + b * U.shape[1]
        V = (E * E).mean(axis=0)
        loss = V
        if val is not None:
            Ev = val[0][s:] - _structure_rows(*val, a, b, k, s) @ np.asarray(res.theta).reshape(-1, p)
            loss = (Ev * Ev).mean(axis=0)
        aic = n * np.log(V) + 2 * d + n * (np.log(2 * np.pi) + 1.0)
        fpe = V * (1 + d / n) / (1 - d / n)
        for i in range(p):
            for key, v in zip(rows, (data.y_names[i], a, b, k, d, loss[i], aic[i], fpe[i])):
                rows[key].append(v)
    table = {key: np.asarray(v) for key, v in rows.items()}
    best = [np.zeros((p, p), int), np.zeros((p, U.shape[1]), int), np.zeros((p, U.shape[1]), int)]
    for i, name in enumerate(data.y_names):
        sel = np.flatnonzero(table["output"] == name)
        j = sel[int(np.argmin(table[criterion][sel]))]
        for M, key in zip(best, ("na", "nb", "nk")):
            M[i] = table[key][j]
    return table, tuple(best), s
