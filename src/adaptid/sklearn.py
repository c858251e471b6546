r"""scikit-learn face of the recursive estimators: :class:`RLSRegressor`.

A thin adapter: ``fit`` / ``partial_fit`` validate the data the scikit-learn
way and hand them to one of the core estimators (:class:`adaptid.RLS`,
:class:`adaptid.SlidingWindowRLS`, :class:`adaptid.KalmanRLS`), whose
compiled ``run`` does all the work. Needs scikit-learn (the
``adaptid[sklearn]`` extra); this module is imported only on request
(``adaptid.sklearn`` or ``from adaptid.sklearn import RLSRegressor``).
"""

from __future__ import annotations

try:
    from sklearn.base import BaseEstimator, RegressorMixin
    from sklearn.utils.validation import check_is_fitted
except ImportError as err:  # pragma: no cover - depends on the environment
    raise ImportError(
        "adaptid.sklearn needs scikit-learn; install it with "
        "`pip install 'adaptid[sklearn]'` (or `pip install scikit-learn`)") from err

try:  # scikit-learn >= 1.6
    from sklearn.utils.validation import validate_data as _sk_validate_data
except ImportError:  # pragma: no cover - scikit-learn 1.4 / 1.5
    _sk_validate_data = None

import numpy as np

from ._validation import as_float_array, check_choice, param_error
from .estimators._factory import METHODS as _FACTORY_METHODS

__all__ = ["RLSRegressor"]

# the least-squares methods of the factory; the gradient ones (lms, nlms: a
# step, no prior P0, no forgetting) are not offered by this regressor
_METHODS = ("auto",) + tuple(m for m in _FACTORY_METHODS if m not in ("lms", "nlms"))


def _validate(est, X, y="no_validation", *, reset, **kw):
    """``validate_data`` on scikit-learn >= 1.6, ``est._validate_data`` before."""
    if _sk_validate_data is not None:
        return _sk_validate_data(est, X, y, reset=reset, **kw)
    return est._validate_data(X, y, reset=reset, **kw)  # pragma: no cover


def _refuse_text(value, name):
    """Refuse text data ("1.5") as the core API's ``as_float_array`` does.

    scikit-learn's ``check_array`` would parse numeric strings; adaptid's
    arrays are numbers, so ``RLSRegressor`` refuses them like ``RLS.run``.
    """
    probe = value if isinstance(value, np.ndarray) else getattr(value, "to_numpy", None)
    if probe is None:
        try:
            probe = np.asarray(value)
        except Exception:  # noqa: BLE001 - ragged input: check_array reports it
            return
    elif not isinstance(probe, np.ndarray):
        probe = probe()
    kind = probe.dtype.kind
    if kind in "USV" or (kind == "O" and any(isinstance(v, (str, bytes)) for v in probe.flat)):
        raise param_error(name, "a real numeric array (not text)", probe, exc=TypeError)


def _is_one(value) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and \
        not isinstance(value, (bool, np.bool_)) and float(value) == 1.0


class RLSRegressor(RegressorMixin, BaseEstimator):
    r"""Recursive least squares as a scikit-learn regressor.

    Fits :math:`y = X\,\mathrm{coef}^T + \mathrm{intercept}` sample by sample
    in the order of the rows of X, with one of adaptid's recursive
    estimators. With regressor :math:`\varphi_k = [x_k^T, 1]^T` (the 1 only
    when ``fit_intercept``) and :math:`\theta = [\mathrm{coef}, \mathrm{intercept}]`,
    the ``"rls"`` method minimises after N samples

    .. math::

        V_N(\theta) = \sum_{k=1}^{N} \lambda^{N-k} w_k (y_k - \varphi_k^T\theta)^2
          + \lambda^{N}(\theta-\theta_0)^T P_0^{-1}(\theta-\theta_0),

    ``"window"`` keeps only the last ``window`` terms of the sum (truncated
    least squares, Yamamoto 1991, eqs. 62–74), and ``"kalman"`` runs the
    Kalman filter of a random-walk parameter with
    :math:`E\,\nu\nu^T = R_1` (``process_cov``) and :math:`E\,e^2 = R_2`
    (``noise_var``). With ``forgetting=1`` and a large ``P0`` the fit is
    ordinary least squares (:class:`sklearn.linear_model.LinearRegression`).
    ``partial_fit`` continues the recursion exactly where it stopped, so
    fitting in chunks equals one ``fit`` on the whole record, bit for bit.

    Parameters
    ----------
    forgetting : float or forgetting strategy, default 1.0
        λ ∈ (0, 1] or an object of :mod:`adaptid.forgetting`; passed
        unchanged to the core estimator (``"rls"`` and ``"window"`` only).
    window : int, optional
        M, the window length (``"window"`` method); must be ≥ the number of
        parameters (n_features + fit_intercept).
    P0 : float or array_like, shape (n_params, n_params), default 1e4
        Prior covariance (a scalar c means c·I), n_params = n_features +
        ``fit_intercept`` (the intercept is the last parameter).
    theta0 : array_like, shape (n_features,) or (n_features, n_outputs), optional
        Prior of the coefficients (default zeros); the intercept's prior is 0.
    fit_intercept : bool, default True
        Append a constant regressor 1 whose parameter is ``intercept_``.
    method : {"auto", "rls", "window", "kalman"}, default "auto"
        Core estimator: :class:`~adaptid.RLS`, :class:`~adaptid.SlidingWindowRLS`
        or :class:`~adaptid.KalmanRLS`. ``"auto"`` is ``"window"`` when
        ``window`` is given, else ``"rls"``.
    process_cov : float or array_like, shape (n_params, n_params), default 0.0
        R₁ of the ``"kalman"`` method (ignored otherwise).
    noise_var : float, default 1.0
        R₂ of the ``"kalman"`` method (ignored otherwise).

    Attributes
    ----------
    coef_ : ndarray, shape (n_features,) or (n_outputs, n_features)
        The estimate after the last sample (layout of scikit-learn's linear
        models).
    intercept_ : float or ndarray, shape (n_outputs,)
        0.0 when ``fit_intercept=False``.
    estimator_ : RLS, SlidingWindowRLS or KalmanRLS
        The core estimator holding θ, P and the recursion's state.
    sigma2_ : float
        σ̂² of the fit by :func:`adaptid.recursive_fit_stats` (the rule of
        ``adaptid fit`` and ``adaptid fleet``). Set by :meth:`fit` for a
        single output only (``partial_fit`` does not keep the earlier
        chunks, so it removes it).
    stderr_ : ndarray, shape (n_params,)
        Standard errors of ``[coef_, intercept_]`` (the intercept last, when
        ``fit_intercept``), by the same rule; set like ``sigma2_``.
    n_features_in_ : int
    feature_names_in_ : ndarray of str, shape (``n_features_in_``,)
        Only when X had string column names (a pandas DataFrame).

    References
    ----------
    .. [1] L. Ljung, T. Söderström, *Theory and Practice of Recursive
       Identification*, MIT Press, 1983, eqs. 2.19–2.20 and 2.114.
    .. [2] T. Yamamoto, "Continuous and discrete time adaptive algorithms by
       the truncated least squares method (TLSM)", 1991, eqs. 62–74.

    Examples
    --------
    >>> import numpy as np
    >>> from adaptid.sklearn import RLSRegressor
    >>> rng = np.random.default_rng(0)
    >>> X = rng.standard_normal((200, 2)); y = X @ [1.5, -0.5] + 2.0
    >>> reg = RLSRegressor(P0=1e8).fit(X, y)
    >>> bool(np.allclose(reg.coef_, [1.5, -0.5]) and np.isclose(reg.intercept_, 2.0))
    True
    """

    def __init__(self, forgetting=1.0, window=None, P0=1e4, theta0=None,
                 fit_intercept=True, method="auto", process_cov=0.0, noise_var=1.0):
        self.forgetting = forgetting
        self.window = window
        self.P0 = P0
        self.theta0 = theta0
        self.fit_intercept = fit_intercept
        self.method = method
        self.process_cov = process_cov
        self.noise_var = noise_var

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.multi_output = True
        tags.target_tags.single_output = True
        return tags

    def __sklearn_is_fitted__(self):
        return hasattr(self, "estimator_")

    def _more_tags(self):  # pragma: no cover - scikit-learn < 1.6
        return {"multioutput": True}

    # ------------------------------------------------------------- helpers
    def _resolved_method(self):
        method = check_choice(self.method, "method", _METHODS)
        if method == "auto":
            method = "rls" if self.window is None else "window"
        if method == "window" and self.window is None:
            raise param_error("window", "an integer with method='window'", None)
        if method != "window" and self.window is not None:
            raise param_error("window", f"None with method={method!r}", self.window)
        if method == "kalman" and not _is_one(self.forgetting):
            raise param_error("forgetting", "1.0 with method='kalman' (use process_cov "
                              "to track varying parameters)", self.forgetting)
        return method

    def _design(self, X):
        if not self.fit_intercept:
            return X
        return np.hstack([X, np.ones((X.shape[0], 1))])

    def _make_core(self, n_features, n_outputs):
        from .estimators import estimator
        if not isinstance(self.fit_intercept, (bool, np.bool_)):
            raise param_error("fit_intercept", "a bool", self.fit_intercept, exc=TypeError)
        method = self._resolved_method()
        n = n_features + int(bool(self.fit_intercept))
        theta0 = None
        if self.theta0 is not None:
            t0 = as_float_array(self.theta0, "theta0", ndim=(1, 2))
            want = (n_features,) if n_outputs is None else (n_features, n_outputs)
            if t0.ndim == 1 and n_outputs == 1:
                t0 = t0[:, None]
            if t0.shape != want:
                raise param_error("theta0", f"of shape {want} (n_features[, n_outputs])",
                                  f"<shape {t0.shape}>")
            if self.fit_intercept:
                t0 = np.concatenate([t0, np.zeros((1,) + t0.shape[1:])], axis=0)
            theta0 = t0
        common = dict(theta0=theta0, P0=self.P0, n_outputs=n_outputs)
        if method == "kalman":
            return estimator(method, n, process_cov=self.process_cov,
                             noise_var=self.noise_var, **common)
        if method == "window":
            common["window"] = self.window
        return estimator(method, n, forgetting=self.forgetting, **common)

    def _sample_weight(self, sample_weight, N):
        if sample_weight is None:
            return None
        w = as_float_array(sample_weight, "sample_weight", ndim=(0, 1))
        if w.ndim == 0:
            w = np.full(N, float(w))
        if w.shape != (N,):
            raise param_error("sample_weight", f"of shape ({N},) (one weight per sample)",
                              f"<shape {w.shape}>")
        if (w < 0).any():
            raise param_error("sample_weight", "non-negative", "<a negative weight>")
        if N and not (w > 0).any():
            raise param_error("sample_weight", "not all zero (no sample would count)",
                              "<all zero weights>")
        return w

    def _run(self, core, X, y, sample_weight, *, stats=False):
        """Validate the weights, run ``core`` over the rows, then publish it.

        With ``stats`` (a fit from the prior, single output): also ``sigma2_``
        and ``stderr_`` by :func:`adaptid.recursive_fit_stats`.
        """
        w = self._sample_weight(sample_weight, X.shape[0])
        Phi = self._design(X)
        # read-only inputs (e.g. memory maps) would make numba compile another
        # signature of the kernels: hand the core writable arrays
        if not Phi.flags.writeable:
            Phi = Phi.copy()
        if not y.flags.writeable:
            y = y.copy()
        traj = core.run(Phi, y, weights=w, store=False)
        self.estimator_ = core
        self._set_coef()
        for attr in ("sigma2_", "stderr_"):
            self.__dict__.pop(attr, None)
        if stats and y.ndim == 1:
            from .estimators import recursive_fit_stats
            with np.errstate(invalid="ignore", over="ignore"):
                st = recursive_fit_stats(core, Phi, y, weights=w, forgetting=traj.forgetting,
                                         used=~np.asarray(traj.skipped, dtype=bool))
            self.sigma2_ = st.sigma2
            self.stderr_ = st.stderr

    def _set_coef(self):
        theta = self.estimator_.theta            # (n,) or (n, p)
        nf = self.n_features_in_
        if theta.ndim == 1:
            self.coef_ = theta[:nf].copy()
            self.intercept_ = float(theta[nf]) if self.fit_intercept else 0.0
        else:
            self.coef_ = np.ascontiguousarray(theta[:nf].T)
            self.intercept_ = theta[nf].copy() if self.fit_intercept else np.zeros(theta.shape[1])

    def _check_xy(self, X, y, reset):
        _refuse_text(X, "X")
        _refuse_text(y, "y")
        X, y = _validate(self, X, y, reset=reset, dtype=np.float64, multi_output=True,
                         y_numeric=True)
        y = np.asarray(y, dtype=np.float64)
        return X, y

    # ------------------------------------------------------------- public API
    def fit(self, X, y, sample_weight=None):
        """Run the recursion over the rows of X from the prior.

        Parameters
        ----------
        X : array_like, shape (N, n_features)
        y : array_like, shape (N,) or (N, n_outputs)
        sample_weight : array_like, shape (N,), optional
            wₖ ≥ 0 (default 1).

        Returns
        -------
        self
        """
        X, y = self._check_xy(X, y, reset=True)
        n_outputs = None if y.ndim == 1 else y.shape[1]
        self._run(self._make_core(X.shape[1], n_outputs), X, y, sample_weight, stats=True)
        return self

    def partial_fit(self, X, y, sample_weight=None):
        """Continue the recursion with more rows (the first call starts from the prior).

        Calling ``partial_fit`` on consecutive chunks gives exactly (bit for
        bit) the result of one :meth:`fit` on their concatenation.

        Parameters
        ----------
        X : array_like, shape (N, n_features)
        y : array_like, shape (N,) or (N, n_outputs)
        sample_weight : array_like, shape (N,), optional

        Returns
        -------
        self
        """
        first = not hasattr(self, "estimator_")
        X, y = self._check_xy(X, y, reset=first)
        n_outputs = None if y.ndim == 1 else y.shape[1]
        if first:
            core = self._make_core(X.shape[1], n_outputs)
        else:
            core = self.estimator_
            had = None if core.theta.ndim == 1 else core.n_outputs
            if had != n_outputs:
                raise param_error("y", f"of the same number of outputs as before ({had or 1}"
                                  f"{', 2-d' if had else ', 1-d'})", f"<shape {y.shape}>")
        self._run(core, X, y, sample_weight)
        return self

    def predict(self, X):
        """Predicted outputs ``X @ coef_.T + intercept_``.

        Parameters
        ----------
        X : array_like, shape (N, n_features)

        Returns
        -------
        ndarray, shape (N,) or (N, n_outputs)
        """
        check_is_fitted(self)
        _refuse_text(X, "X")
        X = _validate(self, X, reset=False, dtype=np.float64)
        return self.estimator_.predict(self._design(X))
