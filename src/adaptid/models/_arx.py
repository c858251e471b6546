r"""The ARX model :math:`A(q)y_k = B(q)u_k + e_k`."""

from __future__ import annotations

from abc import ABCMeta

import numpy as np

from ._polymodel import _PolyModel
from .mimo import MIMOARX

__all__ = ["ARX"]


def _matrix_orders(*specs):
    """True when an order is given as a matrix (MIMO ARX)."""
    return any(np.ndim(v) == 2 for v in specs if v is not None)


class ARX(_PolyModel, metaclass=ABCMeta):
    r"""ARX model, identified by (recursive) least squares.

    .. math::

        y_k + a_1y_{k-1} + \dots + a_{n_a}y_{k-n_a}
          = \sum_i \big(b^{(i)}_0u^{(i)}_{k-n_k} + \dots
                        + b^{(i)}_{n_b-1}u^{(i)}_{k-n_k-n_b+1}\big) + e_k,

    i.e. :math:`y_k = \varphi_k^T\theta + e_k` with
    :math:`\varphi_k = [-y_{k-1}, \dots, -y_{k-n_a}, u_{k-n_k}, \dots]` and
    :math:`\theta = [a_1, \dots, a_{n_a}, b_0, \dots]` (MATLAB's ``arx``
    convention). The rows are the samples k = s … N-1 whose lags are all
    measured, :math:`s = \max(n_a, n_k + n_b - 1)` (no assumed initial
    values).

    With matrix orders — ``na`` (ny, ny), ``nb`` and ``nk`` (ny, nu) —
    ``ARX(na, nb, nk)`` is the multi-output model
    :class:`~adaptid.models.MIMOARX` (MATLAB's ``arx`` convention with
    matrix polynomials, documented there); so is a scalar-order ARX once
    :meth:`fit` or :meth:`fit_recursive` is given data with several
    outputs (its orders broadcast to every equation). ``isinstance(m,
    ARX)`` is True for both.

    Parameters
    ----------
    na : int
        Order of A, ``>= 0``.
    nb : int or sequence of int
        Number of B coefficients (per input), ``>= 0``.
    nk : int or sequence of int
        Input delay (per input), ``>= 0`` (default 1).
    dt : float
        Sample time (default 1.0), used by :meth:`to_control`.

    Attributes
    ----------
    theta : ndarray, shape (d,)
        ``[a1, …, a_na, b…]`` after :meth:`fit` (None before).
    cov : ndarray, shape (d, d)
        Parameter covariance :math:`\hat\sigma^2(\Phi^T\Phi)^{-1}`,
        :math:`\hat\sigma^2 = \sum\varepsilon^2/(N-d)`.
    stderr : ndarray, shape (d,)
    residuals : ndarray, shape (N - s,)
        Prediction errors of the fit's rows.
    noise_variance : float
        :math:`\hat\sigma^2`.
    names : tuple of str
        ``("a1", …, "b0", …)`` or ``"b0_0"`` … per input for several inputs.
    A, B, C, F : ndarray
        Polynomials (C = F = [1]).
    aic, fpe, loss : float
    n_dropped : int
        Rows left out of the fit because their regressors or target touch a
        NaN (gaps; see :meth:`fit`'s ``nan_policy``).
    n_experiments : int
        Experiments of the fit's record (:meth:`IDData.merge`); their rows
        are formed inside each and stacked.

    References
    ----------
    .. [1] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
       Prentice Hall, 1999, secs. 4.2, 7.3 and 16.4 (AIC, FPE).

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import lfilter
    >>> from adaptid.models import ARX
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal(2000); e = 0.1 * rng.standard_normal(2000)
    >>> y = lfilter([0, 1.0, 0.5], [1, -1.5, 0.7], u) + lfilter([1], [1, -1.5, 0.7], e)
    >>> m = ARX(2, 2, 1).fit(y, u)
    >>> bool(np.allclose(m.theta, [-1.5, 0.7, 1.0, 0.5], atol=0.02))
    True
    """

    _order_names = ("na", "nb", "nk")

    def __new__(cls, na=None, nb=None, nk=1, *args, **kwargs):
        if cls is ARX and _matrix_orders(na, nb, nk):
            return MIMOARX(na, nb, nk, *args, **kwargs)
        return super().__new__(cls)

    def _to_mimo(self, y, u):
        """Become the MIMO model when the data have several outputs (True if so)."""
        from .mimo._data import several_outputs

        if not several_outputs(y, u):
            return False
        specs, dt = (self.na, self._nb_spec, self._nk_spec), self.dt
        self.__dict__.clear()
        self.__class__ = MIMOARX
        MIMOARX.__init__(self, *specs, dt=dt)
        return True

    def __init__(self, na, nb, nk=1, *, dt=1.0):
        self._init_orders(na, nb, 0, 0, nk, dt)

    def _split(self, theta):
        a = theta[: self.na]
        bs, o = [], self.na
        for b in self._nb:
            bs.append(theta[o: o + b])
            o += b
        return a, bs, np.zeros(0), [np.zeros(0)] * self._m

    def _names(self):
        names = [f"a{j}" for j in range(1, self.na + 1)]
        for i, b in enumerate(self._nb):
            names += [f"b{j}" if self._single else f"b{i}_{j}" for j in range(b)]
        return tuple(names)

    def _prepare(self, y, u):
        y, U = self._data(y, u, fitting=True)
        reg, Phi = self._fixed_regression(y, U, self._single)
        return reg, Phi

    def fit(self, y, u=None, *, nan_policy="omit"):
        r"""Least-squares fit on the whole record (QR, :func:`adaptid.lstsq`).

        Parameters
        ----------
        y : array_like, shape (N,) or (N, 1); pandas Series; IDData; tuple; DataFrame
            Output, or the whole record with ``u`` omitted: an IDData, a
            ``(y, u)`` tuple, or a DataFrame whose first column is the
            output and the others the inputs. Named or time-indexed data
            give their names to :meth:`summary` and their ``dt`` to the
            model. This is the one input convention of every polynomial
            model's ``fit`` / ``fit_recursive`` and of :func:`compare`,
            :func:`resid`, :func:`select_order`; anything else is refused
            naming the argument. (N, 1) is squeezed to (N,).
        u : array_like, shape (N,) or (N, m); pandas
        nan_policy : {"omit", "raise"}
            ``"omit"`` (default): NaN samples are gaps: the rows whose regressors or target touch a NaN are left out (those of a merged IDData are formed inside each experiment and stacked)
            (``n_dropped`` counts the rows lost, and ``summary()`` reports
            it). ``"raise"``: a NaN in y or u is refused (ValueError naming
            the signal).

        Returns
        -------
        self
        """
        from .._lstsq import lstsq

        if self._to_mimo(y, u):
            return self.fit(y, u)
        from ._segments import check_nan_policy

        self._nan_policy = check_nan_policy(nan_policy)
        reg, Phi = self._prepare(y, u)
        res = lstsq(Phi, reg.y)
        self.theta = np.asarray(res.theta, dtype=np.float64)
        self.cov = np.asarray(res.cov)
        self.noise_variance = float(res.sigma2)
        self.residuals = np.asarray(res.residuals)
        self.index = reg.index
        self.names = self._names()
        self.result = res
        return self

    def fit_recursive(self, y, u=None, estimator=None, **options):
        r"""Fit with a recursive estimator of the core, in one compiled pass.

        The ARX regressors do not depend on the estimates, so Φ is built
        once and a *copy* of ``estimator`` runs over it (the argument is not
        modified; the fitted copy is kept as ``self.estimator``).

        Parameters
        ----------
        y : array_like, shape (N,) or (N, 1); pandas; IDData; tuple; DataFrame
            As :meth:`fit` (the one input convention).
        u : array_like, shape (N,) or (N, m); optional
        estimator : RLS, SlidingWindowRLS or KalmanRLS, optional
            With ``n_params`` equal to the model's d; its options
            (forgetting — a float or a strategy object —, window, process
            covariance, prior) are used as they are. Default
            ``adaptid.RLS(d)``. With ``P0="diffuse"`` θ is exactly the
            (forgotten or windowed) least squares on the rows so far from
            the first full-rank row on (``Trajectory.identified``).
        **options
            Only for data with several outputs (the model then becomes a
            :class:`~adaptid.models.MIMOARX`): estimator options, see
            :meth:`MIMOARX.fit_recursive <adaptid.models.MIMOARX.fit_recursive>`.

        Returns
        -------
        Trajectory
            ``theta[i]`` is the estimate after row i (sample
            ``meta["index"][i]``). The model takes the final estimate;
            ``noise_variance`` and ``cov`` = σ̂² P / R₂ follow the one rule of
            :func:`adaptid.recursive_fit_stats` (the cost-weighted residuals
            of the final estimate; R₂ the Kalman filter's ``noise_var``, 1
            otherwise), as ``adaptid fit --arx`` reports them.
        """
        from ..estimators import RLS, KalmanRLS, SlidingWindowRLS, recursive_fit_stats
        from .._validation import param_error

        if self._to_mimo(y, u):
            return self.fit_recursive(y, u, estimator, **options)
        if options:
            raise param_error("options", "none for one output (they are the estimator options "
                              "of a multi-output fit)", f"<{sorted(options)}>", exc=TypeError)
        self._nan_policy = "omit"           # rows that touch a NaN left out (see fit)
        reg, Phi = self._prepare(y, u)
        d = Phi.shape[1]
        if estimator is None:
            est = RLS(d)
        elif isinstance(estimator, (RLS, SlidingWindowRLS, KalmanRLS)):
            if estimator.n_params != d:
                raise param_error("estimator", f"an estimator with n_params={d} (the model's "
                                  "parameters)", f"<n_params={estimator.n_params}>")
            est = estimator.copy()
        else:
            raise param_error("estimator", "None or an adaptid RLS, SlidingWindowRLS or KalmanRLS",
                              estimator, exc=TypeError)
        traj = est.run(Phi, reg.y)
        self.theta = np.asarray(est.theta, dtype=np.float64).reshape(-1)
        self.residuals = reg.y - Phi @ self.theta
        fs = recursive_fit_stats(est, Phi, reg.y, forgetting=traj.forgetting,
                                 used=None if traj.skipped is None else ~traj.skipped)
        self.noise_variance = fs.sigma2
        self.cov = fs.scale * np.asarray(est.P)
        self.index = reg.index
        self.names = self._names()
        self.estimator = est
        import dataclasses

        meta = dict(traj.meta)
        meta.update(index=reg.index, names=self.names)
        return dataclasses.replace(traj, meta=meta, names=self.names,
                                   time=self._time_of(reg.index))


ARX.register(MIMOARX)   # isinstance(m, ARX) holds for the multi-output model ARX(matrices) makes


def single_output_arx(na, nb, nk, *, where):
    """``ARX(na, nb, nk)`` for functions that are single-output (iv4, ivx, arx_regul).

    Order matrices would make a :class:`MIMOARX`, which their code cannot use:
    refused with a ValueError naming ``na`` and the function.
    """
    from .._validation import param_error

    model = ARX(na, nb, nk)
    if not isinstance(model, _PolyModel):
        raise param_error("na", f"a scalar order ({where} fits one output; for several outputs "
                          "use adaptid.models.ARX with order matrices)", na)
    return model

