r"""Compiled kernel of the recursive residuals (Givens QR updating).

The caller validates and allocates; nothing here checks its input.

The upper triangular factor of the augmented matrix :math:`[\Phi_k\ y_k]`
is updated one row at a time with Givens rotations. Row :math:`k` is
rotated into ``[R | z]`` (``R`` n×n upper triangular with non-negative
diagonal, :math:`R\theta_{k-1} = z` the least-squares solution on samples
1..k−1); what remains in its last entry is

.. math::

    \Bigl(\prod_j c_j\Bigr)\,(y_k - \varphi_k^T\theta_{k-1})
    = \frac{y_k - \varphi_k^T\theta_{k-1}}
           {\sqrt{1 + \varphi_k^T (R^T R)^{-1}\varphi_k}} = w_k,

the recursive residual, because the cosines :math:`c_j = R_{jj}/r_j` are
positive whenever ``R`` is non-singular (Björck 1996, §3.2; Kianifard &
Swallow 1996). Cost: :math:`O(n^2)` per sample, no inverse, no normal
equations.
"""

import math

import numpy as np


from ..._config import NJIT, njit


@njit(**NJIT)
def recursive_residuals_kernel(Phi, y, tol, R, w):  # pragma: no cover - compiled
    """Fill ``w`` (N - n,) with the recursive residuals of (Phi, y).

    ``R`` (n, n + 1) must be zero on entry; on return it holds the
    triangular factor ``[R | z]`` of all N samples. ``w[k - n]`` is NaN while
    the first ``k`` rows have |R_ii| <= tol[i] for some i (rank deficient).
    Returns the number of leading NaN entries of ``w``.
    """
    N, n = Phi.shape
    row = np.empty(n + 1)
    full = False
    n_undefined = 0
    for k in range(N):
        for j in range(n):
            row[j] = Phi[k, j]
        row[n] = y[k]
        for j in range(n):
            xj = row[j]
            if xj == 0.0:
                continue
            rjj = R[j, j]
            r = math.hypot(rjj, xj)
            c = rjj / r
            s = xj / r
            R[j, j] = r
            row[j] = 0.0
            for i in range(j + 1, n + 1):
                t = R[j, i]
                R[j, i] = c * t + s * row[i]
                row[i] = c * row[i] - s * t
        if k >= n:
            if full:
                w[k - n] = row[n]
            else:
                w[k - n] = np.nan
                n_undefined += 1
        if not full:
            full = True
            for i in range(n):
                if not (R[i, i] > tol[i]):
                    full = False
                    break
    return n_undefined
