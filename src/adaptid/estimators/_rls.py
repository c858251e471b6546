r"""Recursive least squares with prior (ridge) and forgetting: the RLS algorithm."""

from __future__ import annotations

import numpy as np

from .. import _config
from .._validation import check_int, check_scalar, param_error
from ..forgetting import ConstantTrace, EFRA, resolve as _resolve_forgetting
from ._engine import RecursiveEstimator
from ._forgetting import ForgettingMixin
from ._rlsforms import FormsMixin, ntag_for, resolve_form
from ._spec import AlgorithmSpec

__all__ = ["RLS"]


def _variant(est):
    """The kernels of an RLS: its exact diffuse start, its strategy (or ``P_max``), or its form."""
    if est._diffuse:
        return "diffuse"
    return est._form if est._fast else "strategy"


class RLS(FormsMixin, ForgettingMixin, RecursiveEstimator):
    r"""Recursive least squares with prior (ridge) and exponential forgetting.

    After samples 1..N the estimate minimises

    .. math::

        V_N(\theta) = \sum_{k=1}^{N} \Big(\prod_{i=k+1}^{N}\lambda_i\Big) w_k
            (y_k - \varphi_k^T\theta)^2
          + \Big(\prod_{i=1}^{N}\lambda_i\Big)(\theta-\theta_0)^T P_0^{-1}(\theta-\theta_0),

    and ``P`` is the inverse of half its Hessian. Per sample
    (Ljung & Söderström 1983, eqs. 2.19–2.20, in three steps: error, gain, update):

    .. math::

        \varepsilon_k = y_k - \varphi_k^T\hat\theta_{k-1},\quad
        K_k = \frac{P_{k-1}\varphi_k}{\lambda_k/w_k + \varphi_k^T P_{k-1}\varphi_k},\quad
        \hat\theta_k = \hat\theta_{k-1} + K_k\varepsilon_k,\quad
        P_k = \frac{1}{\lambda_k}\big(P_{k-1} - K_k\varphi_k^T P_{k-1}\big).

    P is propagated in U-D factored form (Bierman's algorithm), which keeps
    it symmetric positive definite and accurate even with a diffuse prior.

    Parameters
    ----------
    n_params : int
        Number of parameters n.
    forgetting : float or ForgettingStrategy, optional
        λ ∈ (0, 1]; 1 (default) means no forgetting. Per-sample values are
        given to :meth:`update` / :meth:`run`. Or a strategy of
        :mod:`adaptid.forgetting` (``Directional``, ``ConstantTrace``,
        ``EFRA``, ``Variable``) that keeps P bounded when excitation is lost;
        the factor it applied at each sample is ``Trajectory.forgetting``.
    P_max : float, optional
        Bound on P for exponential and variable forgetting: each pivot
        :math:`D_i` of :math:`P = UDU^T` (a conditional variance) is
        forgotten only up to ``P_max``, so an unexcited direction stops
        growing while the excited ones keep forgetting. With directional
        forgetting, a step that would take a diagonal element of P past
        ``P_max`` forgets nothing. See :mod:`adaptid.forgetting`.
    windup_threshold : float, optional
        A :class:`~adaptid.CovarianceWindupWarning` is emitted (once, until
        :meth:`reset`) when a pivot :math:`D_i` of :math:`P = UDU^T` passes
        it (each pivot is at most trace(P)), or when P loses definiteness.
        Default ``1e6 * max(diag(P0))``; ``inf`` watches definiteness only.
    theta0 : array_like, shape (n,) or (n, p), optional
        Prior mean θ₀ (default zeros).
    P0 : float, array_like, shape (n, n), or "diffuse"
        Prior covariance: a scalar c means c·I (default 1e4); a matrix must be
        symmetric positive definite. ``P0 → ∞`` with λ = 1 gives ordinary
        least squares; ``"diffuse"`` is that limit taken exactly (no ridge
        term 1/P0 left; see Notes). Not with a forgetting strategy or
        ``P_max``; ``theta0`` must then be None.
    nan_policy : {"raise", "skip"}
        What a sample with NaN or inf in φ or y does: raise ``ValueError``
        (default), or be skipped — θ and P are left exactly as they were (no
        forgetting is applied either: a missing sample carries no
        information and takes no time), the error is NaN and the sample is
        counted in ``Trajectory.skipped`` / ``n_skipped``.
    n_outputs : int, optional
        p outputs sharing the regressor: θ has shape (n, p), one P.
    form : {"auto", "ud", "sqrt", "covariance"}
        How P is propagated with plain exponential forgetting (a strategy or
        ``P_max`` always uses "ud"): U-D factors (Bierman), a square root
        P = S Sᵀ (Potter), or P itself,
        exactly symmetric, with a definiteness monitor that repairs P
        (:class:`~adaptid.DefinitenessLossWarning`). "auto" (default): U-D for
        n ≤ 15, for n > 64 and with ``P0="diffuse"``, the square root for
        16 ≤ n ≤ 64 (the faster form at each n, ``benchmarks/bench_rls_forms.py``); ``run(stats=True)``
        continues a square-root estimator in U-D form. The C export (:meth:`to_c`) runs U-D. See
        :mod:`adaptid.estimators._rlsforms`; ``RLS.from_state(state, form=...)``
        converts a state between forms.

    Attributes
    ----------
    theta : ndarray, shape (n,) or (n, p)
    P : ndarray, shape (n, n)
        inf entries while a diffuse start is not yet identified.
    identified : bool
        False only during the diffuse phase of ``P0="diffuse"``.
    n_updates : int
        Samples processed (skipped ones not counted).

    Notes
    -----
    Exact diffuse start (``P0="diffuse"``): the prior term of :math:`V_N` is
    dropped. A square-root information filter (Bierman 1977, ch. V–VI) keeps
    an upper triangular :math:`R` and :math:`z` with

    .. math::

        R_k^T R_k = \lambda_k R_{k-1}^T R_{k-1} + w_k\varphi_k\varphi_k^T,\qquad
        R_k^T z_k = \lambda_k R_{k-1}^T z_{k-1} + w_k\varphi_k y_k

    (scaling by :math:`\sqrt{\lambda_k}`, the row :math:`\sqrt{w_k}[\varphi_k^T, y_k]`
    rotated in by Givens rotations). While :math:`R_k` is numerically
    singular (:math:`\sigma_{\min} \le 10^{-10}\sigma_{\max}`,
    ``adaptid._config.DIFFUSE_RCOND``) θ is the minimum-norm least-squares
    solution and ``identified`` is False (``P`` inf, :meth:`predict` NaN). At
    the first sample of full rank :math:`\hat\theta = R^{-1}z` — the exact
    (weighted, forgotten) least-squares solution — and the U-D factors of
    :math:`P = WW^T`, :math:`W = R^{-1}`, are :math:`U = W\,\mathrm{diag}(W)^{-1}`,
    :math:`D = \mathrm{diag}(W)^2`; the ordinary recursion continues from
    there. A large finite P0 instead leaves the ridge term and differs from
    least squares by about :math:`\|(\Phi^T\Phi)^{-1}\|/P_0` relative.

    References
    ----------
    .. [1] G. J. Bierman, *Factorization Methods for Discrete Sequential
       Estimation*, Academic Press, 1977, ch. V.
    .. [2] L. Ljung, T. Söderström, *Theory and Practice of Recursive
       Identification*, MIT Press, 1983.

    Examples
    --------
    >>> import numpy as np, adaptid
    >>> rng = np.random.default_rng(0)
    >>> Phi = rng.standard_normal((500, 3)); y = Phi @ [1.0, -2.0, 0.5]
    >>> est = adaptid.RLS(3, P0=1e8)
    >>> traj = est.run(Phi, y)
    >>> bool(np.allclose(est.theta, [1.0, -2.0, 0.5]))
    True
    >>> exact = adaptid.RLS(3, P0="diffuse")     # no prior: least squares from sample 3 on
    >>> exact.run(Phi[:3], y[:3]).identified.tolist()
    [False, False, True]
    >>> bool(np.allclose(exact.theta, [1.0, -2.0, 0.5], rtol=1e-12, atol=0))
    True
    """

    spec = AlgorithmSpec(
        method="rls",
        kernels={"ud": "RLS", "sqrt": "POTTER", "covariance": "COVARIANCE",
                 "strategy": "STRATEGY", "diffuse": "RLS_DIFFUSE"},
        options=("forgetting", "P_max", "nan_policy", "windup_threshold", "form"),
        variant=_variant,
        diffuse_tail=lambda n, p: 1 + n * n + n * p,  # [flag, R, z]
        reports_forgetting=("strategy",),
        # the statistics hooks are in the U-D stream; the square-root form hands over
        # to it (FormsMixin._before_stats), the covariance form (MATLAB's arithmetic)
        # and the strategies have none
        stats=("ud", "sqrt", "diffuse"))

    def __init__(self, n_params, *, forgetting=1.0, P_max=None, theta0=None, P0=1e4,
                 nan_policy="raise", n_outputs=None, windup_threshold=None, form="auto"):
        self.forgetting, self._lam, self._strategy = _resolve_forgetting(forgetting)
        if P_max is not None:
            P_max = check_scalar(P_max, "P_max", low=0.0, low_open=True)
            if isinstance(self._strategy, (ConstantTrace, EFRA)):
                raise param_error("P_max", f"None with {type(self._strategy).__name__} "
                                  "forgetting (it bounds P by itself)", P_max)
        self.P_max = P_max
        strat = self._strategy
        self._fast = strat is None and P_max is None
        if isinstance(P0, str) and not self._fast:
            raise param_error("P0", "a positive scalar or an SPD matrix with a forgetting "
                              "strategy or P_max ('diffuse' needs constant or per-sample "
                              "exponential forgetting)", P0)
        self._form = resolve_form(form, check_int(n_params, "n_params", low=1), self._fast,
                                  diffuse=isinstance(P0, str))
        if isinstance(P0, str) and self._form != "ud":
            raise param_error("form", "'auto' or 'ud' with P0='diffuse' (the exact diffuse start "
                              "hands over to the U-D form)", form)
        super().__init__(n_params, theta0=theta0, P0=P0, nan_policy=nan_policy,
                         n_outputs=n_outputs, windup_threshold=windup_threshold)
        self._ntag = ntag_for(self._form, self.n_params, self._ntag)
        if isinstance(strat, EFRA):
            bound = (1 - strat.alpha) / (strat.lam * strat.delta) if strat.delta > 0 else np.inf
            if np.linalg.eigvalsh(self.P0)[-1] > bound:
                raise param_error("P0", f"with eigenvalues <= (1 - alpha)/(lam delta) = {bound:.4g} "
                                  "for EFRA forgetting (a larger P makes its -delta P^2 term "
                                  "turn P indefinite)", "<a larger P0>")

    def _kernel_options(self):
        if self._diffuse:
            return np.array([self._windup_threshold, _config.DIFFUSE_RCOND]), np.zeros((1, 1))
        if self._fast:
            return np.array([self._windup_threshold]), np.zeros((1, 1))
        strat = self._strategy
        mode = strat._mode if strat is not None else 0
        fp = strat._params_n(self.n_params) if strat is not None else np.zeros(1)
        pmax = np.inf if self.P_max is None else self.P_max
        return np.array([self._windup_threshold, mode, pmax]), np.atleast_2d(fp).copy()
