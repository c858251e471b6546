"""The records a MIMO ARX model reads: one or several experiments of (Y, U).

One function turns what the user gives into a list of experiments, each an
(N_e, ny) output and an (N_e, nu) input array; the regressors are formed
inside each (:func:`~._orders.stack_rows`) and stacked. A merged record
(several experiments in one object) plugs in here.
"""

from __future__ import annotations

import numpy as np

from ..._validation import as_float_array, param_error
from .._iddata import IDData

__all__ = ["records", "several_outputs", "one_record", "input_array"]


def _is_pair(obj):
    return isinstance(obj, tuple) and len(obj) == 2 and not np.isscalar(obj[0])


def records(data, u=None, name="data"):
    """An :class:`~adaptid.models.statespace._signals.Experiments` from the one input convention.

    ``data`` is an IDData, a ``(Y, U)`` pair, a list of either (several
    experiments), or the outputs ``Y`` with the inputs ``u`` as a second
    argument.
    """
    from ..statespace._signals import experiments

    if u is not None:
        if isinstance(data, (IDData, list, tuple)):
            raise param_error("u", "None when data is an IDData, a (y, u) pair or a list",
                              "<an array>", exc=TypeError)
        named = any(hasattr(v, "columns") or hasattr(v, "index") for v in (data, u))
        data = IDData(data, u) if named else (data, u)   # pandas: their names and dt
    merged = getattr(data, "experiments", None)
    if isinstance(data, IDData) and isinstance(merged, (list, tuple)):
        data = list(merged)       # a merged IDData: its experiments, kept apart
    return experiments(data, name)


def one_record(data, u, name="data"):
    """(Y, U, names) of a single experiment."""
    ex = records(data, u, name)
    if len(ex.Y) != 1:
        raise param_error(name, "one experiment (call it on each)", f"<{len(ex.Y)} experiments>")
    return ex.Y[0], ex.U[0], ex


def several_outputs(y, u=None):
    """True when a model's ``fit(y, u)`` argument holds more than one output."""
    if isinstance(y, list):
        return bool(y) and several_outputs(y[0])
    if isinstance(y, IDData):
        return y.n_outputs > 1
    if u is None:
        if not _is_pair(y):
            return False      # a DataFrame (its first column the output) or a bare output
        y = y[0]
    arr = getattr(y, "to_numpy", lambda: y)()
    return np.ndim(arr) == 2 and np.shape(arr)[1] > 1


def input_array(u, nu, name="u"):
    """Inputs as (N, nu) float64 (an IDData or a (y, u) pair gives its inputs)."""
    if isinstance(u, IDData):
        u = u.inputs
    elif _is_pair(u):
        u = u[1]
    U = as_float_array(getattr(u, "to_numpy", lambda: u)(), name, ndim=(1, 2))
    U = U.reshape(-1, 1) if U.ndim == 1 else U
    if U.shape[1] != nu:
        raise param_error(name, f"an array with {nu} input column(s) as at fit time",
                          f"<{U.shape[1]} columns>")
    return U
