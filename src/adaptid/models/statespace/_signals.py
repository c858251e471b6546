r"""Signals of the state-space family: experiments in, state recursions out.

The state-space functions accept an :class:`~adaptid.models.IDData`, a
``(y, u)`` pair of arrays, or a list of either (several experiments, kept
apart: nothing is ever formed across the boundary between two of them). A
merged IDData (:meth:`~adaptid.IDData.merge`) counts as its experiments, and
a record with NaN samples is split at each gap into the runs of complete
samples, each a separate experiment (``Experiments.cut`` marks the runs so
made, which a function may drop when they are too short for it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..._validation import as_float_array, param_error
from .._iddata import IDData

__all__ = ["Experiments", "experiments", "recurse", "input_matrix"]


@dataclass(frozen=True)
class Experiments:
    """One or more records with the same signals: ``Y[e]`` (N_e, p), ``U[e]`` (N_e, m)."""

    Y: tuple
    U: tuple
    dt: float
    y_names: tuple
    u_names: tuple
    cut: tuple = ()

    def without_short(self, min_length):
        """These experiments without the runs cut at gaps that are shorter than ``min_length``."""
        if not any(self.cut):
            return self
        keep = [e for e, y in enumerate(self.Y) if not (self.cut[e] and y.shape[0] < min_length)]
        if not keep:
            keep = list(range(len(self.Y)))     # the caller's length check reports it
        return Experiments(tuple(self.Y[e] for e in keep), tuple(self.U[e] for e in keep),
                           self.dt, self.y_names, self.u_names,
                           tuple(self.cut[e] for e in keep))

    @property
    def p(self) -> int:
        return self.Y[0].shape[1]

    @property
    def m(self) -> int:
        return self.U[0].shape[1]

    @property
    def lengths(self) -> tuple:
        return tuple(y.shape[0] for y in self.Y)


def _one(item, name):
    """(Y (N, p), U (N, m), IDData or None) of one experiment."""
    if isinstance(item, IDData):
        return item.outputs, item.inputs, item
    if isinstance(item, tuple) and len(item) == 2:
        Y = as_float_array(getattr(item[0], "to_numpy", lambda: item[0])(), f"{name} y",
                           ndim=(1, 2), allow_nan=True)
        U = as_float_array(getattr(item[1], "to_numpy", lambda: item[1])(), f"{name} u",
                           ndim=(1, 2), allow_nan=True)
        Y, U = Y.reshape(Y.shape[0], -1), U.reshape(U.shape[0], -1)
        if U.shape[0] != Y.shape[0]:
            raise param_error(f"{name} u", f"with N={Y.shape[0]} rows (as y)",
                              f"<{U.shape[0]} rows>")
        return Y, U, None
    raise param_error(name, "an IDData, a (y, u) tuple of arrays or a list of them", item,
                      exc=TypeError)


def experiments(data, name="data", *, min_length=1) -> Experiments:
    """Validate ``data`` (IDData, (y, u) or a list of them) into :class:`Experiments`."""
    from .._segments import split_at_gaps

    items = list(data) if isinstance(data, list) else [data]
    if not items:
        raise param_error(name, "a non-empty list of experiments", "<an empty list>")
    items = [e for it in items for e in (it.experiments if isinstance(it, IDData) else [it])]
    parts, cut = [], []
    for i, it in enumerate(items):
        Y, U, d = _one(it, name if len(items) == 1 else f"{name}[{i}]")
        runs = split_at_gaps(Y, U)
        if not runs:
            raise param_error(name if len(items) == 1 else f"{name}[{i}]",
                              "a record with complete samples", "<only NaN>")
        parts += [(Yr, Ur, d) for Yr, Ur in runs]
        cut += [len(runs) > 1 or Yr.shape[0] < Y.shape[0] for Yr, _ in runs]
    if any(c and Y.shape[0] < min_length for c, (Y, _, _) in zip(cut, parts)):
        keep = [e for e, (Y, _, _) in enumerate(parts) if not cut[e] or Y.shape[0] >= min_length]
        parts, cut = [parts[e] for e in keep] or parts, [cut[e] for e in keep] or cut
    p, m = parts[0][0].shape[1], parts[0][1].shape[1]
    for i, (Y, U, _) in enumerate(parts):
        if (Y.shape[1], U.shape[1]) != (p, m):
            raise param_error(f"{name}[{i}]", f"{p} output(s) and {m} input(s) as the first",
                              f"<{Y.shape[1]} outputs, {U.shape[1]} inputs>")
        if Y.shape[0] < min_length:
            raise param_error(name, f"experiments of at least {min_length} samples",
                              f"<{Y.shape[0]} samples>")
    if m == 0:
        raise param_error(name, "a record with at least one input", "<no inputs>")
    first = next((d for _, _, d in parts if d is not None), None)
    if first is not None:
        dt, yn, un = first.dt, first.y_names, first.u_names
    else:
        dt = 1.0
        yn = ("y",) if p == 1 else tuple(f"y{i + 1}" for i in range(p))
        un = ("u",) if m == 1 else tuple(f"u{i + 1}" for i in range(m))
    return Experiments(tuple(np.ascontiguousarray(Y) for Y, _, _ in parts),
                       tuple(np.ascontiguousarray(U) for _, U, _ in parts), float(dt), yn, un,
                       tuple(cut))


def recurse(A, inj, s0):
    r"""The states :math:`s_{k+1} = A s_k + w_k`, k = 0 … N − 2, from :math:`s_0`.

    Parameters
    ----------
    A : ndarray, shape (n, n)
    inj : ndarray, shape (N, n) or (N, n, c)
        :math:`w_k` (the last row is not used).
    s0 : ndarray, shape (n,) or (n, c)

    Returns
    -------
    ndarray, shape like ``inj``
        Row k is :math:`s_k`.
    """
    # A plain loop of N small matrix products (a compiled kernel can replace it
    # once the kernels' reorganisation has landed; it is not the cost that dominates).
    S = np.empty_like(inj)
    if S.shape[0] == 0:
        return S
    S[0] = s0
    for k in range(S.shape[0] - 1):
        np.matmul(A, S[k], out=S[k + 1])
        S[k + 1] += inj[k]
    return S


def input_matrix(u, m, name="u"):
    """Inputs as (N, m) float64 (an IDData gives its inputs)."""
    if isinstance(u, IDData):
        u = u.inputs
    U = as_float_array(getattr(u, "to_numpy", lambda: u)(), name, ndim=(1, 2))
    U = U.reshape(-1, 1) if U.ndim == 1 else U
    if U.shape[1] != m:
        raise param_error(name, f"an array with {m} input column(s)", f"<shape {np.shape(u)}>")
    return U
