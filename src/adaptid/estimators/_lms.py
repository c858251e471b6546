r"""Least mean squares and normalised LMS: the stochastic-gradient estimators."""

from __future__ import annotations

import warnings

import numpy as np

from .._exceptions import DivergenceWarning
from .._validation import check_scalar
from ._engine import RecursiveEstimator
from ._spec import AlgorithmSpec

__all__ = ["LMS", "NLMS"]

#: MATLAB's default ``NormalizationBias`` of ``recursiveLS``: eps(1).
_MATLAB_BIAS = float(np.finfo(np.float64).eps)


class _Gradient(RecursiveEstimator):
    """The engine for a state of θ only (no covariance, no forgetting)."""

    def __init__(self, n_params, *, step, theta0=None, nan_policy="raise", n_outputs=None):
        self.step = check_scalar(step, "step", low=0.0, low_open=True)
        super().__init__(n_params, theta0=theta0, nan_policy=nan_policy, n_outputs=n_outputs)

    def _kernel_options(self):
        return np.array([np.inf, self.step, getattr(self, "eps", 0.0)]), np.zeros((1, 1))

    def _warn_nonpositive(self, where):
        if self._windup_warned:
            return  # once per episode: reset() re-arms the warning
        self._windup_warned = True
        warnings.warn(
            f"{type(self).__name__}: the estimate diverged (θ not finite) or the data "
            f"overflowed or underflowed (φᵀφ not a normal float) at sample {where}; "
            f"step={self.step:g} too large, or data to rescale", DivergenceWarning,
            stacklevel=3)

    def _warn_segments(self, status):
        bad = np.flatnonzero(status >= 0)
        if bad.size:
            warnings.warn(
                f"{type(self).__name__}: in {bad.size} segment(s) (first: segment {int(bad[0])}, "
                f"sample {int(status[bad[0]])}) the estimate diverged (θ not finite) or the "
                f"data overflowed or underflowed; step={self.step:g} too large, or data to "
                "rescale", DivergenceWarning, stacklevel=3)


class LMS(_Gradient):
    r"""Least mean squares: the stochastic-gradient estimator (MATLAB's ``Gradient``).

    Per sample (MATLAB ``recursiveLS`` with ``EstimationMethod="Gradient"``,
    ``AdaptationGain`` = μ; padasip ``FilterLMS`` with ``mu`` = μ; Widrow &
    Stearns 1985, eq. 6.3):

    .. math::

        \varepsilon_k = y_k - \varphi_k^T\hat\theta_{k-1},\qquad
        \hat\theta_k = \hat\theta_{k-1} + \mu\,w_k\,\varphi_k\,\varepsilon_k .

    There is no covariance: ``P``, ``excitation`` and ``P0`` do not exist
    (``P`` raises AttributeError, ``run_segments`` returns ``P=None``), no
    forgetting factor applies (``forgetting=`` raises ValueError), and the
    standard errors of :func:`adaptid.recursive_fit_stats` are NaN. The
    estimate converges in the mean for :math:`0 < \mu < 2/\lambda_{max}(E\,\varphi\varphi^T)`;
    a θ that overflows raises :class:`~adaptid.DivergenceWarning` (so does, for
    :class:`NLMS`, a normalisation ε + φᵀφ that overflows or underflows).

    Parameters
    ----------
    n_params : int
        Number of parameters n.
    step : float
        μ > 0, the adaptation gain.
    theta0 : array_like, shape (n,) or (n, p), optional
        Initial estimate (default zeros).
    nan_policy : {"raise", "skip"}
        As for :class:`~adaptid.RLS`: a sample with NaN or inf raises
        ``ValueError`` (state unchanged) or is skipped (θ unchanged, error NaN).
    n_outputs : int, optional
        p outputs sharing the regressor: θ has shape (n, p).

    Notes
    -----
    The weights wₖ of :meth:`update` / :meth:`run` scale the step (wₖ = 0:
    the sample is not used). The engine's interface is that of
    :class:`~adaptid.RLS`: ``update``, ``run``, ``run_batched``,
    ``run_segments``, ``predict``, ``get_state`` / ``from_state``,
    ``save_state`` / ``load_state``. The state vector is θ only,
    ``[theta (n·p, row-major (n, p))]``.

    References
    ----------
    .. [1] B. Widrow, S. D. Stearns, *Adaptive Signal Processing*,
       Prentice-Hall, 1985, ch. 6.
    .. [2] MathWorks, ``recursiveLS`` (System Identification Toolbox),
       "Gradient" estimation method.

    Examples
    --------
    >>> import numpy as np, adaptid
    >>> rng = np.random.default_rng(0)
    >>> Phi = rng.standard_normal((4000, 3)); y = Phi @ [1.0, -2.0, 0.5]
    >>> est = adaptid.LMS(3, step=0.05)
    >>> traj = est.run(Phi, y)
    >>> bool(np.allclose(est.theta, [1.0, -2.0, 0.5]))
    True
    """

    spec = AlgorithmSpec(method="lms", kernels={"default": "LMS"},
                         options=("step", "nan_policy"), covariance=False)


class NLMS(_Gradient):
    r"""Normalised least mean squares (MATLAB's ``NormalizedGradient``).

    Per sample (MATLAB ``recursiveLS`` with
    ``EstimationMethod="NormalizedGradient"``, ``AdaptationGain`` = μ,
    ``NormalizationBias`` = ε; padasip ``FilterNLMS`` with ``mu`` = μ,
    ``eps`` = ε; Haykin 2002, eq. 6.44):

    .. math::

        \varepsilon_k = y_k - \varphi_k^T\hat\theta_{k-1},\qquad
        \hat\theta_k = \hat\theta_{k-1}
            + \frac{\mu\,w_k}{\epsilon + \varphi_k^T\varphi_k}\,\varphi_k\,\varepsilon_k .

    Stable for 0 < μ < 2 whatever the regressors' scale. A sample with
    φ = 0 and ε = 0 leaves θ unchanged. As :class:`LMS`, no covariance, no
    forgetting and NaN standard errors.

    Parameters
    ----------
    n_params : int
    step : float
        μ > 0.
    eps : float
        ε ≥ 0, the normalisation bias. Default ``2.22e-16`` (MATLAB's
        default ``NormalizationBias``, eps(1)); padasip's default is 1e-3.
    theta0, nan_policy, n_outputs
        As for :class:`LMS`.

    References
    ----------
    .. [1] S. Haykin, *Adaptive Filter Theory*, 4th ed., Prentice-Hall,
       2002, sec. 6.1.
    .. [2] MathWorks, ``recursiveLS`` (System Identification Toolbox),
       "NormalizedGradient" estimation method.

    Examples
    --------
    >>> import numpy as np, adaptid
    >>> rng = np.random.default_rng(0)
    >>> Phi = rng.standard_normal((2000, 3)); y = Phi @ [1.0, -2.0, 0.5]
    >>> est = adaptid.NLMS(3, step=0.5)
    >>> traj = est.run(Phi, y)
    >>> bool(np.allclose(est.theta, [1.0, -2.0, 0.5]))
    True
    """

    spec = AlgorithmSpec(method="nlms", kernels={"default": "NLMS"},
                         options=("step", "eps", "nan_policy"), covariance=False)

    def __init__(self, n_params, *, step, eps=_MATLAB_BIAS, theta0=None, nan_policy="raise",
                 n_outputs=None):
        self.eps = check_scalar(eps, "eps", low=0.0)
        super().__init__(n_params, step=step, theta0=theta0, nan_policy=nan_policy,
                         n_outputs=n_outputs)
