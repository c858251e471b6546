r"""Piecewise polynomial least-squares fit with continuity constraints."""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg as sla

from .._validation import as_float_array, check_int, param_error
from ._linalg import RankProblem, cls_qr

__all__ = ["PiecewisePolynomial", "piecewise_polyfit"]


class PiecewisePolynomial:
    r"""A piecewise polynomial: one polynomial per interval between knots.

    On interval ``i`` (``knots[i] <= x < knots[i+1]``, the last interval
    closed) the value is

    .. math::

        p_i(x) = \sum_{j=0}^{\text{degree}} c_{ij} (x - t_i)^j ,

    with ``c = coefficients`` and ``t = knots``: ascending powers of the
    distance to the interval's left knot (local coefficients are well
    conditioned; :meth:`to_ppoly` converts to SciPy's convention). Points
    left of the first knot or right of the last one are extrapolated with
    the end polynomials.

    Parameters
    ----------
    knots : array_like, shape (K + 1,)
        Strictly increasing break points, both end points included.
    coefficients : array_like, shape (K, degree + 1)
        Local coefficients, ascending powers.
    continuity : int, optional
        Highest derivative that is continuous at the interior knots (−1:
        none), recorded for information.
    rss : float, optional
        Residual sum of squares of the fit that produced the object.

    Attributes
    ----------
    knots : ndarray, shape (K + 1,)
    coefficients : ndarray, shape (K, degree + 1)
    degree : int
    continuity : int or None
    rss : float or None
    """

    def __init__(self, knots, coefficients, continuity=None, *, rss=None):
        knots = as_float_array(knots, "knots", ndim=1)
        if knots.shape[0] < 2 or np.any(np.diff(knots) <= 0):
            raise param_error("knots", "strictly increasing with at least 2 entries", knots)
        coefficients = as_float_array(coefficients, "coefficients", ndim=2)
        if coefficients.shape[0] != knots.shape[0] - 1 or coefficients.shape[1] < 1:
            raise param_error("coefficients", f"of shape ({knots.shape[0] - 1}, degree + 1)",
                              f"<shape {coefficients.shape}>")
        self.knots = knots
        self.coefficients = coefficients
        self.continuity = None if continuity is None else int(continuity)
        self.rss = None if rss is None else float(rss)

    @property
    def degree(self) -> int:
        return self.coefficients.shape[1] - 1

    def __call__(self, x, nu: int = 0) -> np.ndarray:
        """Evaluate the ``nu``-th derivative at ``x`` (any shape)."""
        nu = check_int(nu, "nu", low=0)
        if nu:
            return self.derivative(nu)(x)
        x = as_float_array(x, "x", finite=False)
        K = self.coefficients.shape[0]
        idx = np.clip(np.searchsorted(self.knots, x, side="right") - 1, 0, K - 1)
        t = x - self.knots[idx]
        c = self.coefficients[idx]
        out = c[..., -1].copy()
        for j in range(self.degree - 1, -1, -1):  # Horner
            out = out * t + c[..., j]
        return out

    def derivative(self, k: int = 1) -> "PiecewisePolynomial":
        """The ``k``-th derivative, as a piecewise polynomial of degree ``degree − k``."""
        k = check_int(k, "k", low=0)
        if k == 0:
            return PiecewisePolynomial(self.knots, self.coefficients.copy(), self.continuity)
        deg = self.degree
        if k > deg:
            coef = np.zeros((self.coefficients.shape[0], 1))
        else:
            j = np.arange(deg - k + 1)
            factor = np.array([math.perm(i + k, k) for i in j], dtype=float)
            coef = self.coefficients[:, k:] * factor
        cont = None if self.continuity is None else max(self.continuity - k, -1)
        return PiecewisePolynomial(self.knots, coef, cont)

    def to_ppoly(self):
        """The same function as a :class:`scipy.interpolate.PPoly`."""
        from scipy.interpolate import PPoly
        return PPoly(self.coefficients[:, ::-1].T.copy(), self.knots)

    def __repr__(self) -> str:
        kn = np.array2string(self.knots, precision=4, separator=", ") \
            if self.knots.size <= 8 else f"<{self.knots.size} knots>"
        rss = "" if self.rss is None else f", rss={self.rss:.6g}"
        return (f"PiecewisePolynomial(degree={self.degree}, continuity={self.continuity}, "
                f"intervals={self.coefficients.shape[0]}, knots={kn}{rss})")


def piecewise_polyfit(x, y, knots, degree, continuity) -> PiecewisePolynomial:
    r"""Least-squares piecewise polynomial with continuous derivatives at the knots.

    .. math::

        \min \sum_k \big(p(x_k) - y_k\big)^2 \quad\text{s.t.}\quad
        p_{i-1}^{(r)}(t_i) = p_i^{(r)}(t_i), \quad r = 0, \dots, c,\;
        i = 1, \dots, K - 1,

    one polynomial :math:`p_i` of degree ``degree`` on each interval
    :math:`[t_i, t_{i+1}]`, solved exactly as a constrained least-squares
    problem by QR (:func:`constrained_lstsq`). With ``degree=3`` and
    ``continuity=2`` the result is the least-squares cubic spline with these
    knots (:func:`scipy.interpolate.make_lsq_spline`); ``continuity=1`` is the
    reference's value-and-slope fit.

    Parameters
    ----------
    x : array_like, shape (N,)
        Abscissae, inside ``[knots[0], knots[-1]]``. A point on an interior
        knot belongs to the interval on its right.
    y : array_like, shape (N,)
        Data.
    knots : array_like, shape (K + 1,)
        Strictly increasing break points including both end points.
    degree : int
        Degree of each polynomial (≥ 0).
    continuity : int
        Derivatives ``0..continuity`` are equal at each interior knot;
        ``-1`` fits the intervals independently; at most ``degree``.

    Returns
    -------
    PiecewisePolynomial
        Callable, with ``.coefficients`` (K, degree + 1) in local ascending
        powers, ``.knots``, ``.derivative(k)`` and ``.rss``.

    Raises
    ------
    ValueError
        On bad shapes or values, points outside the knots, or too few points
        to determine the polynomials.

    Notes
    -----
    Each interval's polynomial is built in the scaled variable
    :math:`s = (x - t_i)/(t_{i+1} - t_i) \in [0, 1]` (well-conditioned
    Vandermonde blocks), each block is compressed by its own QR
    factorisation, and the continuity rows are scaled by the mean
    neighbouring interval length to the power ``r``. Source: Boyd &
    Vandenberghe (2018), §16.1.1 "Piecewise-polynomial fitting"
    (two cubics with equal value and slope at the joint; the example
    ``y = x³ − x + 0.4/(1 + 25x²)`` of the tests).

    References
    ----------
    S. Boyd and L. Vandenberghe, *Introduction to Applied Linear Algebra*,
    Cambridge University Press, 2018, §16.1. :doi:`10.1017/9781108583664`

    Examples
    --------
    >>> import numpy as np
    >>> from adaptid.constrained import piecewise_polyfit
    >>> x = np.linspace(-1, 1, 101); y = np.abs(x)
    >>> p = piecewise_polyfit(x, y, [-1, 0, 1], degree=1, continuity=0)
    >>> bool(np.allclose(p(x), y))
    True
    """
    x = as_float_array(x, "x", ndim=1)
    N = x.shape[0]
    y = as_float_array(y, "y", shape=(N,))
    knots = as_float_array(knots, "knots", ndim=1)
    if knots.shape[0] < 2 or np.any(np.diff(knots) <= 0):
        raise param_error("knots", "strictly increasing with at least 2 entries", knots)
    degree = check_int(degree, "degree", low=0, high=50)
    continuity = check_int(continuity, "continuity", low=-1, high=degree)
    if N == 0:
        raise param_error("x", "non-empty", x)
    if x.min() < knots[0] or x.max() > knots[-1]:
        raise param_error("x", f"inside [knots[0], knots[-1]] = [{knots[0]:g}, {knots[-1]:g}]",
                          f"<values in [{x.min():g}, {x.max():g}]>")
    K = knots.shape[0] - 1
    nb = degree + 1
    h = np.diff(knots)
    idx = np.clip(np.searchsorted(knots, x, side="right") - 1, 0, K - 1)
    s = (x - knots[idx]) / h[idx]
    V = s[:, None] ** np.arange(nb)

    # Block-diagonal objective, each block compressed by its own QR.
    order = np.argsort(idx, kind="stable")
    bounds = np.concatenate([[0], np.cumsum(np.bincount(idx, minlength=K))])
    row_blocks, rhs_blocks, col_blocks = [], [], []
    for i in range(K):
        rows = order[bounds[i]:bounds[i + 1]]
        if rows.size == 0:
            continue
        Vi, yi = V[rows], y[rows]
        if rows.size > nb:
            Qi, Ri = sla.qr(Vi, mode="economic")
            Vi, yi = Ri, Qi.T @ yi
        row_blocks.append(Vi)
        rhs_blocks.append(yi)
        col_blocks.append(np.full(Vi.shape[0], i))
    n_rows = sum(r.shape[0] for r in row_blocks)
    A = np.zeros((n_rows, K * nb))
    r0 = 0
    for Vi, ci in zip(row_blocks, col_blocks):
        A[r0:r0 + Vi.shape[0], ci[0] * nb:(ci[0] + 1) * nb] = Vi
        r0 += Vi.shape[0]
    b = np.concatenate(rhs_blocks)

    # Continuity rows: p_{i}^{(r)}(t_{i+1}) − p_{i+1}^{(r)}(t_{i+1}) = 0.
    n_c = (K - 1) * (continuity + 1)
    Ccon = np.zeros((n_c, K * nb))
    j = np.arange(nb)
    for r in range(continuity + 1):
        fall = np.array([math.perm(jj, r) if jj >= r else 0 for jj in j], dtype=float)
        for i in range(K - 1):
            hbar = 0.5 * (h[i] + h[i + 1])
            row = i * (continuity + 1) + r
            Ccon[row, i * nb:(i + 1) * nb] = fall * (hbar / h[i]) ** r
            Ccon[row, (i + 1) * nb + r] = -math.factorial(r) * (hbar / h[i + 1]) ** r
    try:
        a, _ = cls_qr(A, b[:, None], Ccon, np.zeros((n_c, 1)))
    except RankProblem as err:
        raise param_error(
            "x", f"spread over the intervals so that the {K} polynomials of degree "
            f"{degree} are determined (enough distinct points per interval)",
            f"<a rank-deficient fit: rank {err.rank} < {err.full} coefficients>") from None
    coef = a[:, 0].reshape(K, nb) / h[:, None] ** j
    poly = PiecewisePolynomial(knots, coef, continuity)
    resid = poly(x) - y
    poly.rss = float(resid @ resid)
    return poly
