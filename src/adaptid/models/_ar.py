r"""Time-series models: AR :math:`A(q)y_k = e_k` and ARMA :math:`A(q)y_k = C(q)e_k`.

They are the ARX and ARMAX structures without an input (``nb = 0``), fitted
by the same code: internally the input is an all-zero column that no
regressor uses.
"""

from __future__ import annotations

import numpy as np

from .._lazy import lazy
from .._validation import as_float_array, check_choice, check_int
from ._armax import ARMAX
from ._arx import ARX
from ._polymodel import _python_control

signal = lazy("scipy.signal")

__all__ = ["AR", "ARMA"]


class _TimeSeries:
    """The input-free face of ARX / ARMAX (mixed in before them)."""

    @staticmethod
    def _no_input(y):
        from ._iddata import _squeeze_column

        y = as_float_array(_squeeze_column(np.asarray(y)), "y", ndim=1, allow_nan=True)
        return y, np.zeros(y.shape[0])

    @staticmethod
    def _record(y):
        """``fit``'s arguments: an IDData or named / time-indexed pandas output keeps its
        name and ``dt`` (with the all-zero input column); arrays as :meth:`_no_input`."""
        from .._validation import param_error
        from ._iddata import IDData, as_signals

        data = y if isinstance(y, IDData) else as_signals(y, None)[2]
        if data is None:
            return _TimeSeries._no_input(y)
        if data.n_inputs:
            raise param_error("y", "an output record without inputs (a time-series model)",
                              f"<an IDData with {data.n_inputs} input(s)>")
        zero = np.zeros((len(data), 1))
        rec = data._copy_with(inputs=zero, u_trend=zero)
        rec.u_names = ("u",)
        return rec, None

    def _data(self, y, u, *, fitting=False):
        # the internal all-zero input is no signal of the record: no input names, and
        # summary() sees an estimation record without inputs
        y, U = super()._data(y, u, fitting=fitting)
        if fitting:
            self.u_names = ()
            self._fit_signals = (y, np.zeros((y.shape[0], 0)))
        return y, U

    def predict(self, y, u=None, *, k=1):
        r"""k-step-ahead prediction :math:`\hat y_{t|t-k} = (1 - \bar H_k A/C)\,y_t`.

        :math:`\bar H_k` is the impulse response of H = C/A truncated to k
        terms (Ljung 1999, eq. 3.31); signals are zero before the first
        sample.

        Parameters
        ----------
        y : array_like, shape (N,)
        u : None or array_like of zeros
            No input (accepted, as None or the all-zero input column the
            model uses internally, so that :func:`~adaptid.models.compare`,
            :func:`~adaptid.models.resid` and ``summary()`` call every model
            as ``predict(y, u, k=k)``).
        k : int
            Horizon, ``>= 1`` (default 1).

        Returns
        -------
        ndarray, shape (N,)
        """
        if u is not None and np.any(np.asarray(u, dtype=np.float64) != 0.0):
            from .._validation import param_error

            raise param_error("u", "None (a time-series model has no input)", "<an input>",
                              exc=TypeError)
        from ._iddata import IDData

        if isinstance(y, IDData):       # a record (merged: predicted experiment by experiment)
            return super().predict(self._record(y)[0], k=k)
        y, u = self._no_input(y)
        return super().predict(y, u, k=k)

    def simulate(self, noise):
        r"""The output driven by a noise sequence: :math:`y_t = C(q)/A(q)\,e_t` (zero initial conditions).

        Parameters
        ----------
        noise : array_like, shape (N,)

        Returns
        -------
        ndarray, shape (N,)
        """
        self._check_fitted()
        e = as_float_array(noise, "noise", ndim=1)
        A, _, C, _ = self._polys()
        return signal.lfilter(C, A, e)

    def fit_percent(self, y, *, k=1):
        """Normalised fit (NRMSE, percent) of the k-step prediction (default k = 1)."""
        from .._teststats import fit_percent

        y = as_float_array(y, "y", ndim=1, allow_nan=True)
        y_hat = self.predict(y, k=check_int(k, "k", low=1))
        ok = np.isfinite(y) & np.isfinite(y_hat)
        return fit_percent(y[ok], y_hat[ok])

    def to_control(self, form="tf"):
        r"""The noise model :math:`H = C(q)/A(q)` (input e, output y) as a python-control system.

        Parameters
        ----------
        form : {"tf", "ss"}

        Returns
        -------
        control.TransferFunction or control.StateSpace
            Discrete, with ``dt`` the model's sample time; its forced
            response to e equals :meth:`simulate`.

        Raises
        ------
        ImportError
            If python-control is not installed (``pip install 'adaptid[control]'``).
        """
        check_choice(form, "form", ("tf", "ss"))
        self._check_fitted()
        control = _python_control()
        A, _, C, _ = self._polys()
        L = max(A.size, C.size)
        num, den = np.zeros(L), np.zeros(L)
        num[: C.size], den[: A.size] = C, A
        sys = control.tf(num, den, self.dt)
        return sys if form == "tf" else control.tf2ss(sys)

    def _freq_structure(self):
        """The noise model H = C/A as a function of θ (see ``_PolyModel._freq_structure``)."""
        d = self.theta.size
        a_i, _, c_i, _ = self._split(np.arange(d, dtype=float))
        A, _, C, _ = self._polys()
        return [((C, [(int(j), k + 1) for k, j in enumerate(c_i)]),
                 [(A, [(int(j), k + 1) for k, j in enumerate(a_i)])])]

    def _freq_names(self):
        return (getattr(self, "y_name", "y"),), ("e",)

    def __repr__(self):
        orders = ", ".join(f"{k}={getattr(self, k)}" for k in self._order_names)
        state = "fitted" if self.theta is not None else "not fitted"
        return f"{type(self).__name__}({orders}, dt={self.dt:g}) [{state}]"


class AR(_TimeSeries, ARX):
    r"""Autoregressive model :math:`A(q)y_k = e_k`, identified by (recursive) least squares.

    .. math::

        y_k + a_1y_{k-1} + \dots + a_{n_a}y_{k-n_a} = e_k,\qquad
        \theta = [a_1, \dots, a_{n_a}]

    (MATLAB's ``ar`` with the ``"ls"`` approach and its ``recursiveAR``).
    The rows are the samples k = n_a … N-1 (no assumed initial values), so
    :meth:`fit` is the conditional least squares of
    :class:`statsmodels.tsa.ar_model.AutoReg` (``trend="n"``), whose
    coefficients are :math:`-a_j`. ``cov`` is
    :math:`\hat\sigma^2(\Phi^T\Phi)^{-1}` with
    :math:`\hat\sigma^2 = \sum\varepsilon^2/(N - 2n_a)` (the N - n_a rows less the n_a parameters).

    Parameters
    ----------
    na : int
        Order, ``>= 1``.
    dt : float
        Sample time (default 1.0).

    Attributes
    ----------
    theta, cov, stderr, residuals, noise_variance, names, A, C
        As for :class:`ARX` (``names = ("a1", …)``, C = [1]).

    References
    ----------
    .. [1] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
       Prentice Hall, 1999, sec. 7.3.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import lfilter
    >>> from adaptid.models import AR
    >>> e = np.random.default_rng(0).standard_normal(5000)
    >>> y = lfilter([1.0], [1, -1.5, 0.7], e)
    >>> m = AR(2).fit(y)
    >>> bool(np.allclose(m.theta, [-1.5, 0.7], atol=0.03))
    True
    """

    _order_names = ("na",)

    def __init__(self, na, *, dt=1.0):
        super().__init__(check_int(na, "na", low=1), 0, 1, dt=dt)

    def fit(self, y, *, nan_policy="omit"):
        r"""Least-squares fit (QR, :func:`adaptid.lstsq`) on the rows k = n_a … N-1.

        Parameters
        ----------
        y : array_like, shape (N,); pandas Series; or IDData without inputs
            A pandas or IDData record gives the model its name and ``dt``;
            a merged IDData gives each experiment's rows, stacked.
        nan_policy : {"omit", "raise"}
            As :meth:`ARX.fit`: the rows that touch a NaN are left out, or
            a NaN is refused.

        Returns
        -------
        self
        """
        return super().fit(*self._record(y), nan_policy=nan_policy)

    def fit_recursive(self, y, estimator=None):
        r"""Recursive least squares with a core estimator (MATLAB's ``recursiveAR``).

        The regressors :math:`[-y_{k-1}, \dots, -y_{k-n_a}]` do not depend on
        the estimate, so a copy of ``estimator`` runs over them in one
        compiled pass (see :meth:`ARX.fit_recursive`).

        Parameters
        ----------
        y : array_like, shape (N,); pandas Series; or IDData without inputs
        estimator : RLS, SlidingWindowRLS or KalmanRLS, optional
            With ``n_params = na``; default ``adaptid.RLS(na)``.

        Returns
        -------
        Trajectory
        """
        return super().fit_recursive(*self._record(y), estimator)


class ARMA(_TimeSeries, ARMAX):
    r"""ARMA model :math:`A(q)y_k = C(q)e_k`.

    .. math::

        y_k + a_1y_{k-1} + \dots + a_{n_a}y_{k-n_a}
          = e_k + c_1e_{k-1} + \dots + c_{n_c}e_{k-n_c},\qquad
        \theta = [a_1..a_{n_a},\ c_1..c_{n_c}]

    (MATLAB's ``armax`` without input and its ``recursiveARMA``). The
    prediction errors are :math:`\varepsilon = A(q)/C(q)\,y` on the rows
    k = n_a … N-1 with zero initial conditions (the *conditional*
    likelihood):

    * :meth:`fit` — Hannan–Rissanen (a long AR model's residuals as the
      innovations, least squares on :math:`[-y_{k-j}, \hat e_{k-j}]`, one
      Gauss–Newton step), then, by default, the prediction-error
      minimisation of :math:`\sum\varepsilon_k^2(\theta)`, the conditional
      maximum-likelihood estimate for Gaussian e. It differs from the exact
      likelihood of :class:`statsmodels.tsa.arima.model.ARIMA` by terms of
      order 1/N.
    * :meth:`fit_recursive` — recursive extended least squares (RELS) with
      any core estimator, as :meth:`ARMAX.fit_recursive`.

    Roots of C outside the unit circle are reflected inside.

    Parameters
    ----------
    na : int
        Order of A, ``>= 1``.
    nc : int
        Order of C, ``>= 0``.
    dt : float
        Sample time (default 1.0).

    References
    ----------
    .. [1] E. J. Hannan, J. Rissanen, "Recursive estimation of mixed
       autoregressive-moving average order", *Biometrika* 69(1), 1982.
    .. [2] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
       Prentice Hall, 1999, secs. 7.3, 11.3.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import lfilter
    >>> from adaptid.models import ARMA
    >>> e = np.random.default_rng(1).standard_normal(5000)
    >>> y = lfilter([1, 0.5], [1, -0.8], e)
    >>> m = ARMA(1, 1).fit(y)
    >>> bool(np.allclose(m.theta, [-0.8, 0.5], atol=0.05))
    True
    """

    _order_names = ("na", "nc")

    def __init__(self, na, nc, *, dt=1.0):
        super().__init__(check_int(na, "na", low=1), 0, nc, 1, dt=dt)

    def fit(self, y, *, refine=True, arx_order=None, nan_policy="omit"):
        r"""Hannan–Rissanen, then (``refine=True``, default) prediction-error minimisation.

        Parameters
        ----------
        y : array_like, shape (N,); pandas Series; or IDData without inputs
        refine : bool
            Minimise :math:`\sum\varepsilon_k^2(\theta)` from the
            Hannan–Rissanen estimate (default True).
        arx_order : int, optional
            Order of the long AR model (see :meth:`ARMAX.fit`).
        nan_policy : {"omit", "raise"}
            As :meth:`ARMAX.fit`: the record is split at each NaN run into
            separate experiments, or a NaN is refused.

        Returns
        -------
        self
        """
        return super().fit(*self._record(y), refine=refine, arx_order=arx_order,
                           nan_policy=nan_policy)

    def fit_recursive(self, y, estimator=None, *, refine=False):
        r"""Recursive extended least squares (MATLAB's ``recursiveARMA``), one compiled pass.

        See :meth:`ARMAX.fit_recursive`: the regressor
        :math:`[-y_{k-1}, \dots, -y_{k-n_a}, \varepsilon_{k-1}, \dots, \varepsilon_{k-n_c}]`
        holds the a-posteriori residuals; any RLS (with a forgetting
        strategy), SlidingWindowRLS or KalmanRLS with ``n_params = na + nc``.
        A merged IDData or NaN gaps: the residual lags restart from zero in
        each experiment and each run between gaps, θ and P run on (as
        :meth:`ARMAX.fit_recursive`).

        Parameters
        ----------
        y : array_like, shape (N,); pandas Series; or IDData without inputs
        estimator : RLS, SlidingWindowRLS or KalmanRLS, optional
        refine : bool
            Follow with the prediction-error refinement.

        Returns
        -------
        Trajectory
        """
        return super().fit_recursive(*self._record(y), estimator, refine=refine)
