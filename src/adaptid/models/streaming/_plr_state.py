"""Rebuilding a streaming pseudo-linear model from its state (``from_state``)."""

from __future__ import annotations

import numpy as np

from ..._validation import param_error
from ._arx import _METHODS

__all__ = ["restore"]

#: arrays stored as a zero-padded square (a window buffer, the diffuse state): a state
#: file bounds every side of an array by one size
_PACKED = ("Bphi", "By", "dif")


def _packed(a):
    """``a`` raveled into the smallest zero-padded square."""
    flat = a.ravel()
    c = max(1, int(np.ceil(np.sqrt(flat.size))))
    while c * c < flat.size:
        c += 1
    out = np.zeros(c * c)
    out[: flat.size] = flat
    return out.reshape(c, c)


def _header(cls, state):
    """The dict's kind and format, and its options, inner estimator and arrays."""
    from ...estimators._statefile import estimator_from_state

    cls._check_state(state)
    try:
        o = dict(state["options"])
        inner = estimator_from_state(state["inner"])
        arrays = {k: np.array(state[k], dtype=np.float64) for k in cls._STATE_FILE_ARRAYS}
        obj = cls._build(o)
        counts = (o["count"], o["k"], o.get("since", o["count"]))  # (states before restarts)
    except KeyError as err:
        raise param_error("state", "a complete dict from get_state()",
                          f"<missing key {err.args[0]!r}>") from None
    return obj, inner, arrays, counts


def _check_inner(obj, inner):
    kind = type(inner).spec.method
    want = _METHODS[obj.method]
    if inner.n_params != obj.n_params or not (kind == want or (want == "rls" and
                                                               kind == "window")):
        raise param_error("state['inner']", f"the {want} estimator of {obj.n_params} "
                          f"parameters of method={obj.method!r}",
                          f"<a {kind} estimator of {inner.n_params} parameters>")


def _check_factor(U, D):
    n = D.shape[0]
    if not (np.all(np.diag(U) == 1.0) and np.all(U[np.tril_indices(n, -1)] == 0.0)
            and np.all(D > 0.0)):
        raise param_error("state['U'], state['D']", "the U-D factors of P (U unit upper "
                          "triangular, D > 0)", "<other arrays>")


def restore(cls, state):
    """``cls.from_state(state)``: check the dict, rebuild, put the arrays back."""
    obj, inner, arrays, (count, k, since) = _header(cls, state)
    _check_inner(obj, inner)
    obj._est = inner
    obj._configure()
    obj.reset()
    mine = {}
    for key, a in arrays.items():
        like = getattr(obj, "_" + key)
        if key in _PACKED:  # a zero-padded square
            flat = a.ravel()
            a = (flat[: like.size].reshape(like.shape)
                 if a.ndim == 2 and a.shape[0] == a.shape[1] and flat.size >= like.size
                 and not np.any(flat[like.size:]) else a)
        elif a.size == like.size:
            a = a.reshape(like.shape)
        if a.shape != like.shape or not np.isfinite(a).all():
            raise param_error(f"state[{key!r}]", f"finite, of shape {like.shape}",
                              f"<shape {arrays[key].shape}>")
        mine[key] = a
    if not obj._opts[9]:
        _check_factor(mine["U"], mine["D"])
    if type(count) is not int or type(k) is not int or not 0 <= k <= count:
        raise param_error("state['options']", "counts 'count' >= 'k' >= 0",
                          f"<{count!r}, {k!r}>")
    if type(since) is not int or not 0 <= since <= count:
        raise param_error("state['options']['since']", "an integer in [0, count]", since)
    for key, a in mine.items():
        setattr(obj, "_" + key, a)
    obj._count, obj._k, obj._since = count, k, since
    return obj
