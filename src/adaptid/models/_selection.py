"""Order selection (MATLAB's ``arxstruc``/``selstruc``): :func:`select_order`."""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from .._teststats import fit_percent
from .._validation import check_choice, check_int, param_error
from ._segments import record_runs
from ._workflow import _as_iddata, _single_output

__all__ = ["OrderSelection", "select_order"]


@dataclass(frozen=True, eq=False)
class OrderSelection:
    r"""Result of :func:`select_order`.

    Attributes
    ----------
    table : pandas.DataFrame or dict of ndarray
        One row per structure: ``na``, ``nb``, ``nk``, ``n_params``,
        ``loss`` (MATLAB's ``arxstruc`` loss: with a validation record the
        validation loss :math:`V = \frac1{N_v}\sum e_k^2` of the one-step
        prediction errors on it, otherwise the estimation loss V = SSR/N on
        the common rows), ``aic``, ``fpe`` (from the estimation loss, the
        definitions of :meth:`ARX.summary`) and ``fit_validation``
        (simulation fit % on the validation record, NaN without one); a
        DataFrame when pandas is installed.
    best : tuple of int
        (na, nb, nk) of the chosen structure (three matrices, one row per
        output, for a record with several outputs; the table then has a
        column ``output``).
    criterion : str
    start : int
        s, the common first row of the estimation record.
    """

    table: object
    best: tuple
    criterion: str
    start: int = 0
    data: object = field(default=None, repr=False)

    def model(self, order=None):
        r"""The structure fitted on the table's rows, as :class:`ARX`.

        ``ARX(na, nb, nk).fit(data[s - s_own:])`` with s the common first
        row and :math:`s_{own} = \max(n_a, n_k + n_b - 1)`: the same rows
        k = s … N − 1 as the table, so its :meth:`~ARX.summary` reports the
        table's ``aic``, ``fpe`` and estimation loss exactly. (``ARX(...).fit(data)``
        on the whole record uses its own, longer, rows k = s_own … N − 1,
        hence a different N in its AIC.)

        Parameters
        ----------
        order : tuple of int, optional
            (na, nb, nk); default :attr:`best`.

        Returns
        -------
        ARX
        """
        from ._arx import ARX

        if self.data.n_outputs > 1:     # order matrices, one row per output
            from .mimo._workflow import fit_start

            (na, nb, nk), own = fit_start(self.best if order is None else order,
                                          self.data.n_outputs, self.data.n_inputs)
            return ARX(na, nb, nk).fit(self.data[self.start - own:])
        na, nb, nk = self.best if order is None else tuple(int(v) for v in order)
        own = max(na, nk + nb - 1)
        parts = [e[self.start - own:] for e in self.data.experiments]   # each experiment's rows
        return ARX(na, nb, nk).fit(parts[0].merge(*parts[1:]))

    def __repr__(self):
        return f"OrderSelection(best (na, nb, nk)={self.best}, criterion={self.criterion!r})"

    def _repr_html_(self):
        t = self.table
        inner = t.to_html() if hasattr(t, "to_html") else ""
        return f"<p>best (na, nb, nk) = {self.best} by {self.criterion}</p>{inner}"


def _orders(value, name, low):
    vals = [value] if np.ndim(value) == 0 else list(np.ravel(value))
    if not vals:
        raise param_error(name, "an integer or a non-empty sequence of integers", value)
    return sorted({check_int(v, name, low=low) for v in vals})


def select_order(data, u=None, *, na, nb, nk=1, criterion="aic", validation=None):
    r"""ARX order search: MATLAB's ``arxstruc`` and ``selstruc``.

    Every structure (na, nb, nk) of the grid ``na × nb × nk`` is fitted by
    least squares on the estimation record on **one shared regressor
    matrix**: the columns
    :math:`-y_{k-1}, \dots, -y_{k-\max n_a}, u_{k-\min n_k}, \dots,
    u_{k-\max n_k-\max n_b+1}` are built once over the common rows
    :math:`k = s, \dots, N-1`, :math:`s = \max(\max n_a, \max n_k + \max n_b - 1)`,
    and each structure is one QR (:func:`adaptid.lstsq`) of its columns,
    so every loss is over the same samples and comparable.

    ``loss`` is ``arxstruc``'s: with ``validation``, the **validation
    loss** :math:`V_v = \frac1{N_v}\sum_k \varepsilon_k^2`, the one-step
    prediction errors :math:`\varepsilon_k = y_k - \varphi_k^T\hat\theta`
    of the model fitted on ``data``, over the validation rows
    :math:`k = s, \dots, N_v - 1` (:math:`N_v` of them, the same for every
    structure); without it, the estimation loss V = SSR/(N − s).

    AIC and FPE are those of :meth:`ARX.summary` (one definition in
    adaptid), from the estimation loss V = SSR/n over the n = N − s common
    rows and d = na + nb:

    .. math::

        \mathrm{AIC} = -2\ell + 2d = n\log V + 2d + n(\log 2\pi + 1),\qquad
        \mathrm{FPE} = V\,\frac{1 + d/n}{1 - d/n}

    (ℓ the Gaussian log-likelihood at σ² = V; Ljung 1999, sec. 16.4).
    ``result.model()`` fits the chosen structure on exactly these rows,
    and its ``summary()`` reports the same AIC; ``ARX(*best).fit(data)``
    uses its own, longer, rows and so a larger n (its AIC differs by that
    alone). With ``validation`` the simulation fit % on it (zero initial
    conditions) is reported too.

    Parameters
    ----------
    data : IDData, (y, u) tuple, DataFrame (output column first), or y
        Estimation record, one output and one input; arrays may come as
        two arguments ``select_order(y, u, ...)`` (the one input
        convention of the models' ``fit``). A merged record gives the
        rows of each experiment (from its sample s on), stacked; rows that
        touch a NaN are left out.
    u : array_like or pandas, optional
        The input when ``data`` is the output.
    na, nb, nk : int or sequence of int
        The grid (na ≥ 0, nb ≥ 1, nk ≥ 0).
    criterion : {"aic", "fpe", "loss", "validation"}
        The smallest AIC, FPE or ``loss`` (with ``validation``, MATLAB's
        ``selstruc(V, 0)``: the smallest validation loss), or the largest
        validation simulation fit.
    validation : IDData, (y, u) or DataFrame, optional
        Required by ``criterion="validation"``. Longer than s samples.

    Returns
    -------
    OrderSelection
        ``table`` (DataFrame when pandas is there), ``best`` = (na, nb, nk)
        and ``model()``. A record with several outputs selects each
        output's row of the order matrices (``best`` = three matrices; see
        :func:`adaptid.models.mimo._workflow.select_order_outputs`).

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import lfilter
    >>> from adaptid.models import select_order
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal(2000)
    >>> e = 0.05 * rng.standard_normal(2000)
    >>> y = lfilter([0, 0, 1.0, 0.5], [1, -1.2, 0.5], u) + lfilter([1], [1, -1.2, 0.5], e)
    >>> select_order((y, u), na=[1, 2, 3], nb=[1, 2, 3], nk=[1, 2, 3]).best
    (2, 2, 2)
    """
    from .._lstsq import lstsq

    data = _as_iddata(data, "data", u)
    if data.n_outputs > 1:      # per output (adaptid.models.mimo)
        from .mimo._workflow import select_order_outputs

        check_choice(criterion, "criterion", ("aic", "fpe", "loss", "validation"))
        table, best, s = select_order_outputs(data, _orders(na, "na", 0), _orders(nb, "nb", 1),
                                              _orders(nk, "nk", 0), criterion=criterion,
                                              validation=validation)
        return OrderSelection(table=_frame(table), best=best, criterion=criterion, start=s,
                              data=data)
    _single_output(data)
    if data.n_inputs != 1:
        raise param_error("data", "a record with one input", f"<{data.n_inputs} inputs>")
    criterion = check_choice(criterion, "criterion", ("aic", "fpe", "loss", "validation"))
    nas, nbs, nks = _orders(na, "na", 0), _orders(nb, "nb", 1), _orders(nk, "nk", 0)
    if criterion == "validation" and validation is None:
        raise param_error("validation", "a record when criterion='validation'", None)
    val = None if validation is None else _as_iddata(validation, "validation")
    if val is not None:
        _single_output(val, "validation")
        if val.n_inputs != 1:
            raise param_error("validation", "a record with one input", f"<{val.n_inputs} inputs>")
    N = min(len(e) for e in data.experiments)
    na_max, nk_min, ulag_max = max(nas), min(nks), max(nks) + max(nbs) - 1
    s = max(na_max, ulag_max)
    if N - s <= max(nas) + max(nbs):
        need = s + na_max + max(nbs)
        raise param_error("data", f"longer than the largest structure needs (> {need} samples)",
                          f"<{N} samples>")
    if val is not None and min(len(e) for e in val.experiments) <= s:
        raise param_error("validation", f"longer than the largest lag (> {s} samples)",
                          f"<{len(val)} samples>")

    def shared(rec):
        """The shared regressor matrix: -y lags 1..na_max, then u lags nk_min..ulag_max,
        rows inside each experiment, those touching a NaN left out."""
        blocks = []
        for e in rec.experiments:
            y, u = e.y, e.u
            rows = np.arange(s, y.size)
            Y_cols = (np.column_stack([-y[rows - j] for j in range(1, na_max + 1)]) if na_max
                      else np.zeros((rows.size, 0)))
            U_cols = np.column_stack([u[rows - j] for j in range(nk_min, ulag_max + 1)])
            keep = np.isfinite(Y_cols).all(axis=1) & np.isfinite(U_cols).all(axis=1) \
                & np.isfinite(y[rows])
            blocks.append((Y_cols[keep], U_cols[keep], y[rows][keep]))
        return tuple(np.concatenate([b[j] for b in blocks]) for j in range(3))

    Y_cols, U_cols, target = shared(data)
    if val is not None:
        Yv_cols, Uv_cols, target_v = shared(val)
    n_rows = target.size
    out = {key: [] for key in ("na", "nb", "nk", "n_params", "loss", "aic", "fpe", "fit_validation")}
    for a, b, k in itertools.product(nas, nbs, nks):
        cols = np.hstack([Y_cols[:, :a], U_cols[:, k - nk_min: k - nk_min + b]])
        res = lstsq(cols, target)
        d = a + b
        V = float(res.residuals @ res.residuals) / n_rows
        aic = n_rows * np.log(V) + 2 * d + n_rows * (np.log(2 * np.pi) + 1.0)
        fpe = V * (1 + d / n_rows) / (1 - d / n_rows)
        fv, loss = np.nan, V
        if val is not None:
            from scipy.signal import lfilter

            th = np.asarray(res.theta)
            e_v = target_v - np.hstack([Yv_cols[:, :a], Uv_cols[:, k - nk_min: k - nk_min + b]]) @ th
            loss = float(e_v @ e_v) / e_v.size
            A = np.concatenate([[1.0], th[:a]])
            B = np.concatenate([np.zeros(k), th[a:]])
            sim = np.full(len(val), np.nan)
            for p, q in record_runs(val):            # each experiment, restarted after gaps
                sim[p:q] = lfilter(B, A, val.u[p:q])
            ok = np.isfinite(sim) & np.isfinite(val.y)
            fv = fit_percent(val.y[ok], sim[ok])
        for key, v in zip(out, (a, b, k, d, loss, aic, fpe, fv)):
            out[key].append(v)
    table = {key: np.asarray(v) for key, v in out.items()}
    score = {"aic": table["aic"], "fpe": table["fpe"], "loss": table["loss"],
             "validation": -table["fit_validation"]}[criterion]
    if criterion == "validation" and not np.isfinite(score).any():
        raise param_error("validation", "a record on which some structure's simulation is finite",
                          "<no finite fit>")
    i = int(np.nanargmin(score))
    best = (int(table["na"][i]), int(table["nb"][i]), int(table["nk"][i]))
    return OrderSelection(table=_frame(table), best=best, criterion=criterion, start=s, data=data)


def _frame(table):
    """The table as a DataFrame when pandas is there."""
    try:
        import pandas as pd
    except ImportError:  # pragma: no cover - pandas is optional
        return table
    return pd.DataFrame(table)
