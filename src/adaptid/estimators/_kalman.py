r"""Kalman filter for a random-walk parameter."""

from __future__ import annotations

import numpy as np

from .. import _config
from .._validation import as_float_array, check_int, check_scalar, param_error, symmetrised
from . import _kalmanfit, _kalmansmooth
from ._engine import RecursiveEstimator
from ._spec import AlgorithmSpec

__all__ = ["KalmanRLS"]


class KalmanRLS(RecursiveEstimator):
    r"""Kalman filter for a random-walk parameter.

    Model: :math:`\theta_k = \theta_{k-1} + \nu_k`, :math:`E\,\nu\nu^T = R_1`,
    :math:`y_k = \varphi_k^T\theta_k + e_k`, :math:`E\,e^2 = R_2`. Per sample
    (recursive-identification note, Kalman filter for a random walk; Ljung &
    Söderström 1983, eq. 2.114):

    .. math::

        K_k = \frac{P_{k-1}\varphi_k}{R_2/w_k + \varphi_k^T P_{k-1}\varphi_k},\quad
        \hat\theta_k = \hat\theta_{k-1} + K_k\varepsilon_k,\quad
        P_k = P_{k-1} - K_k\varphi_k^T P_{k-1} + R_1 .

    This is the measurement update followed by the time update ("update then
    predict"). The measurement update is Bierman's; the time update forms
    ``U D Uᵀ + R₁`` and re-factorises it. Under ``nan_policy="skip"`` a
    missing sample gets the time update only (P grows by R₁, θ unchanged).

    :meth:`smooth` gives the smoothed track θ(k|N) with its covariance
    (Rauch–Tung–Striebel), :meth:`loglike` the Gaussian log-likelihood of the
    data under this model and :meth:`fit_variances` the maximum-likelihood
    R₁ and R₂; all three run from the prior and leave the state unchanged
    (``docs/models/smoothing.md``).

    Parameters
    ----------
    n_params : int
    process_cov : float or array_like, shape (n, n)
        R₁ ≥ 0: a scalar q means q·I; a matrix must be symmetric positive
        semi-definite.
    noise_var : float
        R₂ > 0 (default 1).
    theta0, P0, nan_policy, n_outputs
        As for :class:`RLS`. ``P0="diffuse"`` is the exact diffuse
        initialisation of Koopman and Durbin (Durbin & Koopman 2012, §5.2,
        univariate treatment §6.4): :math:`P = \kappa P_\infty + P_*`,
        :math:`\kappa\to\infty`, :math:`P_\infty = I`, :math:`P_* = 0`; per
        sample with :math:`F_\infty = \varphi^TP_\infty\varphi`,
        :math:`F_* = \varphi^TP_*\varphi + R_2/w`,
        :math:`M_\infty = P_\infty\varphi`, :math:`M_* = P_*\varphi`:

        .. math::

            F_\infty > 0:\; \hat\theta \mathrel{+}= \frac{M_\infty}{F_\infty}\varepsilon,\;
            P_* \mathrel{+}= \frac{F_*}{F_\infty^2}M_\infty M_\infty^T
              - \frac{M_*M_\infty^T + M_\infty M_*^T}{F_\infty},\;
            P_\infty \mathrel{-}= \frac{M_\infty M_\infty^T}{F_\infty};\qquad
            F_\infty = 0:\; \hat\theta \mathrel{+}= \frac{M_*}{F_*}\varepsilon,\;
            P_* \mathrel{-}= \frac{M_*M_*^T}{F_*},

        then :math:`P_* \mathrel{+}= R_1`. After n steps with
        :math:`F_\infty > 0` (:math:`F_\infty > 10^{-10}\varphi^T\varphi`)
        :math:`P_\infty = 0`, ``identified`` becomes True and the U-D filter
        continues from :math:`P_*`. The filtered θ equals statsmodels'
        state-space filter with ``initialization="diffuse"``.

    References
    ----------
    .. [1] J. Durbin, S. J. Koopman, *Time Series Analysis by State Space
       Methods*, 2nd ed., Oxford University Press, 2012, §5.2, §6.4.
    """

    spec = AlgorithmSpec(
        method="kalman",
        kernels={"default": "KALMAN", "diffuse": "KALMAN_DIFFUSE"},
        options=("process_cov", "noise_var", "nan_policy", "windup_threshold"),
        diffuse_tail=lambda n, p: 2 + 2 * n * n)  # [flag, rank steps, P∞, P*]

    def __init__(self, n_params, *, process_cov, noise_var=1.0, theta0=None, P0=1e4,
                 nan_policy="raise", n_outputs=None, windup_threshold=None):
        n = check_int(n_params, "n_params", low=1)
        if np.ndim(process_cov) == 0:
            q = check_scalar(process_cov, "process_cov", low=0.0)
            Q = np.eye(n) * q
        else:
            Q = symmetrised(as_float_array(process_cov, "process_cov", shape=(n, n)),
                            "process_cov")
            ev = np.linalg.eigvalsh(Q)
            if ev[0] < -100 * n * np.finfo(float).eps * max(abs(ev[-1]), 1e-300):
                raise param_error("process_cov", "positive semi-definite",
                                  f"<smallest eigenvalue {ev[0]:.3g}>")
        self.process_cov = Q
        self.noise_var = check_scalar(noise_var, "noise_var", low=0.0, low_open=True)
        super().__init__(n_params, theta0=theta0, P0=P0, nan_policy=nan_policy,
                         n_outputs=n_outputs, windup_threshold=windup_threshold)

    def _fill_diffuse(self, T):
        n = self.n_params
        T[2: 2 + n * n] = np.eye(n).ravel()  # P∞ = I, P* = 0

    def _kernel_options(self):
        skip = 1.0 if self._nan_policy == "skip" else 0.0
        opt = [self._windup_threshold, self.noise_var, skip]
        if self._diffuse:
            opt.append(_config.DIFFUSE_KALMAN_TOL)
        return np.array(opt), np.ascontiguousarray(self.process_cov)

    # smoothing and the likelihood, from the prior (._kalmansmooth, ._kalmanfit)
    smooth = _kalmansmooth.smooth
    loglike = _kalmansmooth.loglike
    fit_variances = _kalmanfit.fit_variances
