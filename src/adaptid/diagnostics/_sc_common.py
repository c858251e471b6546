"""Shared validation and linear algebra of the structural-change tests."""

from __future__ import annotations

import numpy as np

from .._validation import as_float_array, param_error


def regression_data(X, y, *, min_rows: int | None = None):
    """Validate (X, y); X (N, n) or (N,) taken as one column; y (N,)."""
    X = as_float_array(X, "X", ndim=(1, 2))
    if X.ndim == 1:
        X = np.ascontiguousarray(X[:, None])
    N, n = X.shape
    if n < 1:
        raise param_error("X", "of shape (N, n) with n >= 1", f"<shape {X.shape}>")
    need = n + 1 if min_rows is None else min_rows
    if N < need:
        raise param_error("X", f"at least {need} rows long", f"<shape {X.shape}>")
    y = as_float_array(y, "y", shape=(N,))
    if np.linalg.matrix_rank(X) < n:
        raise param_error("X", f"of full column rank {n}", "<a rank-deficient matrix>")
    return X, y


def ols(X, y):
    """Least-squares coefficients and residuals (LAPACK gelsd, no normal equations)."""
    theta = np.linalg.lstsq(X, y, rcond=None)[0]
    return theta, y - X @ theta


def root_from_factor(R):
    """Symmetric square roots of RᵀR for a stack R (..., n, n), as strucchange's ``root.matrix``.

    strucchange takes the eigen-decomposition of the cross-product XᵀX; the
    same matrix is formed here from its triangular factor (XᵀX = RᵀR).
    """
    G = np.swapaxes(R, -1, -2) @ R
    lam, V = np.linalg.eigh(G)
    lam = np.clip(lam, 0.0, None)
    return (V * np.sqrt(lam)[..., None, :]) @ np.swapaxes(V, -1, -2)


def new_axes(ax=None):
    """``ax``, or the Axes of a new constrained-layout Figure (room for an outside legend)."""
    if ax is not None:
        return ax
    plt = lazy_pyplot()
    _, ax = plt.subplots(layout="constrained")
    return ax


def outside_legend(ax, *more):
    """One legend right of the plot (it never covers the data); repeated labels once.

    ``more``: further Axes sharing the area (a ``twinx``) whose lines join the legend.
    """
    handles, labels = [], []
    for a in (ax, *more):
        for h, lab in zip(*a.get_legend_handles_labels()):
            if lab not in labels:
                handles.append(h)
                labels.append(lab)
    ax.legend(handles, labels, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0,
              fontsize="small")


def lazy_pyplot():
    try:
        import matplotlib.pyplot as plt
    except ImportError as err:  # pragma: no cover - depends on the install
        raise ImportError("plotting needs matplotlib: pip install 'adaptid[plot]'") from err
    return plt
