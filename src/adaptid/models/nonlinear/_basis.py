r"""Polynomial candidate terms of a NARX model, without forming the candidate matrix.

The candidates are the monomials of degree ≤ D in n base variables
:math:`x_1 … x_n` (lagged outputs and inputs). With :math:`x_0 \equiv 1`
they are exactly the monomials of degree D in :math:`x_0 … x_n`, i.e. the
sorted index tuples :math:`i_1 \le \dots \le i_D` over :math:`\{0, …, n\}`
(``itertools.combinations_with_replacement`` order, the constant first, as
sysidentpy orders them): :math:`\binom{n + D}{D}` candidates.

Every product :math:`P^T w` of the (never formed) candidate matrix P with
a vector w is one matrix product: with Q the products of the first D − 1
factors (one column per distinct prefix :math:`i_1 … i_{D-1}`) and
:math:`\tilde X = [1, x_1, …, x_n]`,

.. math::

    (P^T w)_{(i_1 … i_D)} = \sum_k Q_{k, (i_1 … i_{D-1})}\, w_k\, \tilde X_{k, i_D}
                         = \big[Q^T \operatorname{diag}(w) \tilde X\big]_{(i_1 … i_{D-1}),\, i_D},

a GEMM of :math:`\binom{n+D-1}{D-1} \times N` by :math:`N \times (n+1)` —
compute-bound BLAS work instead of a memory-bound pass over the
:math:`N \times \binom{n+D}{D}` matrix P. Q is kept when it fits the memory
budget and is otherwise rebuilt in row blocks on each product.
"""

from __future__ import annotations

import itertools

import numpy as np

__all__ = ["MonomialBasis", "multisets"]

#: bytes of the prefix-product matrix Q kept in memory; larger problems work in row blocks
Q_BUDGET = 256 * 2**20


def multisets(n_vars, degree):
    """All sorted index tuples of length ``degree`` over 0 … n_vars, shape (M, degree)."""
    out = np.array(list(itertools.combinations_with_replacement(range(n_vars + 1), degree)),
                   dtype=np.intp)
    return out.reshape(-1, degree)


class MonomialBasis:
    r"""The candidate monomials of degree ≤ D of the columns of X.

    Parameters
    ----------
    X : ndarray, shape (N, n)
        Base variables (the constant is added as column 0).
    degree : int
        D ≥ 1.
    budget : int, optional
        Bytes allowed for the cached prefix products (default ``Q_BUDGET``).

    Attributes
    ----------
    combos : ndarray of intp, shape (M, D)
        Candidate j is :math:`\prod_c \tilde X_{:, combos[j, c]}` (index 0 the constant).
    """

    def __init__(self, X, degree, *, budget=None):
        X = np.asarray(X, dtype=np.float64)
        N, n = X.shape
        self.N, self.n, self.degree = N, n, degree
        self.Xt = np.empty((N, n + 1))
        self.Xt[:, 0] = 1.0
        self.Xt[:, 1:] = X
        self.combos = multisets(n, degree)
        self.M = self.combos.shape[0]
        if degree > 1:
            self._prefixes = multisets(n, degree - 1)
            pos = {tuple(p): i for i, p in enumerate(self._prefixes)}
            pidx = np.array([pos[tuple(c[:-1])] for c in self.combos], dtype=np.intp)
        else:
            self._prefixes = np.zeros((1, 0), dtype=np.intp)
            pidx = np.zeros(self.M, dtype=np.intp)
        self._flat = pidx * (n + 1) + self.combos[:, -1]
        n_pref = self._prefixes.shape[0]
        budget = Q_BUDGET if budget is None else budget
        # columns of Q squared at once in sq_norms: a quarter of the budget, at most 4096
        self._sq_step = int(min(4096, max(1, budget // (32 * n_pref))))
        self._rows = N if N * n_pref * 8 <= budget else max(1, budget // (8 * n_pref))
        self._Q = self._prefix_products(slice(0, N)) if self._rows == N else None

    def _prefix_products(self, rows):
        """Qᵀ on ``rows``, shape (n_prefixes, rows): level by level, each prefix's
        children are one broadcast product.

        In lexicographic order the prefixes extending a shorter prefix c are
        contiguous, ordered by their last index i ≥ last(c).
        """
        XT = np.ascontiguousarray(self.Xt[rows].T)
        n1 = XT.shape[0]
        QT = np.ones((1, XT.shape[1]))
        last = np.zeros(1, dtype=np.intp)
        for _ in range(self._prefixes.shape[1]):
            widths = n1 - last
            nxt = np.empty((int(widths.sum()), XT.shape[1]))
            nlast = np.empty(nxt.shape[0], dtype=np.intp)
            o = 0
            for c in range(QT.shape[0]):
                b, w = int(last[c]), int(widths[c])
                np.multiply(QT[c], XT[b:], out=nxt[o:o + w])
                nlast[o:o + w] = np.arange(b, n1)
                o += w
            QT, last = nxt, nlast
        return QT

    def _blocks(self):
        """Row slices and Qᵀ on each: the cached Q, or one block at a time (the
        caller drops its block before the next is built: one block in memory)."""
        if self._Q is not None:
            yield slice(0, self.N), self._Q
            return
        for start in range(0, self.N, self._rows):
            rows = slice(start, min(start + self._rows, self.N))
            yield rows, self._prefix_products(rows)

    def project(self, w):
        r"""All :math:`p_j^T w`, shape (M,), for w of shape (N,)."""
        G = np.zeros((self._prefixes.shape[0], self.n + 1))
        blocks = self._blocks()
        for rows, QT in blocks:
            G += QT @ (w[rows, None] * self.Xt[rows])
            del QT
        return G.ravel()[self._flat]

    def sq_norms(self):
        r"""All :math:`\lVert p_j\rVert^2`, shape (M,)."""
        G = np.zeros((self._prefixes.shape[0], self.n + 1))
        for rows, QT in self._blocks():
            X2 = self.Xt[rows] ** 2
            step = self._sq_step  # squares in slices: no second copy of Q
            for s0 in range(0, QT.shape[1], step):
                Qs = QT[:, s0:s0 + step]
                G += (Qs * Qs) @ X2[s0:s0 + step]
            del QT, Qs
        return G.ravel()[self._flat]

    def columns(self, js):
        """The candidate columns ``js``, shape (N, len(js))."""
        js = np.asarray(js, dtype=np.intp).reshape(-1)
        out = np.ones((self.N, js.size))
        for c in range(self.degree):
            out *= self.Xt[:, self.combos[js, c]]
        return out


def evaluate(Xt, combos):
    r"""Terms given by index tuples ``combos`` (d, D) of the columns of ``Xt`` (with its constant)."""
    out = np.ones((Xt.shape[0], combos.shape[0]))
    for c in range(combos.shape[1]):
        out *= Xt[:, combos[:, c]]
    return out
