r"""The ARMAX model :math:`A(q)y_k = B(q)u_k + C(q)e_k`."""

from __future__ import annotations

import numpy as np

from .._validation import check_int
from ._pem import _PseudoLinearModel, stabilize

__all__ = ["ARMAX"]


class ARMAX(_PseudoLinearModel):
    r"""ARMAX model, identified by extended least squares and prediction errors.

    .. math::

        A(q)y_k = \sum_i B_i(q)u^{(i)}_k + C(q)e_k,\qquad
        \theta = [a_1..a_{n_a},\ b\dots,\ c_1..c_{n_c}].

    The one-step predictor is pseudo-linear,
    :math:`\hat y_k = \varphi_k^T\theta` with
    :math:`\varphi_k = [-y_{k-1}, \dots, u_{k-n_k}, \dots,
    \varepsilon_{k-1}, \dots, \varepsilon_{k-n_c}]` and
    :math:`C(q)\varepsilon_k = A(q)y_k - B(q)u_k`, so the estimates follow
    from least squares on a regressor that contains estimated residuals:

    * :meth:`fit_recursive` — recursive extended least squares (RELS,
      a-posteriori residuals, Ljung 1999, sec. 11.3; Söderström & Stoica
      1989, sec. 9.4), one compiled pass with any core estimator;
    * :meth:`fit` — batch: the Hannan–Rissanen three-stage least squares
      (:func:`adaptid.lstsq`): a long ARX model gives residuals, least
      squares on the extended regressor, one Gauss–Newton correction.

    RELS is consistent when :math:`1/C(e^{i\omega}) - 1/2` is strictly
    positive real; Hannan–Rissanen for a long enough ARX order. :meth:`fit`
    then (``refine=True``, the default) refines the estimate by
    minimising the prediction-error criterion :math:`\sum_k\varepsilon_k^2(\theta)`
    (:func:`scipy.optimize.least_squares` with the analytic gradient
    :math:`\psi_k = \varphi_k/C(q)`), which is the maximum-likelihood
    estimate for Gaussian e. Roots of C outside the unit circle are
    reflected inside (the predictor must be stable).

    The rows are the samples k = s … N-1, :math:`s = \max(n_a, n_k+n_b-1)`,
    with :math:`\varepsilon_k = 0` before the first row. ``cov`` is the
    asymptotic prediction-error covariance
    :math:`\hat\sigma^2(\Psi^T\Psi)^{-1}` (Ljung 1999, eq. 9.17).

    Parameters
    ----------
    na, nb, nc, nk : int (nb, nk: or per input)
        Orders (``>= 0``) and input delays.
    dt : float
        Sample time (default 1.0).

    References
    ----------
    .. [1] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
       Prentice Hall, 1999.
    .. [2] T. Söderström, P. Stoica, *System Identification*, Prentice Hall,
       1989.
    .. [3] E. J. Hannan, J. Rissanen, "Recursive estimation of mixed
       autoregressive-moving average order", *Biometrika* 69(1), 1982.
    """

    _order_names = ("na", "nb", "nc", "nk")
    _alpha, _beta, _sgn = 1.0, -1.0, 1.0

    def __init__(self, na, nb, nc, nk=1, *, dt=1.0):
        self._init_orders(na, nb, nc, 0, nk, dt)
        self._nd = self.nc

    def _split(self, theta):
        a = theta[: self.na]
        bs, o = [], self.na
        for b in self._nb:
            bs.append(theta[o: o + b])
            o += b
        return a, bs, theta[o: o + self.nc], [np.zeros(0)] * self._m

    def _names(self):
        names = [f"a{j}" for j in range(1, self.na + 1)]
        for i, b in enumerate(self._nb):
            names += [f"b{j}" if self._single else f"b{i}_{j}" for j in range(b)]
        return tuple(names + [f"c{j}" for j in range(1, self.nc + 1)])

    def _errors(self, theta, Phi_fix, Y):
        nab = Phi_fix.shape[1]
        C = np.concatenate([[1.0], theta[nab:]])
        eps = self._filt(C, Y - Phi_fix @ theta[:nab])
        Phi = np.hstack([Phi_fix, self._lag(eps, self.nc)])
        return eps, self._filt(C, Phi)

    def _stable(self, theta):
        theta = np.array(theta, dtype=np.float64)
        nab = theta.size - self.nc
        theta[nab:] = stabilize(np.concatenate([[1.0], theta[nab:]]))[1:]
        return theta

    def fit(self, y, u=None, *, refine=True, arx_order=None, nan_policy="omit"):
        r"""Batch fit: the Hannan–Rissanen three-stage least squares, then prediction-error refinement.

        1. a long ARX model, fitted by least squares, gives residuals
           :math:`\hat e_k` that approximate the innovations;
        2. least squares on :math:`[\varphi^{ARX}_k, \hat e_{k-1}, \dots, \hat e_{k-n_c}]`
           gives A, B, C;
        3. one Gauss–Newton step on the prediction errors (least squares of
           :math:`\varepsilon(\hat\theta)` on the gradient Ψ), kept if it
           lowers the loss.

        Every solve is :func:`adaptid.lstsq` (QR). Hannan & Rissanen (1982);
        Söderström & Stoica (1989), complement C7.4.

        Parameters
        ----------
        y : array_like, shape (N,); pandas Series; or IDData (``u`` then omitted)
        u : array_like, shape (N,) or (N, m); pandas
        refine : bool
            Refine by minimising the prediction-error criterion from the
            Hannan–Rissanen estimate (default True, as MATLAB's ``armax``;
            False gives the three-stage estimate alone).
        arx_order : int, optional
            Order of the long ARX model for the initial residuals (default
            ``max(20, 3 (na + nc))``, capped by the record length).
        nan_policy : {"omit", "raise"}
            ``"omit"`` (default): NaN samples are gaps: the record is split at each run of NaN into separate experiments (the filters restart after each gap)
            (``n_dropped`` counts the rows lost, and ``summary()`` reports
            it). ``"raise"``: a NaN in y or u is refused (ValueError naming
            the signal).

        Returns
        -------
        self
        """
        from .._lstsq import lstsq

        from ._segments import check_nan_policy

        self._nan_policy = check_nan_policy(nan_policy)
        y, U = self._data(y, u, fitting=True)
        reg, Phi_fix = self._fixed_regression(y, U, self._single)
        Y = reg.y
        if self.nc == 0:
            theta = np.asarray(lstsq(Phi_fix, Y).theta)
        else:
            from ._builders import arx_regressors

            L = max(20, 3 * (self.na + self.nc)) if arx_order is None else \
                check_int(arx_order, "arx_order", low=1)
            ys, Us, sb = self._segment_signals(y, U)
            longest = int(np.max(np.diff(sb)))
            L = max(1, min(L, longest // (4 * (1 + self._m))))
            # long ARX: its residuals approximate the innovations (Hannan-Rissanen),
            # formed inside each experiment and run between gaps
            pieces = [(ys[a:b], Us[a:b, 0] if self._single else Us[a:b])
                      for a, b in zip(sb[:-1], sb[1:])]
            regL = arx_regressors([p[0] for p in pieces], [p[1] for p in pieces], L,
                                  [b + L if b else 0 for b in self._nb], self._nk)
            resL = lstsq(regL.Phi, regL.y)
            eps_full = np.zeros(ys.size)
            eps_full[regL.index] = np.asarray(resL.residuals)
            eps = eps_full[reg.meta["seg_index"]]
            Phi = np.hstack([Phi_fix, self._lag(eps, self.nc)])
            theta = self._stable(np.asarray(lstsq(Phi, Y).theta))
            # stage 3: one Gauss-Newton step on the prediction errors, by least squares
            eps, Psi = self._errors(theta, Phi_fix, Y)
            step = self._stable(theta + np.asarray(lstsq(Psi, eps).theta))
            if np.sum(self._errors(step, Phi_fix, Y)[0] ** 2) <= np.sum(eps ** 2):
                theta = step
        if refine:
            theta = self._refine(theta, Phi_fix, Y)
        self._finish(theta, Phi_fix, Y, reg)
        return self
