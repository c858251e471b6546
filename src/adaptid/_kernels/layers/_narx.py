r"""Compiled loops of the polynomial NARX model (:mod:`adaptid.models.nonlinear`).

A term is an index tuple ``combos[t]`` (length D) into
:math:`\tilde x = [1, x_1, …, x_n]`, the constant and the base variables
(lagged outputs and inputs); its value is the product
:math:`\tilde x_{c_0}\tilde x_{c_1}\cdots\tilde x_{c_{D-1}}`, taken left to
right. An output's prediction is the sum over its terms, in order, of
:math:`\theta_t` times that product:

.. math::

    \hat y = \Big(\big((0 + \theta_0 p_0) + \theta_1 p_1\big) + \cdots\Big).

These kernels are compiled **without** FMA contraction (unlike
:data:`adaptid._config.NJIT`): the generated C predictor of
:mod:`adaptid.codegen._narx` writes the same operations in the same order,
so that with ``-ffp-contract=off`` (the default of ``-std=c99``) it gives
the same bits on any IEEE-754 machine, and a simulation is the same bits
on every machine.

As every kernel, nothing here validates: the model checks and allocates.
"""

import numpy as np

from ..._config import NJIT, njit

__all__ = ["narx_terms", "narx_simulate"]

#: NJIT without contraction: the C export reproduces these sums bit for bit
_NJIT_EXACT = {**NJIT, "fastmath": False}


@njit(**_NJIT_EXACT)
def narx_terms(Xt, combos, theta, out):
    """out[k] = Σ_t θ_t Π_c Xt[k, combos[t, c]] for every row k (sequential sums)."""
    N = Xt.shape[0]
    T, D = combos.shape
    for k in range(N):
        s = 0.0
        for t in range(T):
            p = Xt[k, combos[t, 0]]
            for c in range(1, D):
                p = p * Xt[k, combos[t, c]]
            s = s + theta[t] * p
        out[k] = s


@njit(**_NJIT_EXACT)
def narx_simulate(Y, Xu, yi, yj, combos, theta, start, L):
    r"""Free run: Y[k, o] for k = L … N−1 from the model's own past outputs.

    Parameters
    ----------
    Y : (N, p) float64
        Rows 0 … L−1 hold the initial outputs; the rest is overwritten.
    Xu : (N, n_u) float64
        The input base variables of each row (u_i(k − j) in the model's order).
    yi, yj : (n_y,) int64
        Output index and lag of each output base variable.
    combos : (T, D) int64
        The terms of every output, output after output, indices into
        [1, output base variables, input base variables].
    theta : (T,) float64
    start : (p + 1,) int64
        Output o's terms are ``start[o] … start[o+1] − 1``.
    L : int
        The largest lag.
    """
    N, P = Y.shape
    ny = yi.shape[0]
    nu = Xu.shape[1]
    D = combos.shape[1]
    xt = np.empty(1 + ny + nu)
    xt[0] = 1.0
    for k in range(L, N):
        for i in range(ny):
            xt[1 + i] = Y[k - yj[i], yi[i]]
        for i in range(nu):
            xt[1 + ny + i] = Xu[k, i]
        for o in range(P):
            s = 0.0
            for t in range(start[o], start[o + 1]):
                p = xt[combos[t, 0]]
                for c in range(1, D):
                    p = p * xt[combos[t, c]]
                s = s + theta[t] * p
            Y[k, o] = s
