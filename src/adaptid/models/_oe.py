r"""The output-error model :math:`y_k = \frac{B(q)}{F(q)}u_k + e_k`."""

from __future__ import annotations

import numpy as np
from scipy import signal

from .._validation import check_int, param_error
from ._pem import _PseudoLinearModel, lagmat

__all__ = ["OE"]


class OE(_PseudoLinearModel):
    r"""Output-error model, identified by pseudo-linear regression.

    .. math::

        y_k = \frac{B(q)}{F(q)}u_k + e_k,\qquad
        \theta = [b_0..b_{n_b-1},\ f_1..f_{n_f}],

    with the noise-free output :math:`w_k = B(q)/F(q)\,u_k`. The predictor
    is :math:`\hat y_k = w_k = \varphi_k^T\theta`,
    :math:`\varphi_k = [u_{k-n_k}, \dots, u_{k-n_k-n_b+1}, -w_{k-1}, \dots, -w_{k-n_f}]`
    — a pseudo-linear regression on the model's own simulated output, which
    (unlike ARX, whose regressor holds the noisy y) is not correlated with
    the noise, so the estimate is consistent for white or coloured e
    (when :math:`1/F(e^{i\omega}) - 1/2` is strictly positive real for the
    recursive version):

    * :meth:`fit_recursive` — recursive pseudo-linear regression (RPLR,
      Landau's output-error algorithm; Ljung 1999, sec. 11.3; Söderström &
      Stoica 1989, sec. 9.4), one compiled pass with any core estimator;
    * :meth:`fit` — batch: the Steiglitz–McBride iteration (ARX fits by
      :func:`adaptid.lstsq` on y and u prefiltered by 1/F̂), started from
      the plain ARX estimate.

    ``refine=True`` then minimises :math:`\sum_k(y_k - w_k(\theta))^2` with
    :func:`scipy.optimize.least_squares` (analytic gradient
    :math:`\psi_k = \varphi_k/F(q)`). The rows are the samples
    k = s … N-1, :math:`s = n_k + n_b - 1`, with w = 0 before the first
    row. One input only.

    Parameters
    ----------
    nb, nf, nk : int
        Orders (``nb >= 1``, ``nf >= 0``) and input delay (``>= 0``).
    dt : float
        Sample time (default 1.0).

    References
    ----------
    .. [1] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
       Prentice Hall, 1999.
    .. [2] T. Söderström, P. Stoica, *System Identification*, Prentice Hall,
       1989.
    .. [3] K. Steiglitz, L. E. McBride, "A technique for the identification
       of linear systems", *IEEE Trans. Automatic Control* 10(4), 1965.
    """

    _order_names = ("nb", "nf", "nk")
    _alpha, _beta, _sgn = 0.0, 1.0, -1.0

    def __init__(self, nb, nf, nk=1, *, dt=1.0):
        check_int(nb, "nb", low=1)
        self._init_orders(0, nb, 0, nf, nk, dt)
        self._nd = self.nf

    def _check_inputs(self, U):
        if U.shape[1] != 1:
            raise param_error("u", "one input (shape (N,) or (N, 1)) for OE", f"<{U.shape[1]} inputs>")

    def _split(self, theta):
        nb = self._nb[0]
        return np.zeros(0), [theta[:nb]], np.zeros(0), [theta[nb: nb + self.nf]]

    def _names(self):
        return tuple([f"b{j}" for j in range(self._nb[0])] + [f"f{j}" for j in range(1, self.nf + 1)])

    def _errors(self, theta, Phi_fix, Y):
        nb = Phi_fix.shape[1]
        F = np.concatenate([[1.0], theta[nb:]])
        w = self._filt(F, Phi_fix @ theta[:nb])
        Phi = np.hstack([Phi_fix, -lagmat(w, self.nf)])
        return Y - w, self._filt(F, Phi)

    def fit(self, y, u, *, refine=False, n_iter=30, tol=1e-8):
        r"""Batch fit: Steiglitz–McBride iterations, optionally refined.

        Iteration: filter y and u by :math:`1/\hat F`, fit
        :math:`\hat F(q)y^F_k = \hat B(q)u^F_k + e_k` by least squares, repeat
        until θ changes by less than ``tol·(1 + |θ|)`` or ``n_iter`` times.

        Parameters
        ----------
        y : array_like, shape (N,)
        u : array_like, shape (N,) or (N, 1)
        refine : bool
            Refine by minimising :math:`\sum(y - w(\theta))^2` (default False).
        n_iter : int
            Largest number of iterations (default 30).
        tol : float

        Returns
        -------
        self
        """
        from .._lstsq import lstsq
        from ._builders import arx_regressors

        y, U = self._data(y, u, fitting=True)
        self._check_inputs(U)
        n_iter = check_int(n_iter, "n_iter", low=1)
        reg, Phi_fix = self._fixed_regression(y, U, True)
        nb, nk = self._nb[0], self._nk[0]
        F = np.ones(1)
        theta = None
        for _ in range(n_iter if self.nf else 1):
            yf = signal.lfilter([1.0], F, y)
            uf = signal.lfilter([1.0], F, U[:, 0])
            regf = arx_regressors(yf, uf, self.nf, nb, nk)
            th = np.asarray(lstsq(regf.Phi, regf.y).theta)
            new = np.concatenate([th[self.nf:], -th[: self.nf]])   # [b, f]
            F = np.concatenate([[1.0], new[nb:]])
            done = theta is not None and np.max(np.abs(new - theta)) < tol * (1 + np.max(np.abs(new)))
            theta = new
            if done:
                break
        if refine:
            theta = self._refine(theta, Phi_fix, reg.y)
        self._finish(theta, Phi_fix, reg.y, reg)
        return self
