r"""Orders, parameter layout and regressors of the MIMO ARX model.

Equation i of :math:`A(q)y_k = B(q)u_k + e_k` (MATLAB's ``arx``
convention, :math:`A(q) = I + A_1q^{-1} + \dots`) is

.. math::

    y^{(i)}_k + \sum_{j=1}^{n_y}\sum_{l=1}^{n_a[i,j]} a^{(ij)}_l\,y^{(j)}_{k-l}
      = \sum_{j=1}^{n_u}\sum_{l=0}^{n_b[i,j]-1} b^{(ij)}_l\,u^{(j)}_{k-n_k[i,j]-l} + e^{(i)}_k,

so :math:`y^{(i)}_k = \varphi^{(i)T}_k\theta_i + e^{(i)}_k` with the
columns of :math:`\varphi^{(i)}` in the order of :func:`layout`: the
output lags :math:`-y^{(j)}_{k-l}` output by output (j = 1 … ny, l = 1 …
na[i, j]), then the input lags :math:`u^{(j)}_{k-n_k-l}` input by input.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..._validation import check_int, param_error

__all__ = ["Orders", "check_spec", "resolve", "layout", "equation_rows", "stack_rows"]


def check_spec(value, name):
    """Validate an order spec (integer, or array of integers >= 0); return it as an int array."""
    arr = np.asarray(value)
    if arr.ndim > 2:
        raise param_error(name, "an integer or an array of integers of at most 2 dimensions",
                          f"<an array of shape {arr.shape}>")
    if arr.size == 0:
        raise param_error(name, "a non-empty integer or array of integers", "<an empty array>")
    flat = arr.ravel()
    for i, v in enumerate(flat):
        check_int(v.item() if hasattr(v, "item") else v,
                  name if arr.ndim == 0 else f"{name}[{np.unravel_index(i, arr.shape)}]", low=0)
    return arr.astype(np.int64)


def _broadcast(spec, shape, name, what):
    try:
        return np.ascontiguousarray(np.broadcast_to(spec, shape), dtype=np.int64)
    except ValueError:
        raise param_error(name, f"an integer or an array of shape {shape} ({what})",
                          f"<an array of shape {spec.shape}>") from None


@dataclass(frozen=True)
class Orders:
    """The three order matrices: na (ny, ny), nb (ny, nu), nk (ny, nu)."""

    na: np.ndarray
    nb: np.ndarray
    nk: np.ndarray

    @property
    def ny(self) -> int:
        return self.na.shape[0]

    @property
    def nu(self) -> int:
        return self.nb.shape[1]

    @property
    def start(self) -> int:
        r"""s: the largest lag of any equation (inputs with nb = 0 do not count)."""
        lags = [int(self.na.max())]
        used = self.nb > 0
        if used.any():
            lags.append(int((self.nk + self.nb - 1)[used].max()))
        return max(lags)

    @property
    def shared(self) -> bool:
        """True when every equation has the same regressors (identical rows of na, nb, nk)."""
        same = lambda M: bool((M == M[:1]).all())  # noqa: E731
        nk = np.where(self.nb > 0, self.nk, 0)
        return same(self.na) and same(self.nb) and same(nk)

    def n_params(self, i) -> int:
        return int(self.na[i].sum() + self.nb[i].sum())


def resolve(na, nb, nk, ny, nu):
    """The specs broadcast to (ny, ny), (ny, nu), (ny, nu); every equation needs a parameter."""
    o = Orders(_broadcast(na, (ny, ny), "na", "ny × ny"),
               _broadcast(nb, (ny, nu), "nb", "ny × nu"),
               _broadcast(nk, (ny, nu), "nk", "ny × nu"))
    for i in range(ny):
        if o.n_params(i) == 0:
            raise param_error(f"na[{i}], nb[{i}]", "orders with at least one coefficient in "
                              "every equation", "<all zero>")
    return o


def layout(orders, i, y_names, u_names):
    """Columns of equation i: ``[(kind, j, lag, name)]`` with kind "a" (lag l) or "b" (index l).

    Names: ``a{l}_{y_i}_{y_j}`` is the coefficient of :math:`y^{(j)}_{k-l}` in
    the equation of :math:`y^{(i)}`; ``b{l}_{y_i}_{u_j}`` that of
    :math:`u^{(j)}_{k-n_k[i,j]-l}` (l from 0, as the SISO ARX's ``b0``).
    """
    cols = []
    yi = y_names[i]
    for j in range(orders.ny):
        cols += [("a", j, l, f"a{l}_{yi}_{y_names[j]}") for l in range(1, orders.na[i, j] + 1)]
    for j in range(orders.nu):
        cols += [("b", j, l, f"b{l}_{yi}_{u_names[j]}") for l in range(orders.nb[i, j])]
    return cols


def equation_rows(Y, U, orders, i, s):
    r"""Regressors of equation i over ONE experiment: rows k = s … N − 1.

    Parameters
    ----------
    Y : ndarray, shape (N, ny)
    U : ndarray, shape (N, nu)
    orders : Orders
    i : int
    s : int
        First row (the common start of all equations).

    Returns
    -------
    ndarray, shape (N - s, d_i)
        Columns :math:`-y^{(j)}_{k-l}` then :math:`u^{(j)}_{k-n_k-l}` (the
        order of :func:`layout`), built by slicing (no loop over samples).
    """
    N = Y.shape[0]
    cols = []
    for j in range(orders.ny):
        cols += [-Y[s - l: N - l, j] for l in range(1, orders.na[i, j] + 1)]
    for j in range(orders.nu):
        k0 = orders.nk[i, j]
        cols += [U[s - k0 - l: N - k0 - l, j] for l in range(orders.nb[i, j])]
    return np.column_stack(cols) if cols else np.zeros((N - s, 0))


def stack_rows(experiments, orders):
    """Every equation's regressors stacked over the experiments (formed inside each).

    Parameters
    ----------
    experiments : sequence of (Y (N_e, ny), U (N_e, nu))
    orders : Orders

    Returns
    -------
    Phis : list of ndarray, one (n_rows, d_i) per equation
    T : ndarray, shape (n_rows, ny)
        The targets :math:`y_k`.
    index : ndarray of int, shape (n_rows,)
        Sample of each row inside its experiment.
    experiment : ndarray of int, shape (n_rows,)
    """
    s = orders.start
    for e, (Y, _) in enumerate(experiments):
        if Y.shape[0] <= s:
            where = "data" if len(experiments) == 1 else f"data[{e}]"
            raise param_error(where, f"longer than the largest lag s={s} of the orders",
                              f"<{Y.shape[0]} samples>")
    Phis = [np.vstack([equation_rows(Y, U, orders, i, s) for Y, U in experiments])
            for i in range(orders.ny)]
    T = np.vstack([Y[s:] for Y, _ in experiments])
    index = np.concatenate([np.arange(s, Y.shape[0]) for Y, _ in experiments])
    experiment = np.concatenate([np.full(Y.shape[0] - s, e) for e, (Y, _) in enumerate(experiments)])
    return Phis, T, index, experiment
