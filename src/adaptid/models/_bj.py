r"""The Box–Jenkins model :math:`y_k = \frac{B(q)}{F(q)}u_k + \frac{C(q)}{D(q)}e_k`."""

from __future__ import annotations

import numpy as np
from scipy import signal

from .._validation import as_float_array, check_int, param_error
from ._pem import _PseudoLinearModel, lagmat, stabilize
from ._polymodel import _poly_sub

__all__ = ["BJ"]


def _lf(num, den, X):
    """Filter the columns of X (none: an empty (N, 0) array)."""
    return signal.lfilter(num, den, X, axis=0) if X.shape[1] else X


class BJ(_PseudoLinearModel):
    r"""Box–Jenkins model: independently parametrised plant and noise.

    .. math::

        y_k = \frac{B(q)}{F(q)}u_k + \frac{C(q)}{D(q)}e_k,\qquad
        \theta = [b_0..b_{n_b-1},\ c_1..c_{n_c},\ d_1..d_{n_d},\ f_1..f_{n_f}]

    (MATLAB's ``bj`` parameter order), with
    :math:`B(q) = q^{-n_k}(b_0 + \dots + b_{n_b-1}q^{-n_b+1})` and monic C, D,
    F. With the noise-free output :math:`w = B/F\,u`, the noise
    :math:`v = y - w` and the prediction error
    :math:`\varepsilon = D/C\,v`, the one-step predictor is pseudo-linear,
    :math:`\hat y_k = \varphi_k^T\theta` with

    .. math::

        \varphi_k = [u_{k-n_k}, \dots, u_{k-n_k-n_b+1},\
                     \varepsilon_{k-1}, \dots, \varepsilon_{k-n_c},\
                     -v_{k-1}, \dots, -v_{k-n_d},\
                     -w_{k-1}, \dots, -w_{k-n_f}]

    (Ljung 1999, eq. 4.44 and sec. 10.3):

    * :meth:`fit_recursive` — recursive pseudo-linear regression on these
      signals, each formed a posteriori from the current estimate (MATLAB's
      ``recursiveBJ``; Ljung 1999, sec. 11.3), one compiled pass with any
      core estimator (RLS with any forgetting strategy, SlidingWindowRLS,
      KalmanRLS);
    * :meth:`fit` — prediction-error minimisation of
      :math:`\sum_k\varepsilon_k^2(\theta)` (:func:`scipy.optimize.least_squares`,
      analytic gradient), started from B, F of the Steiglitz–McBride output-error
      estimate (:class:`OE`, refined) and C, D of the Hannan–Rissanen ARMA fit of its
      residual v. PEM is consistent (and for Gaussian e asymptotically
      efficient) where ARX, and ARMAX with its shared denominator, are biased.

    Roots of C, D and F outside the unit circle are reflected inside. The
    rows are the samples k = s … N-1, :math:`s = n_k + n_b - 1`, with the
    signals zero before the first row; ``cov`` is the asymptotic
    prediction-error covariance :math:`\hat\sigma^2(\Psi^T\Psi)^{-1}`
    (Ljung 1999, eq. 9.17). One input.

    Parameters
    ----------
    nb : int
        Number of B coefficients, ``>= 1``.
    nc, nd, nf : int
        Orders of C, D, F, ``>= 0``.
    nk : int
        Input delay, ``>= 0`` (default 1).
    dt : float
        Sample time (default 1.0).

    References
    ----------
    .. [1] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
       Prentice Hall, 1999.
    .. [2] G. E. P. Box, G. M. Jenkins, *Time Series Analysis: Forecasting
       and Control*, Holden-Day, 1970.
    .. [3] K. Steiglitz, L. E. McBride, "A technique for the identification
       of linear systems", *IEEE Trans. Automatic Control* 10(4), 1965.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import lfilter
    >>> from adaptid.models import BJ
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal(4000); e = 0.3 * rng.standard_normal(4000)
    >>> y = lfilter([0, 1.0, 0.5], [1, -0.7], u) + lfilter([1, 0.4], [1, -0.9], e)
    >>> m = BJ(2, 1, 1, 1).fit(y, u)
    >>> m.names
    ('b0', 'b1', 'c1', 'd1', 'f1')
    >>> bool(np.allclose(m.theta, [1.0, 0.5, 0.4, -0.9, -0.7], atol=0.05))
    True
    """

    _order_names = ("nb", "nc", "nd", "nf", "nk")

    def __init__(self, nb, nc, nd, nf, nk=1, *, dt=1.0):
        nb = check_int(nb, "nb", low=1)
        self._init_orders(0, nb, nc, nf, nk, dt)
        self.nd = check_int(nd, "nd", low=0)
        self.nb, self.nk = nb, check_int(nk, "nk", low=0)
        self._nd = self.nc + self.nd + self.nf

    def _check_inputs(self, U):
        if U.shape[1] != 1:
            raise param_error("u", "one input signal (shape (N,) or (N, 1)) for BJ",
                              f"<{U.shape[1]} columns>")

    # ------------------------------------------------------------ layout
    def _parts(self, theta):
        nb, nc, nd = self.nb, self.nc, self.nd
        return (theta[:nb], theta[nb: nb + nc], theta[nb + nc: nb + nc + nd],
                theta[nb + nc + nd:])

    def _split(self, theta):
        b, c, _, f = self._parts(theta)
        return np.zeros(0), [b], c, [f]

    def _names(self):
        return tuple([f"b{j}" for j in range(self.nb)] +
                     [f"c{j}" for j in range(1, self.nc + 1)] +
                     [f"d{j}" for j in range(1, self.nd + 1)] +
                     [f"f{j}" for j in range(1, self.nf + 1)])

    @property
    def D(self):
        """D polynomial (noise denominator), shape (nd + 1,)."""
        self._check_fitted()
        return np.concatenate([[1.0], self._parts(self.theta)[2]])

    def _signal_spec(self, nfix):
        # signals: 0 = w (simulated output), 1 = v = y - w, 2 = ε (residual)
        nb, nc, nd, nf = self.nb, self.nc, self.nd, self.nf
        n = nb + nc + nd + nf
        plant = np.zeros(n, dtype=bool)
        plant[:nb] = True
        plant[nb + nc + nd:] = True
        mix = np.zeros((3, n))
        mix[0, plant] = 1.0
        mix[1, plant] = -1.0
        mix[2, :] = -1.0
        alpha = np.array([0.0, 1.0, 1.0])
        dyn_group = np.r_[np.full(nc, 2), np.full(nd, 1), np.full(nf, 0)].astype(np.int64)
        dyn_lag = np.r_[np.arange(1, nc + 1), np.arange(1, nd + 1),
                        np.arange(1, nf + 1)].astype(np.int64)
        dyn_sgn = np.r_[np.ones(nc), -np.ones(nd), -np.ones(nf)]
        return alpha, mix, dyn_group, dyn_lag, dyn_sgn

    # ------------------------------------------------- prediction errors
    def _errors(self, theta, Phi_fix, Y):
        r"""ε = D/C (y − B/F u) and ψ = −∂ε/∂θ (Ljung 1999, eq. 10.54)."""
        b, c, d, f = self._parts(np.asarray(theta, dtype=np.float64))
        C = np.concatenate([[1.0], c])
        D = np.concatenate([[1.0], d])
        F = np.concatenate([[1.0], f])
        w = self._filt(F, Phi_fix @ b)
        v = Y - w
        eps = signal.lfilter(D, C, v)
        CF = np.convolve(C, F)
        psi_b = _lf(D, CF, Phi_fix)
        psi_c = _lf([1.0], C, lagmat(eps, self.nc))
        psi_d = -_lf([1.0], C, lagmat(v, self.nd))
        psi_f = -_lf(D, CF, lagmat(w, self.nf))
        return eps, np.hstack([psi_b, psi_c, psi_d, psi_f])

    def _refine(self, theta, Phi_fix, Y, max_nfev=None):
        # a trial step may put a root of C or F outside the unit circle: the
        # filtered errors then overflow, least_squares rejects the step (an
        # inf cost) and shrinks its trust region; that is not worth a warning
        with np.errstate(over="ignore", invalid="ignore"):
            return super()._refine(theta, Phi_fix, Y, max_nfev=max_nfev)

    def _stable(self, theta):
        theta = np.array(theta, dtype=np.float64)
        nb, nc, nd = self.nb, self.nc, self.nd
        for lo, hi in ((nb, nb + nc), (nb + nc, nb + nc + nd), (nb + nc + nd, theta.size)):
            theta[lo:hi] = stabilize(np.concatenate([[1.0], theta[lo:hi]]))[1:]
        return theta

    # ------------------------------------------------------------- fit
    def fit(self, y, u, *, refine=True, n_iter=30, arx_order=None, max_nfev=None):
        r"""Batch fit: Steiglitz–McBride + Hannan–Rissanen start, prediction-error minimisation.

        1. B, F: :meth:`OE.fit` (Steiglitz–McBride iterations, least squares
           on y and u prefiltered by :math:`1/\hat F`, then its output-error
           minimisation, which unlike Steiglitz–McBride stays consistent
           for coloured noise);
        2. C, D: :meth:`ARMA.fit` of :math:`\hat v = y - \hat B/\hat F\,u`
           (Hannan–Rissanen, no refinement);
        3. with ``refine=True`` (default): minimise
           :math:`\sum_k\varepsilon_k^2(\theta)`,
           :math:`\varepsilon = \frac{D}{C}\big(y - \frac{B}{F}u\big)`, by
           :func:`scipy.optimize.least_squares` with the analytic gradient
           :math:`\psi_b = \frac{D}{CF}u_{k-n_k-j}`,
           :math:`\psi_c = \varepsilon_{k-j}/C`,
           :math:`\psi_d = -v_{k-j}/C`,
           :math:`\psi_f = -\frac{D}{CF}w_{k-j}` (Ljung 1999, sec. 10.3).

        Parameters
        ----------
        y : array_like, shape (N,)
        u : array_like, shape (N,) or (N, 1)
        refine : bool
            Run step 3 (default True); False keeps the start estimate.
        n_iter : int
            Steiglitz–McBride iterations at most (default 30).
        arx_order : int, optional
            Long AR order of the Hannan–Rissanen step.
        max_nfev : int, optional
            Function evaluations of the minimisation at most.

        Returns
        -------
        self
        """
        from ._ar import ARMA
        from ._oe import OE

        reg, Phi_fix = self._prepare(y, u)
        y = as_float_array(y, "y", ndim=1)
        U = np.asarray(u, dtype=np.float64).reshape(y.shape[0], -1)
        oe = OE(self.nb, self.nf, self.nk).fit(y, U[:, 0], n_iter=n_iter, refine=True)
        bf = oe.theta
        c, d = np.zeros(self.nc), np.zeros(self.nd)
        if self.nc + self.nd:
            vhat = y - oe.simulate(U[:, 0])
            if self.nd:
                arma = ARMA(self.nd, self.nc).fit(vhat, refine=False, arx_order=arx_order)
                d, c = arma.theta[: self.nd], arma.theta[self.nd:]
            else:  # MA noise: Hannan-Rissanen of an ARMA(1, nc), keeping its C
                arma = ARMA(1, self.nc).fit(vhat, refine=False, arx_order=arx_order)
                c = arma.theta[1:]
        theta = self._stable(np.r_[bf[: self.nb], c, d, bf[self.nb:]])
        if refine:
            theta = self._refine(theta, Phi_fix, reg.y, max_nfev=max_nfev)
        self._finish(theta, Phi_fix, reg.y, reg)
        return self

    # ------------------------------------------------------ prediction
    def predict(self, y, u, k=1):
        r"""k-step-ahead prediction with the noise model H = C/D.

        .. math::

            \hat y_{t|t-k} = \frac{\bar H_k D B}{C F}u_t + \frac{C - \bar H_k D}{C}\,y_t,

        :math:`\bar H_k` the impulse response of C/D truncated to k terms
        (Ljung 1999, eq. 3.31); signals zero before the first sample.

        Parameters
        ----------
        y : array_like, shape (N,)
        u : array_like, shape (N,) or (N, 1)
        k : int
            Horizon, ``>= 1`` (default 1).

        Returns
        -------
        ndarray, shape (N,)
        """
        y, U = self._data(y, u)
        k = check_int(k, "k", low=1)
        _, Bs, C, Fs = self._polys()
        D = self.D
        Hk = self._hbar(k, D, C)
        HD = np.convolve(Hk, D)
        out = signal.lfilter(_poly_sub(C, HD), C, y)
        return out + signal.lfilter(np.convolve(HD, Bs[0]), np.convolve(C, Fs[0]), U[:, 0])

    def simulate(self, u, *, noise=None):
        r"""Simulated output :math:`B/F\,u` (plus :math:`C/D\,e` when ``noise`` = e is given).

        Parameters
        ----------
        u : array_like, shape (N,) or (N, 1)
        noise : array_like, shape (N,), optional

        Returns
        -------
        ndarray, shape (N,)
        """
        U = self._inputs(u)
        _, Bs, C, Fs = self._polys()
        out = signal.lfilter(Bs[0], Fs[0], U[:, 0])
        if noise is not None:
            e = as_float_array(noise, "noise", shape=(U.shape[0],))
            out = out + signal.lfilter(C, self.D, e)
        return out
