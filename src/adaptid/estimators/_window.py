r"""Sliding-window least squares: the truncated least squares method (TLSM)."""

from __future__ import annotations

import numpy as np

from .. import _config
from .._validation import check_int, param_error
from ..forgetting import resolve as _resolve_forgetting
from ._engine import RecursiveEstimator
from ._forgetting import ForgettingMixin
from ._spec import AlgorithmSpec

__all__ = ["SlidingWindowRLS"]


def _buffer(est):
    """The window's block after θ, U, D: [log-forgetting, pos, count], its buffer of
    M samples (M·(n + p + 2) values), then θ, U, D of the decayed prior term."""
    n, p, M = est.n_params, est.n_outputs, est.window
    return n * p + n * n + n + 3 + M * (n + p + 2)


class SlidingWindowRLS(ForgettingMixin, RecursiveEstimator):
    r"""Sliding-window least squares: the truncated least squares method (TLSM).

    After sample k the estimate minimises the RLS cost restricted to the
    last M samples (the prior term kept, decaying with the forgetting):

    .. math::

        V_k(\theta) = \sum_{j=k-M+1}^{k} \Big(\prod_{i=j+1}^{k}\lambda_i\Big) w_j
            (y_j - \varphi_j^T\theta)^2
          + \Big(\prod_{i=1}^{k}\lambda_i\Big)(\theta-\theta_0)^T P_0^{-1}(\theta-\theta_0).

    ``forgetting=1`` is Yamamoto's discrete algorithm 2 (eqs. 69–70), a
    constant λ is algorithm 3 (eqs. 71–72), per-sample λₖ and weights wₖ are
    algorithm 4 (eqs. 73–74); in the general form of eqs. 62–65 each step
    adds the new sample and removes the one leaving the window:

    .. math::

        R_k = \lambda_k R_{k-1} + w_k\varphi_k\varphi_k^T
              - c_k\,\varphi_{k-M}\varphi_{k-M}^T,\qquad
        c_k = w_{k-M}\prod_{i=k-M+1}^{k}\lambda_i .

    Both rank-one changes are done on the U-D factors of P = R⁻¹ (the removal
    as a Bierman update with negative weight). A removal whose ratio
    ``1 − c φᵀPφ`` of determinants falls below ``DOWNDATE_RTOL`` would lose
    definiteness (or most of its digits): it is replaced by an exact re-solve
    of the window from the buffer, and a :class:`DefinitenessLossWarning` is
    emitted. With noise-free data the estimate equals the true θ exactly M
    samples after an abrupt change (up to the decayed prior term).

    Parameters
    ----------
    n_params : int
    window : int
        M ≥ n_params, the number of samples in the window.
    forgetting, theta0, P0, nan_policy, n_outputs
        As for :class:`RLS`. With ``P0="diffuse"`` the prior term is
        dropped: θ is the least-squares solution over the window contents
        alone (what ``statsmodels`` ``RollingOLS`` gives), computed exactly
        (square-root information, Bierman 1977, ch. V) whenever the window
        is rank-deficient — at the start and after a removal that would make
        it so — with θ then the minimum-norm solution and ``identified``
        False; the re-solves from the buffer use no prior.

    References
    ----------
    .. [1] T. Yamamoto, "Continuous and discrete time adaptive algorithms by
       the truncated least squares method (TLSM)", 1991, eqs. 62–74.
    """

    spec = AlgorithmSpec(
        method="window",
        kernels={"default": "WINDOW", "diffuse": "WINDOW_DIFFUSE"},
        options=("window", "forgetting", "nan_policy", "windup_threshold"),
        diffuse_tail=lambda n, p: 2,  # [flag, stop]
        buffer=_buffer,
        rebuilds=True,
        stats=("default", "diffuse"),
        stats_from_buffer=True)

    def __init__(self, n_params, window, *, forgetting=1.0, theta0=None, P0=1e4,
                 nan_policy="raise", n_outputs=None, windup_threshold=None):
        n = check_int(n_params, "n_params", low=1)
        self.window = check_int(window, "window", low=n)
        self.forgetting, self._lam, self._strategy = _resolve_forgetting(
            forgetting, allow_strategies=False, owner="SlidingWindowRLS")
        super().__init__(n_params, theta0=theta0, P0=P0, nan_policy=nan_policy,
                         n_outputs=n_outputs, windup_threshold=windup_threshold)

    def _fill_initial(self, S):
        super()._fill_initial(S)
        n, p, M = self.n_params, self.n_outputs, self.window
        o = n * p + n * n + n + 3 + M * (n + p + 2)
        S[o: o + n * p] = self.theta0.ravel()
        S[o + n * p: o + n * p + n * n] = self._U0.T.ravel()
        S[o + n * p + n * n: o + n * p + n * n + n] = self._D0

    def _check_state(self, S):
        super()._check_state(S)
        n, p, M = self.n_params, self.n_outputs, self.window
        o = n * p + n * n + n
        L, pos, count = S[:, o], S[:, o + 1], S[:, o + 2]
        Bw = S[:, o + 3 + M * (n + p): o + 3 + M * (n + p + 1)]
        ok = (np.isfinite(L) & (L <= 0) & (pos == np.round(pos)) & (pos >= 0) & (pos < M)
              & (count == np.round(count)) & (count >= 0) & (count <= M)
              & ((count == M) | (pos == count)) & np.all(np.isfinite(Bw) & (Bw >= 0), axis=1))
        if not ok.all():  # the buffer indices: a forged value would write out of bounds
            raise param_error("state['state']", f"a window state (0 <= pos < {M}, "
                              f"0 <= count <= {M}, log-forgetting <= 0, weights >= 0)",
                              "<a damaged window state>")

    def _kernel_options(self):
        opt = [self._windup_threshold, self.window, _config.DOWNDATE_RTOL]
        if self._diffuse:
            opt.append(_config.DIFFUSE_RCOND)
        return np.array(opt), np.zeros((1, 1))
