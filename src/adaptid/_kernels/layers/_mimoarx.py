r"""The autoregressive recursion of a MIMO ARX model (:mod:`adaptid.models.mimo`).

``mimo_ar_recursion`` runs

.. math::

    y_t = f_t - \sum_{l=1}^{L} A_l\,y_{t-l}, \qquad t = t_0, \dots, N-1,

over a preallocated ``y`` whose rows before :math:`t_0` hold the initial
outputs (samples before row 0 count as zero). The forcing :math:`f_t` (the
input part :math:`\sum_l B_l u_{t-l}`, or a sensitivity's right-hand side)
is formed by the caller. As every kernel, nothing here validates: the
model checks the arguments and allocates.
"""

from ..._config import NJIT, njit

__all__ = ["mimo_ar_recursion"]


@njit(**NJIT)
def mimo_ar_recursion(A, f, t0, y):
    """``y[t] = f[t] - sum_l A[l - 1] @ y[t - l]`` for t >= t0; A (L, p, p), f and y (N, p)."""
    L, p = A.shape[0], A.shape[1]
    for t in range(t0, y.shape[0]):
        top = min(L, t)
        for i in range(p):
            s = f[t, i]
            for l in range(1, top + 1):
                for j in range(p):
                    s -= A[l - 1, i, j] * y[t - l, j]
            y[t, i] = s
