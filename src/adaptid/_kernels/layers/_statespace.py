r"""Compiled sensitivity recursion of a state-space one-step predictor.

The predictor of the innovation form (A, B, C, D, K),

.. math::

    \hat x_{k+1} = \bar A\hat x_k + \bar Bu_k + Ky_k,\qquad
    \hat y_k = C\hat x_k + Du_k,\qquad \bar A = A - KC,\ \bar B = B - KD,

and the derivatives of its prediction errors :math:`\varepsilon_k = y_k - \hat y_k`
with respect to every entry of the full parameterisation
θ = [A, B, C, D, K, x̂₀] (each matrix row by row). With
:math:`S_k = \partial\hat x_k/\partial\theta` (n × d):

.. math::

    S_{k+1} = \bar AS_k + F_k,\qquad
    \frac{\partial\varepsilon_k}{\partial\theta} = -(CS_k + G_k),

where the injections :math:`F_k` hold, in the column of :math:`A_{ij}`,
:math:`e_i\hat x_{k,j}`; of :math:`B_{ij}`, :math:`e_iu_{k,j}`; of :math:`K_{ij}`,
:math:`e_i\varepsilon_{k,j}`; of :math:`C_{ij}`, :math:`-K_{:,i}\hat x_{k,j}`; of
:math:`D_{ij}`, :math:`-K_{:,i}u_{k,j}`; and the direct terms :math:`G_k`, in
the column of :math:`C_{ij}`, :math:`e_i\hat x_{k,j}` and of :math:`D_{ij}`,
:math:`e_iu_{k,j}`. :math:`S_0` is zero except the x̂₀ block (the identity).
With K = 0 and y = 0 the same loop gives the sensitivities of a simulation
(a step response). Nothing here validates: the caller
(:mod:`adaptid.models.statespace._uncertainty`) checks and allocates.
"""

from __future__ import annotations

from ..._config import NJIT, njit

__all__ = ["predictor_sensitivity"]


@njit(**NJIT)
def predictor_sensitivity(Abar, Bbar, K, C, D, Y, U, x, S, E, J):  # noqa: C901 - one loop
    """Rows k = 0 … N−1 of E (N, p) and J (N, p, d); x (n,) and S (n, d) carried in place."""
    n, m, p = Bbar.shape[0], Bbar.shape[1], C.shape[0]
    d = S.shape[1]
    oB = n * n
    oC = oB + n * m
    oD = oC + p * n
    oK = oD + p * m
    Sn = S.copy()
    xn = x.copy()
    for k in range(Y.shape[0]):
        for r in range(p):                       # prediction error
            s = Y[k, r]
            for i in range(n):
                s -= C[r, i] * x[i]
            for j in range(m):
                s -= D[r, j] * U[k, j]
            E[k, r] = s
        for r in range(p):                       # its derivative −(C S + G)
            for c in range(d):
                s = 0.0
                for i in range(n):
                    s += C[r, i] * S[i, c]
                J[k, r, c] = -s
            for j in range(n):
                J[k, r, oC + r * n + j] -= x[j]
            for j in range(m):
                J[k, r, oD + r * m + j] -= U[k, j]
        for i in range(n):                       # S ← Ā S + F
            for c in range(d):
                s = 0.0
                for l in range(n):
                    s += Abar[i, l] * S[l, c]
                Sn[i, c] = s
            for j in range(n):
                Sn[i, i * n + j] += x[j]
            for j in range(m):
                Sn[i, oB + i * m + j] += U[k, j]
            for j in range(p):
                Sn[i, oK + i * p + j] += E[k, j]
            for r in range(p):
                for j in range(n):
                    Sn[i, oC + r * n + j] -= K[i, r] * x[j]
                for j in range(m):
                    Sn[i, oD + r * m + j] -= K[i, r] * U[k, j]
        for i in range(n):                       # x ← Ā x + B̄ u + K y
            s = 0.0
            for l in range(n):
                s += Abar[i, l] * x[l]
            for j in range(m):
                s += Bbar[i, j] * U[k, j]
            for j in range(p):
                s += K[i, j] * Y[k, j]
            xn[i] = s
        x[:] = xn
        S[:, :] = Sn
