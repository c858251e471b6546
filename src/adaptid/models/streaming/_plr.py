r"""The machinery of the streaming pseudo-linear models (ARMAX, ARMA, OE, BJ).

:class:`_PseudoLinearStream` keeps the lag buffers of the measured signals
(as :class:`~adaptid.models.RecursiveARX`, whose helpers it reuses), and the
whole state of the compiled recursion :func:`adaptid._kernels.layers._plr_stream.plr_stream`:
θ, the U-D factors of P, the lag history of the signals the recursion forms
(residuals, simulated outputs), the window buffer and the diffuse state.
A core estimator built by :func:`adaptid.estimator` at construction gives
the algorithm, the options and the prior; it is never updated itself.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..._validation import as_float_array, check_choice, param_error
from ...estimators._statefile import StateFileMethods
from ._arx import _METHODS, _STARTS, RecursiveARX, StreamResult, _by_experiment, _core_estimator
from ._plr_state import _PACKED, _packed, restore

__all__ = ["_PseudoLinearStream"]

#: the arrays of the recursion's state (attribute ``_<name>``), in the order the kernel takes
_ARRAYS = ("theta", "U", "D", "vh", "Bphi", "By")


class _PseudoLinearStream(StateFileMethods):
    """Shared body of RecursiveARMAX / ARMA / OE / BJ (see :class:`RecursiveARMAX`)."""

    _kind = None
    _init_structure = RecursiveARX._init_structure
    _inputs = RecursiveARX._inputs
    _regressors = RecursiveARX._regressors

    def _setup(self, structure, *, method, forgetting, noise_cov, noise_var, step, bias,
               window, theta0, P0, start):
        self._init_structure(*structure)
        self.method = check_choice(method, "method", tuple(_METHODS))
        self.start = check_choice(start, "start", _STARTS)
        self.dt = self._model.dt
        self._est = _core_estimator(self.method, self.n_params, forgetting=forgetting,
                                    noise_cov=noise_cov, noise_var=noise_var, step=step,
                                    bias=bias, window=window, theta0=theta0, P0=P0)
        self._spec = self._model._signal_spec(self.na + sum(self.nb))
        self._configure()
        self.reset()

    def _configure(self):
        """Kernel options and the prior from the core estimator ``self._est``."""
        from .._recursive import estimator_settings

        n = self.n_params
        if self.method in ("gradient", "ngradient"):
            est = self._est
            self._start = (np.array(est.theta, dtype=np.float64).reshape(-1), np.eye(n),
                           np.ones(n), np.zeros(0))
            self._opts = (1.0, np.zeros((n, n)), False, 1.0, 0, -1, np.zeros(1), np.inf, 0.0,
                          1 if self.method == "gradient" else 2, float(est.step),
                          float(getattr(est, "eps", 0.0)))
            return
        lam, Q, kalman, r2, M, theta, U, D, (mode, fp, pmax), (dif, dtol) = \
            estimator_settings(self._est, n)
        self._start = (theta, U, D, dif)
        self._opts = (lam, Q, kalman, r2, M, mode, fp, pmax, dtol, 0, 0.0, 0.0)

    def _use_core(self, estimator):
        """Take the algorithm, options and prior of a core estimator (read, not modified;
        RLS, SlidingWindowRLS, KalmanRLS, LMS, NLMS, as ``fit_recursive`` reads one), and
        reset. For the CLI, whose options build that estimator."""
        from ...estimators import KalmanRLS, LMS, NLMS, RLS, SlidingWindowRLS

        kinds = ((SlidingWindowRLS, "forgetting"), (RLS, "forgetting"), (KalmanRLS, "kalman"),
                 (NLMS, "ngradient"), (LMS, "gradient"))
        method = next((m for c, m in kinds if isinstance(estimator, c)), None)
        if method is None:
            raise param_error("estimator", "an adaptid RLS, SlidingWindowRLS, KalmanRLS, LMS "
                              "or NLMS", estimator, exc=TypeError)
        if estimator.n_params != self.n_params:
            raise param_error("estimator", f"an estimator with n_params={self.n_params}",
                              f"<n_params={estimator.n_params}>")
        self.method, self._est = method, estimator.copy()
        self._configure()
        self.reset()
        return self

    def _fitted_model(self, y, u=None):
        """The batch model at the current θ as ``fit_recursive`` leaves it after a
        ``start="filled"`` run over the record (y, u): roots reflected into the unit
        circle, the prediction-error covariance at that θ, ``P``."""
        import copy

        model = copy.deepcopy(self._model)
        args = model._record(y) if self._m == 0 else (y, u)
        reg, Phi_fix = model._prepare(*args)
        model._finish(model._stable(self.theta), Phi_fix, reg.y, reg)
        model.P = self.P
        return model

    # ------------------------------------------------------------ state
    def reset(self):
        """Back to the prior (θ₀, P₀): zero lag buffers and signal history, counts at 0."""
        theta, U, D, dif = self._start
        n, M = self.n_params, self._opts[4]
        self._theta, self._U, self._D, self._dif = theta.copy(), U.copy(), D.copy(), dif.copy()
        self._Bphi = np.zeros((max(M, 1), n))        # the window's regressors (slot k mod M)
        self._By = np.zeros(max(M, 1))
        self._count = 0                              # samples seen
        self._k = 0                                  # recursion steps made
        self._restart()

    def _restart(self):
        """Zero lag buffers and signal history (a new experiment); θ, P, the window
        buffer, the diffuse state and the counts run on."""
        G = self._spec[0].shape[0]
        L = max([1] + [int(x) for x in self._spec[3]])
        self._vh = np.zeros((G, L))                  # vh[g, l - 1] = v_g(k - l)
        self._ybuf = np.zeros(self.na)               # y(k-1), …, y(k-na)
        self._ubuf = np.zeros((self._m, self._Lu))   # u(k-1), …, u(k-Lu) per input
        self._since = 0                              # samples since the buffers restarted

    @property
    def theta(self):
        """The current estimate, shape (n,) (a copy)."""
        return self._theta.copy()

    @property
    def P(self):
        """The current P, shape (n, n) (None for the gradient methods; inf entries
        while a diffuse start has not identified θ)."""
        if self._opts[9]:
            return None
        if self._dif.shape[0] and self._dif[0] == 0.0:
            return np.full((self.n_params,) * 2, np.inf)
        P = (self._U * self._D) @ self._U.T
        return 0.5 * (P + P.T)

    @property
    def n_updates(self) -> int:
        """Recursion steps made so far (samples a ``start="filled"`` wait skips not counted)."""
        return self._k

    # ------------------------------------------------------------ use
    def _advance(self, Phi, Y):
        """The kernel over the rows Phi, Y on copies of the state; commit after success.
        Returns (Th, E, Yh)."""
        from ..._exceptions import DefinitenessLossWarning
        from ..._config import DOWNDATE_RTOL
        from ..._kernels.layers._plr_stream import plr_stream

        N, n = Y.shape[0], self.n_params
        lam, Q, kalman, r2, M, mode, fp, pmax, dtol, grad, mu, beta = self._opts
        alpha, mix, dyn_group, dyn_lag, dyn_sgn = self._spec
        st = [getattr(self, "_" + a).copy() for a in _ARRAYS]
        dif = self._dif.copy()
        Th, E, Yh, Lk, Ik = (np.empty((N, n)), np.empty(N), np.empty(N), np.empty(N),
                             np.empty(N))
        V = np.empty((N, alpha.shape[0]))
        theta_s, U_s, D_s, _ = self._start
        status = plr_stream(np.ascontiguousarray(Phi), np.ascontiguousarray(Y),
                            alpha, mix, dyn_group, dyn_lag, dyn_sgn, *st, theta_s, U_s, D_s,
                            dif, self._k, lam, Q, kalman, r2, M, DOWNDATE_RTOL, mode, fp.copy(),
                            pmax, dtol, grad, mu, beta, Th, E, Yh, V, Lk, Ik)
        if status < 0:
            raise FloatingPointError("the Kalman time update P + Q lost positive definiteness "
                                     "(P overflowed?); the state is unchanged")
        if status:
            warnings.warn(f"{type(self).__name__}: {status} removal(s) from the window would "
                          "have lost positive definiteness; the window was re-solved exactly "
                          "from its buffer (poorly excited window?)", DefinitenessLossWarning,
                          stacklevel=4)
        for a, x in zip(_ARRAYS, st):
            setattr(self, "_" + a, x)
        self._dif = dif
        self._k += N
        return Th, E, Yh

    def _samples(self, y, U):
        """Φ of the fixed columns, the rows the recursion uses, and the tracks of all."""
        N = y.shape[0]
        for name, x in (("y", y), ("u", U)):
            if not np.isfinite(x).all():
                raise param_error(name, "finite values (no NaN or inf)", "<non-finite values>")
        Phi, ybuf, ubuf = self._regressors(y, U)
        first = min(max(self._s - self._since, 0), N) if self.start == "filled" else 0
        before = self.theta
        theta = np.empty((N, self.n_params))
        theta[:first] = before
        yhat = np.full(N, np.nan)
        if first < N:
            Th, _, Yh = self._advance(Phi[first:], y[first:])
            theta[first:] = Th
            yhat[first:] = Yh
        self._ybuf, self._ubuf = ybuf, ubuf
        self._count += N
        self._since += N
        return theta, yhat

    def step(self, y, u=None):
        r"""One sample: MATLAB's ``[A, B, C, yhat] = step(obj, y, u)`` (θ as one vector).

        Parameters
        ----------
        y : float
            Output y(k).
        u : float or array_like, shape (m,)
            Input(s) u(k) (none for :class:`RecursiveARMA`).

        Returns
        -------
        theta : ndarray, shape (n,)
            The estimate after y(k) is used (a copy).
        yhat : float
            The one-step prediction :math:`\varphi_k^T\hat\theta_{k-1}` made
            before y(k) is used (NaN while ``start="filled"`` waits).
        """
        yv = as_float_array(y, "y").reshape(-1)
        if yv.shape != (1,):
            raise param_error("y", "one output sample (a scalar)", f"<shape {np.shape(y)}>")
        U = self._inputs(None if u is None else np.reshape(as_float_array(u, "u"), (1, -1)), 1)
        theta, yhat = self._samples(yv, U)
        return theta[0], float(yhat[0])

    def run(self, y, u=None):
        """A record in one compiled pass: equal bit for bit to one :meth:`step` per sample.

        Parameters
        ----------
        y : array_like, shape (N,); pandas; IDData; tuple ``(y, u)``; DataFrame
            The output, or the whole record (the one input convention of
            :func:`adaptid.models._iddata.as_signals`). An IDData, or a
            pandas record with names or a time index, sets ``dt``.
        u : array_like, shape (N,) or (N, m), optional

        Returns
        -------
        StreamResult
            ``theta`` (N, n) after each sample, ``yhat`` (N,) before it.

        Notes
        -----
        A merged IDData (:meth:`IDData.merge <adaptid.IDData.merge>`) is run
        experiment by experiment, as ``fit_recursive`` runs it: the lag
        buffers of y, u and of the signals the recursion forms restart
        from zero at the first sample of each (``start="filled"`` waits
        again), while θ, P, the window buffer and the diffuse state run
        on; equal bit for bit to :meth:`step` over the samples with those
        buffers zeroed at each boundary. NaN (a gap) is refused: split the
        record at its gaps and merge the runs.
        """
        from .._iddata import as_signals

        yy, uu, data = as_signals(y, u)
        yy = as_float_array(yy, "y", ndim=1)
        U = self._inputs(uu, yy.shape[0])
        theta, yhat = _by_experiment(self, self._samples, yy, U, data)
        if data is not None and getattr(data, "dt", None) is not None:
            self.dt = float(data.dt)
        return StreamResult(theta=theta, yhat=yhat, names=self.names)

    def to_model(self):
        """The batch model object (ARMAX, ARMA, OE, BJ) with the current θ as it stands
        (no root reflection), ``dt`` and ``P``; no ``cov``."""
        import copy

        model = copy.deepcopy(self._model)
        if self._m == 0:  # a time-series model's internal all-zero input column
            model._set_inputs(1, True)
        model.dt = self.dt
        model.theta = self.theta
        model.names = self.names
        model.cov = None
        model.noise_variance = None
        model.P = self.P
        return model

    # ---------------------------------------------------- state files
    _STATE_FILE_ARRAYS = {k: k for k in _ARRAYS + ("dif", "ybuf", "ubuf")}

    def _options(self):
        raise NotImplementedError

    def get_state(self) -> dict:
        """Everything needed to resume exactly: the core estimator (algorithm and prior),
        the recursion's arrays, the lag buffers, the structure and the counts."""
        o = dict(self._options(), method=self.method, start=self.start, dt=self.dt,
                 count=self._count, k=self._k, since=self._since)
        arrays = {a: np.array(getattr(self, "_" + a), dtype=np.float64) for a in _ARRAYS}
        arrays.update(dif=self._dif, ybuf=self._ybuf, ubuf=self._ubuf.copy())
        arrays = {k: (_packed(v) if k in _PACKED else v.reshape(1, -1).copy() if v.ndim == 1
                      else v.copy()) for k, v in arrays.items()}
        side = max([1] + [d for v in arrays.values() for d in v.shape])
        return {"estimator": self._kind, "format": self._STATE_FORMAT, "n_params": side,
                "options": o, "inner": self._est.get_state(), **arrays}

    @classmethod
    def from_state(cls, state: dict):
        """Rebuild from :meth:`get_state`'s dict (exact round trip)."""
        return restore(cls, state)

    def save_state(self, path):
        """Write the state to ``path`` (adaptid's versioned, checksummed ``.npz``; never pickle)."""
        from ...estimators._stateread import MAX_PARAMS
        from ...estimators._statefile import save_state

        side = self.get_state()["n_params"]
        if side > MAX_PARAMS:
            raise ValueError(f"the {type(self).__name__} cannot be saved: its arrays need a "
                             f"side of {side} > {MAX_PARAMS}, the largest a state file holds "
                             "(a window buffer of window × n_params entries beyond "
                             f"{MAX_PARAMS}²)")
        save_state(self, path)

    def __repr__(self):
        orders = ", ".join(f"{k}={v}" for k, v in self._options().items() if k != "single")
        return (f"{type(self).__name__}({orders}, method={self.method!r}, "
                f"start={self.start!r}, n_updates={self._k})")
