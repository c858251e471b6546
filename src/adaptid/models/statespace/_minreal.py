r"""Minimal realisation by orthogonal staircase reductions (SLICOT TB01PD style).

A realisation (A, B, C, D) of a discrete transfer matrix
:math:`G(z) = C(zI - A)^{-1}B + D` is minimal when it is controllable and
observable; its order is then the McMillan degree of G. The reduction is
done with orthogonal similarity transformations only, in two passes:

1. **Controllable part** — the controllability staircase (Van Dooren 1981;
   Varga 1981; SLICOT TB01UD). With :math:`R_1 = B`,
   step i takes the SVD :math:`R_i = U_i\Sigma_iV_i^\mathsf T` of the
   block still to be reduced, decides its rank :math:`r_i` (the singular
   values above the tolerance), and applies :math:`U_i` to the trailing
   rows and columns of A (rows of B, columns of C). Then
   :math:`R_{i+1}` is the block of the new A below the :math:`r_i` columns
   just found. The loop stops when a rank is zero or every state is
   reached; with :math:`n_c = \sum_i r_i`,

   .. math::

       Q^\mathsf TAQ = \begin{bmatrix}A_c & A_{12}\\ 0 & A_{\bar c}\end{bmatrix},\quad
       Q^\mathsf TB = \begin{bmatrix}B_c\\ 0\end{bmatrix},\quad
       CQ = \begin{bmatrix}C_c & C_{\bar c}\end{bmatrix},

   and :math:`(A_c, B_c)` is controllable with the same transfer matrix
   :math:`C_c(zI - A_c)^{-1}B_c = C(zI - A)^{-1}B`.
2. **Observable part** of :math:`(A_c, B_c, C_c)` — the same staircase on
   the dual :math:`(A_c^\mathsf T, C_c^\mathsf T, B_c^\mathsf T)`,
   transposed back.

**Rank decisions.** A singular value σ of a block counts when
:math:`\sigma > \mathrm{tol}\cdot\max(\|A\|_F, \|B\|_F)` (observability
pass: :math:`\|C\|_F` for :math:`\|B\|_F`); the default relative tolerance
is :math:`n^2\varepsilon` (SLICOT TB01PD's default ``TOLDEF = N*N*EPS``
on the norms of A and B), so only exact cancellations, up to rounding,
are removed. A model estimated from data has its near-cancellations
removed only with a larger ``tol`` (MATLAB's ``minreal`` uses
:math:`\sqrt\varepsilon`). An SVD per step makes the rank decisions
reliable; it costs :math:`O(n^3)` per step, :math:`O(n^4)` at worst,
which is nothing at the orders of identified models.

References
----------
A. Varga (1981). Numerically stable algorithm for standard controllability
form determination. *Electronics Letters* 17(2), 74–75; and A. Varga
(1991). Minimal realization procedures based on balancing and related
techniques. In *New Trends in Systems Theory*, Birkhäuser, 733–761.
P. Van Dooren (1981). The generalized eigenstructure problem in linear
system theory. *IEEE Trans. Automatic Control* 26(1), 111–129.
SLICOT Library, routines TB01PD (minimal realisation) and TB01UD
(controllable realisation), https://github.com/SLICOT/SLICOT-Reference.
"""

from __future__ import annotations

import numpy as np

from ..._validation import as_float_array, check_scalar, param_error

__all__ = ["controllable_part", "minimal_realization"]


def _threshold(A, B, tol):
    n = A.shape[0]
    rel = n * n * np.finfo(float).eps if tol is None else tol
    return rel * max(np.linalg.norm(A), np.linalg.norm(B))


def controllable_part(A, B, C, tol=None):
    r"""The controllable subsystem :math:`(A_c, B_c, C_c)` by the orthogonal staircase.

    See the module notes for the algorithm (Van Dooren 1981;
    SLICOT TB01UD) and the rank rule.

    Parameters
    ----------
    A : ndarray, shape (n, n)
    B : ndarray, shape (n, m)
    C : ndarray, shape (p, n)
    tol : float, optional
        Relative tolerance of the rank decisions (default :math:`n^2\varepsilon`).

    Returns
    -------
    Ac : ndarray, shape (nc, nc)
    Bc : ndarray, shape (nc, m)
    Cc : ndarray, shape (p, nc)
    """
    A, B, C = np.array(A, float), np.array(B, float), np.array(C, float)
    n = A.shape[0]
    thr = _threshold(A, B, tol)
    nc, prev = 0, 0
    while nc < n:
        R = B[nc:] if nc == 0 else A[nc:, nc - prev: nc]
        if R.shape[1] == 0:
            break
        U, s, _ = np.linalg.svd(R, full_matrices=True)
        r = int(np.sum(s > thr))
        if r == 0:
            break
        A[nc:] = U.T @ A[nc:]
        A[:, nc:] = A[:, nc:] @ U
        C[:, nc:] = C[:, nc:] @ U
        if nc == 0:
            B = U.T @ B
        prev, nc = r, nc + r
    return A[:nc, :nc].copy(), B[:nc].copy(), C[:, :nc].copy()


def minimal_realization(A, B, C, D=None, *, tol=None):
    r"""A minimal realisation of :math:`C(zI - A)^{-1}B + D` (SLICOT TB01PD, JOB = 'M').

    The controllable part (orthogonal controllability staircase), then the
    observable part of that (the staircase on the dual system); see the
    module notes (Varga 1981; Van Dooren 1981). The result has the
    same Markov parameters :math:`D, CB, CAB, \dots` and, up to the
    tolerance, as many states as the McMillan degree of the transfer matrix.

    Parameters
    ----------
    A : array_like, shape (n, n)
    B : array_like, shape (n, m)
    C : array_like, shape (p, n)
    D : array_like, shape (p, m), optional
        Feedthrough, returned unchanged (zeros when omitted).
    tol : float, optional
        Relative tolerance of the rank decisions: a singular value counts
        when it exceeds ``tol`` times the larger Frobenius norm of A and B
        (of A and C in the dual pass). Default :math:`n^2\varepsilon`.

    Returns
    -------
    Am : ndarray, shape (nm, nm)
    Bm : ndarray, shape (nm, m)
    Cm : ndarray, shape (p, nm)
    D : ndarray, shape (p, m)

    Examples
    --------
    A second-order system whose second mode the input does not reach:

    >>> import numpy as np
    >>> from adaptid.models.statespace._minreal import minimal_realization
    >>> A = np.diag([0.5, 0.8]); B = np.array([[1.0], [0.0]]); C = np.array([[1.0, 1.0]])
    >>> Am, Bm, Cm, D = minimal_realization(A, B, C)
    >>> Am.shape, bool(np.isclose((Cm @ Bm)[0, 0], 1.0)), bool(np.isclose(Am[0, 0], 0.5))
    ((1, 1), True, True)
    """
    A = as_float_array(A, "A", ndim=2)
    n = A.shape[0]
    if A.shape != (n, n):
        raise param_error("A", "a square matrix", f"<shape {A.shape}>")
    B = as_float_array(B, "B", ndim=2)
    C = as_float_array(C, "C", ndim=2)
    if B.shape[0] != n:
        raise param_error("B", f"of {n} rows (the order of A)", f"<shape {B.shape}>")
    if C.shape[1] != n:
        raise param_error("C", f"of {n} columns (the order of A)", f"<shape {C.shape}>")
    D = np.zeros((C.shape[0], B.shape[1])) if D is None else as_float_array(D, "D", ndim=2)
    if D.shape != (C.shape[0], B.shape[1]):
        raise param_error("D", f"of shape {(C.shape[0], B.shape[1])}", f"<shape {D.shape}>")
    if tol is not None:
        tol = check_scalar(tol, "tol", low=0.0)
    Ac, Bc, Cc = controllable_part(A, B, C, tol)
    At, Ct, Bt = controllable_part(Ac.T, Cc.T, Bc.T, tol)
    return At.T.copy(), Bt.T.copy(), Ct.T.copy(), D.copy()
