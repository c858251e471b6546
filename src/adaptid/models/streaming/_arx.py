r"""Streaming ARX / AR model objects (MATLAB's ``recursiveARX``, ``recursiveAR``)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..._validation import as_float_array, check_choice, param_error
from ...estimators._statefile import StateFileMethods

__all__ = ["RecursiveARX", "RecursiveAR", "StreamResult"]

#: MATLAB's estimation methods -> the core method of :func:`adaptid.estimator`
_METHODS = {"forgetting": "rls", "kalman": "kalman", "ngradient": "nlms", "gradient": "lms"}
_STARTS = ("zero", "filled")


@dataclass(frozen=True)
class StreamResult:
    r"""The tracks of :meth:`RecursiveARX.run`.

    Attributes
    ----------
    theta : ndarray, shape (N, n)
        ``theta[k]``: the estimate after sample k (as :meth:`RecursiveARX.step` returns it).
    yhat : ndarray, shape (N,)
        ``yhat[k]``: the one-step prediction :math:`\varphi_k^T\hat\theta_{k-1}` made
        before ``y[k]`` is used (NaN for a sample that ``start="filled"`` skips).
    names : tuple of str
        Parameter names (``a1``, …, ``b0``, …), as the model's.
    """

    theta: np.ndarray
    yhat: np.ndarray
    names: tuple

    def to_frame(self):
        """A pandas DataFrame: one column per parameter, then ``yhat``."""
        import pandas as pd

        frame = pd.DataFrame(self.theta, columns=list(self.names))
        frame["yhat"] = self.yhat
        return frame

    def summary(self) -> str:
        """A few lines: the number of samples (and of predictions made), the final estimate."""
        N = self.theta.shape[0]
        made = int(np.sum(~np.isnan(self.yhat)))
        lines = [f"Streaming estimate: {N} samples, {made} one-step predictions"]
        if N:
            lines += [f"  {n:>8s} = {v: .6g}" for n, v in zip(self.names, self.theta[-1])]
        return "\n".join(lines)

    def plot(self, *, ax=None):
        """The parameter tracks (:func:`adaptid.plot.tracks`, sample 1 … N); returns the Figure."""
        from ...estimators._hooks import upward
        tracks = upward("adaptid.plot").tracks  # drawing lives in layer 7

        return tracks(np.arange(1, self.theta.shape[0] + 1), self.theta, self.names, ax=ax)


def _core_estimator(method, n, *, forgetting, noise_cov, noise_var, step, bias, window,
                    theta0, P0):
    """The core estimator of MATLAB's ``method`` (checked) with the streaming options."""
    from ...estimators._factory import estimator

    opts = {} if theta0 is None else {"theta0": theta0}
    core = _METHODS[method]
    if window is not None:
        if method != "forgetting":
            raise param_error("window", "None unless method='forgetting' (MATLAB's finite "
                              "history)", window)
        core = "window"
        opts.update(window=window, forgetting=forgetting, P0=P0)
    elif core == "rls":
        opts.update(forgetting=forgetting, P0=P0)
    elif core == "kalman":
        Q = noise_cov * np.eye(n) if np.ndim(noise_cov) == 0 else noise_cov
        opts.update(process_cov=Q, noise_var=noise_var, P0=P0)
    else:
        opts.update(step=step)
        if core == "nlms" and bias is not None:
            opts["eps"] = bias
    return estimator(core, n, **opts)


def _by_experiment(obj, fn, y, U, data):
    """``fn(y_e, U_e) -> (theta, yhat)`` on each experiment of a merged IDData in turn,
    the lag buffers restarted (``obj._restart()``) before each but the first; the
    tracks concatenated. If one raises, the object's state is restored as it was."""
    from .._segments import record_bounds

    bounds = record_bounds(data, y.shape[0])
    if len(bounds) == 2:
        return fn(y, U)
    saved = dict(obj.__dict__)
    saved["_est"] = obj._est.copy()
    parts = []
    try:
        for i, (a, b) in enumerate(zip(bounds[:-1], bounds[1:])):
            if i:
                obj._restart()
            parts.append(fn(y[a:b], U[a:b]))
    except BaseException:
        obj.__dict__.clear()
        obj.__dict__.update(saved)
        raise
    return np.vstack([p[0] for p in parts]), np.concatenate([p[1] for p in parts])


def _row_dot(Phi, Th):
    """φₖᵀθₖ row by row (the one formula of step and run: equal bit for bit)."""
    return (Phi * Th).sum(axis=1)


class RecursiveARX(StateFileMethods):
    r"""Streaming ARX model: MATLAB's ``recursiveARX`` (``obj = recursiveARX([na nb nk])``).

    .. math::

        \varphi_k = [-y_{k-1}, \dots, -y_{k-n_a},\;
                     u_{k-n_k}, \dots, u_{k-n_k-n_b+1}]^T,\qquad
        \hat y_k = \varphi_k^T\hat\theta_{k-1},\qquad
        \varepsilon_k = y_k - \hat y_k,

    and :math:`\theta = [a_1, \dots, a_{n_a}, b_0, \dots]` (MATLAB's sign
    convention, as :class:`~adaptid.models.ARX`), updated by the method
    chosen (Ljung (1999), sec. 11.2; MATLAB's ``EstimationMethod``):

    * ``"forgetting"`` (``ForgettingFactor``, :class:`~adaptid.RLS`):
      :math:`K_k = P_{k-1}\varphi_k/(\lambda + \varphi_k^TP_{k-1}\varphi_k)`,
      :math:`\hat\theta_k = \hat\theta_{k-1} + K_k\varepsilon_k`,
      :math:`P_k = (P_{k-1} - K_k\varphi_k^TP_{k-1})/\lambda`;
    * ``"kalman"`` (``KalmanFilter``, :class:`~adaptid.KalmanRLS`):
      :math:`K_k = P_{k-1}\varphi_k/(R_2 + \varphi_k^TP_{k-1}\varphi_k)`,
      :math:`P_k = P_{k-1} - K_k\varphi_k^TP_{k-1} + R_1` with
      :math:`R_1` = ``noise_cov`` (``ProcessNoiseCovariance``) and
      :math:`R_2` = ``noise_var``;
    * ``"ngradient"`` (``NormalizedGradient``, :class:`~adaptid.NLMS`):
      :math:`\hat\theta_k = \hat\theta_{k-1} + \mu\varphi_k\varepsilon_k/(\beta + \varphi_k^T\varphi_k)`,
      μ = ``step`` (``AdaptationGain``), β = ``bias`` (``NormalizationBias``,
      MATLAB's default ``eps``);
    * ``"gradient"`` (``Gradient``, :class:`~adaptid.LMS`):
      :math:`\hat\theta_k = \hat\theta_{k-1} + \mu\varphi_k\varepsilon_k`;
    * ``window=M`` (``History="Finite"``, ``WindowLength``,
      :class:`~adaptid.SlidingWindowRLS`): least squares over the last M
      regressor rows (with ``method="forgetting"`` only): exactly so with
      ``P0="diffuse"``; a finite ``P0`` keeps its prior term
      :math:`P_0^{-1}` in the window's normal equations, as
      :class:`~adaptid.SlidingWindowRLS` does.

    The estimator is built by :func:`adaptid.estimator`; this object adds the
    lag buffers. **The lag buffers start at zero**, as MATLAB's do: with
    ``start="zero"`` (default) the first samples are used with the unknown
    past outputs and inputs taken as 0. With ``start="filled"`` no update is
    made until the buffers hold measured data (sample
    :math:`s = \max(n_a, n_k + n_b - 1)`, counted from the first sample
    after construction or :meth:`reset`): before it :meth:`step` returns the
    unchanged θ and ``yhat = NaN``; :meth:`run` over a whole record then
    equals ``ARX(na, nb, nk).fit_recursive(...)`` with the same estimator
    bit for bit. A merged IDData given to :meth:`run` restarts the buffers
    (and the wait) at each experiment while θ and P run on, as
    ``fit_recursive`` forms its rows inside each experiment.

    Parameters
    ----------
    na : int
        Order of A, ``>= 0``.
    nb : int or sequence of int
        Number of B coefficients; a sequence gives one entry per input
        (MATLAB's ``[na nb1 nb2 nk1 nk2]``), ``>= 0``.
    nk : int or sequence of int
        Input delay (per input), ``>= 0`` (default 1).
    method : {"forgetting", "kalman", "ngradient", "gradient"}
        MATLAB's estimation method (default ``"forgetting"``).
    forgetting : float
        λ in (0, 1] (``"forgetting"`` and ``window``; default 1).
    noise_cov : float or array_like, shape (n, n)
        Process noise covariance :math:`R_1` (``"kalman"``; default 0.1,
        i.e. ``0.1 I`` as MATLAB's).
    noise_var : float
        Measurement noise variance :math:`R_2` (``"kalman"``; default 1).
    step : float
        Adaptation gain μ (``"ngradient"``, ``"gradient"``; default 1 as
        MATLAB's ``AdaptationGain``).
    bias : float, optional
        Normalisation bias β (``"ngradient"``; default machine epsilon, as
        MATLAB's ``NormalizationBias``).
    window : int, optional
        Finite history of M rows (``M >= n``).
    theta0 : array_like, shape (n,), optional
        Initial parameters (default 0).
    P0 : float or array_like
        Initial covariance (not for the gradient methods; default 1e4, as
        MATLAB's ``InitialParameterCovariance``); ``"diffuse"`` as in
        :class:`~adaptid.RLS`.
    start : {"zero", "filled"}
        Lag buffers: zeros used from the first sample (MATLAB) or an
        update only once they hold measured data.
    dt : float
        Sample time of the model :meth:`to_model` returns (default 1.0;
        replaced by the ``dt`` of an IDData or a named / time-indexed pandas
        record given to :meth:`run`).

    Attributes
    ----------
    n_params : int
    names : tuple of str
    estimator : RLS, SlidingWindowRLS, KalmanRLS, NLMS or LMS
        The core estimator (its ``P``, ``n_updates``, …).

    See Also
    --------
    adaptid.models.ARX.fit_recursive : the same recursion over a record.

    References
    ----------
    .. [1] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
       Prentice Hall, 1999, sec. 11.2.
    .. [2] The MathWorks, System Identification Toolbox, ``recursiveARX``
       (behavioural reference: ``[A, B, EstimatedOutput] = step(obj, y, u)``).

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import lfilter
    >>> from adaptid.models import RecursiveARX
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal(500)
    >>> y = lfilter([0, 1.0, 0.5], [1, -1.5, 0.7], u) + 0.01 * rng.standard_normal(500)
    >>> obj = RecursiveARX(2, 2, 1)
    >>> theta, yhat = obj.step(y[0], u[0])
    >>> res = obj.run((y[1:], u[1:]))
    >>> bool(np.allclose(res.theta[-1], [-1.5, 0.7, 1.0, 0.5], atol=0.01))
    True
    """

    _kind = "RecursiveARX"

    def __init__(self, na, nb, nk=1, *, method="forgetting", forgetting=1.0, noise_cov=0.1,
                 noise_var=1.0, step=1.0, bias=None, window=None, theta0=None, P0=1e4,
                 start="zero", dt=1.0):
        self._init_structure(*self._make_model(na, nb, nk, dt))
        self.method = check_choice(method, "method", tuple(_METHODS))
        self.start = check_choice(start, "start", _STARTS)
        self.dt = self._model.dt
        self._est = _core_estimator(self.method, self.n_params, forgetting=forgetting,
                                    noise_cov=noise_cov, noise_var=noise_var, step=step,
                                    bias=bias, window=window, theta0=theta0, P0=P0)
        self.reset()

    def _make_model(self, na, nb, nk, dt):
        """(the model object of the structure, number of inputs, single input?)."""
        from .._arx import ARX

        single = np.ndim(nb) == 0 and np.ndim(nk) == 0
        m = 1 if single else (len(nb) if np.ndim(nb) else len(nk))
        return ARX(na, nb, nk, dt=dt), m, single

    def _init_structure(self, model, m, single):
        model._set_inputs(m, single)
        self._model = model
        self.na = model.na
        self.nb = tuple(model._nb)
        self.nk = tuple(model._nk)
        self._m = m
        self._single = single
        self.names = model._names()
        self.n_params = len(self.names)
        if self.n_params == 0:
            raise param_error("na + sum(nb)", ">= 1", 0)
        # u lags held: u(k-1) … u(k-Lu); the current u(k) comes with step()
        self._Lu = max([k + b - 1 for k, b in zip(self.nk, self.nb) if b] or [0])
        self._s = max([self.na] + [k + b - 1 for k, b in zip(self.nk, self.nb) if b])

    # ------------------------------------------------------------ state
    @property
    def estimator(self):
        """The core estimator (read it; :meth:`step` and :meth:`run` update it)."""
        return self._est

    def _run_on(self, estimator):
        """Run on ``estimator`` itself (not a copy, not reset: its θ, P and counts as they
        are), with its algorithm and options; the lag buffers and the sample count stay
        this object's. For the CLI, whose options build, or whose ``--resume`` file
        holds, that estimator (``fit --arx/--ar/--fir`` with a recursive method)."""
        from ...estimators._factory import method_of

        core = method_of(estimator)   # TypeError for anything but the factory's estimators
        if estimator.n_params != self.n_params:
            raise param_error("estimator", f"an estimator with n_params={self.n_params}",
                              f"<n_params={estimator.n_params}>")
        self.method = {"rls": "forgetting", "window": "forgetting", "kalman": "kalman",
                       "lms": "gradient", "nlms": "ngradient"}[core]
        self._est = estimator
        return self

    @property
    def theta(self):
        """The current estimate, shape (n,) (a copy)."""
        return np.array(self._est.theta, dtype=np.float64).reshape(-1)

    def reset(self):
        """Back to the prior (θ₀, P₀) with zero lag buffers and the sample count at 0."""
        self._est.reset()
        self._count = 0
        self._restart()

    def _restart(self):
        """Zero lag buffers (a new experiment): the estimate and P run on."""
        self._ybuf = np.zeros(self.na)               # y(k-1), …, y(k-na)
        self._ubuf = np.zeros((self._m, self._Lu))   # u(k-1), …, u(k-Lu) per input
        self._since = 0                              # samples since the buffers restarted

    # ------------------------------------------------------ regressors
    def _inputs(self, u, N, where="u"):
        if self._m == 0 or not any(self.nb):
            if u is not None and np.size(u) and self._m == 0:
                raise param_error(where, "None (the model has no input)", "<an array>",
                                  exc=TypeError)
            return np.zeros((N, self._m))
        if u is None:
            raise param_error(where, "an input signal", None, exc=TypeError)
        U = as_float_array(u, where)
        if U.ndim <= 1 and self._m == 1:
            U = U.reshape(N, 1) if U.size == N else U
        if U.shape != (N, self._m):
            raise param_error(where, f"of shape ({N},) or ({N}, {self._m})" if self._m == 1
                              else f"of shape ({N}, {self._m})", f"<shape {np.shape(u)}>")
        return U

    def _regressors(self, y, U):
        """Φ (N, n) of the samples y, U following the buffers, and the new buffers."""
        N = y.shape[0]
        yext = np.concatenate([self._ybuf[::-1], y])            # oldest first
        k = np.arange(N)
        cols = [-yext[self.na + k - j] for j in range(1, self.na + 1)]
        new_ybuf = yext[::-1][: self.na].copy()
        new_ubuf = np.empty((self._m, self._Lu))
        for i in range(self._m):
            uext = np.concatenate([self._ubuf[i, ::-1], U[:, i]])
            cols += [uext[self._Lu + k - j] for j in range(self.nk[i], self.nk[i] + self.nb[i])]
            new_ubuf[i] = uext[::-1][: self._Lu]
        Phi = np.column_stack(cols) if cols else np.zeros((N, 0))
        return np.ascontiguousarray(Phi, dtype=np.float64), new_ybuf, new_ubuf

    # ------------------------------------------------------------ use
    def step(self, y, u=None):
        r"""One sample: MATLAB's ``[A, B, yhat] = step(obj, y, u)``.

        Parameters
        ----------
        y : float
            Output y(k).
        u : float or array_like, shape (m,)
            Input(s) u(k) (needed with ``nb > 0``; none for :class:`RecursiveAR`).

        Returns
        -------
        theta : ndarray, shape (n,)
            The estimate after y(k) is used (a copy).
        yhat : float
            The one-step prediction :math:`\varphi_k^T\hat\theta_{k-1}`
            made before y(k) is used (NaN while ``start="filled"`` waits).
        """
        yv = as_float_array(y, "y").reshape(-1)
        if yv.shape != (1,):
            raise param_error("y", "one output sample (a scalar)", f"<shape {np.shape(y)}>")
        U = self._inputs(None if u is None else np.reshape(as_float_array(u, "u"), (1, -1)), 1)
        Phi, ybuf, ubuf = self._regressors(yv, U)
        if self.start == "filled" and self._since < self._s:
            yhat = np.nan
        else:
            th = np.array(self._est.theta, dtype=np.float64).reshape(1, -1)
            yhat = float(_row_dot(Phi, th)[0])
            self._est.update(Phi[0], yv[0])
        self._ybuf, self._ubuf = ybuf, ubuf
        self._count += 1
        self._since += 1
        return self.theta, yhat

    def run(self, y, u=None):
        """A record at once: equal bit for bit to one :meth:`step` per sample.

        The regressors are formed in NumPy from the buffers and the record,
        and the core estimator runs over them in one compiled pass; the
        object continues from the record's end.

        Parameters
        ----------
        y : array_like, shape (N,); pandas; IDData; tuple ``(y, u)``; DataFrame
            The output, or the whole record (the one input convention of
            :func:`adaptid.models._iddata.as_signals`). An IDData, or a
            pandas record with names or a time index, sets ``dt`` (that of
            its time axis; arrays leave it).
        u : array_like, shape (N,) or (N, m), optional

        Returns
        -------
        StreamResult
            ``theta`` (N, n) after each sample, ``yhat`` (N,) before it.

        Notes
        -----
        A merged IDData (:meth:`IDData.merge <adaptid.IDData.merge>`) is run
        experiment by experiment: the lag buffers restart from zero at the
        first sample of each (``start="filled"`` waits again), while the
        estimator's θ and P run on; equal to :meth:`step` over the samples
        with the buffers zeroed at each boundary.
        """
        from .._iddata import as_signals

        yy, uu, data = as_signals(y, u)
        yy = as_float_array(yy, "y", ndim=1)
        U = self._inputs(uu, yy.shape[0])
        theta, yhat = _by_experiment(self, self._samples, yy, U, data)
        if data is not None and getattr(data, "dt", None) is not None:
            self.dt = float(data.dt)
        return StreamResult(theta=theta, yhat=yhat, names=self.names)

    def _samples(self, yy, U):
        """The samples of one experiment following the buffers: (theta, yhat)."""
        N = yy.shape[0]
        Phi, ybuf, ubuf = self._regressors(yy, U)
        used = np.ones(N, dtype=bool)
        if self.start == "filled":
            used[: max(self._s - self._since, 0)] = False
        th_prev = np.empty((N, self.n_params))
        theta = np.empty((N, self.n_params))
        yhat = np.full(N, np.nan)
        first = int(np.argmax(used)) if used.any() else N
        before = self.theta
        theta[:first] = before
        th_prev[:first] = before
        if first < N:
            traj = self._est.run(Phi[first:], yy[first:])
            Th = np.asarray(traj.theta, dtype=np.float64).reshape(N - first, -1)
            theta[first:] = Th
            th_prev[first] = before
            th_prev[first + 1:] = Th[:-1]
            yhat[first:] = _row_dot(Phi[first:], th_prev[first:])
        self._ybuf, self._ubuf = ybuf, ubuf
        self._count += N
        self._since += N
        return theta, yhat

    def to_model(self):
        """The :class:`~adaptid.models.ARX` (:class:`~adaptid.models.AR`) with the current θ."""
        import copy

        model = copy.deepcopy(self._model)
        if self._m == 0:  # AR: the internal all-zero input column of AR's own fit
            model._set_inputs(1, True)
        model.dt = self.dt
        model.theta = self.theta
        model.names = self.names
        model.cov = None
        model.noise_variance = None
        return model

    # ---------------------------------------------------- state files
    _STATE_FILE_ARRAYS = {"ybuf": "ybuf", "ubuf": "ubuf"}

    def _options(self):
        return {"na": self.na, "nb": list(self.nb), "nk": list(self.nk), "single": self._single,
                "method": self.method, "start": self.start, "dt": self.dt,
                "count": self._count, "since": self._since}

    def get_state(self) -> dict:
        """Everything needed to resume exactly: the core estimator's state, the lag
        buffers, the structure and the sample count (plain values, float64 arrays)."""
        return {
            "estimator": self._kind,
            "format": self._STATE_FORMAT,
            "n_params": max(self.n_params, self.na, self._Lu, self._m, 1),
            "options": self._options(),
            "inner": self._est.get_state(),
            "ybuf": self._ybuf.reshape(1, -1).copy(),
            "ubuf": self._ubuf.copy(),
        }

    @classmethod
    def _build(cls, o):
        nb = o["nb"][0] if o["single"] else o["nb"]
        nk = o["nk"][0] if o["single"] else o["nk"]
        return cls(o["na"], nb, nk, method=o["method"], start=o["start"], dt=o["dt"])

    @classmethod
    def from_state(cls, state: dict):
        """Rebuild from :meth:`get_state`'s dict (exact round trip)."""
        from ...estimators._statefile import estimator_from_state

        cls._check_state(state)
        try:
            o = dict(state["options"])
            obj = cls._build(o)
            inner = estimator_from_state(state["inner"])
            ybuf = np.array(state["ybuf"], dtype=np.float64).reshape(-1)
            ubuf = np.array(state["ubuf"], dtype=np.float64)
            count = o["count"]
            since = o.get("since", count)    # states written before buffers restarted
        except KeyError as err:
            raise param_error("state", "a complete dict from get_state()",
                              f"<missing key {err.args[0]!r}>") from None
        if inner.n_params != obj.n_params:
            raise param_error("state['inner']", f"an estimator of {obj.n_params} parameters",
                              f"<{inner.n_params} parameters>")
        if ybuf.shape != obj._ybuf.shape or ubuf.shape != obj._ubuf.shape:
            raise param_error("state", "lag buffers of the model's structure",
                              f"<shapes {ybuf.shape}, {ubuf.shape}>")
        if type(count) is not int or count < 0:
            raise param_error("state['options']['count']", "an integer >= 0", count)
        if type(since) is not int or not 0 <= since <= count:
            raise param_error("state['options']['since']", "an integer in [0, count]", since)
        obj._est, obj._ybuf, obj._ubuf, obj._count = inner, ybuf, ubuf, count
        obj._since = since
        return obj

    def __repr__(self):
        return (f"{type(self).__name__}(na={self.na}, nb={self.nb}, nk={self.nk}, "
                f"method={self.method!r}, start={self.start!r}, n_updates="
                f"{self._est.n_updates})")


class RecursiveAR(RecursiveARX):
    r"""Streaming AR model: MATLAB's ``recursiveAR`` (``obj = recursiveAR(na)``).

    :math:`\varphi_k = [-y_{k-1}, \dots, -y_{k-n_a}]^T`, θ = [a₁, …, a_na];
    ``step(y)`` returns ``(theta, yhat)``. Everything else as
    :class:`RecursiveARX` (methods, ``window``, ``start``, state files);
    :meth:`to_model` returns an :class:`~adaptid.models.AR`, and with
    ``start="filled"`` :meth:`run` equals ``AR(na).fit_recursive`` bit for bit.

    Parameters
    ----------
    na : int
        Order of A, ``>= 1``.
    **options
        As :class:`RecursiveARX` (``method``, ``forgetting``, ``noise_cov``,
        ``noise_var``, ``step``, ``bias``, ``window``, ``theta0``, ``P0``,
        ``start``, ``dt``).

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import lfilter
    >>> from adaptid.models import RecursiveAR
    >>> y = lfilter([1], [1, -0.8], np.random.default_rng(1).standard_normal(3000))
    >>> res = RecursiveAR(1).run(y)
    >>> bool(abs(res.theta[-1, 0] + 0.8) < 0.05)
    True
    """

    _kind = "RecursiveAR"

    def __init__(self, na, *, method="forgetting", forgetting=1.0, noise_cov=0.1,
                 noise_var=1.0, step=1.0, bias=None, window=None, theta0=None, P0=1e4,
                 start="zero", dt=1.0):
        super().__init__(na, 0, 1, method=method, forgetting=forgetting, noise_cov=noise_cov,
                         noise_var=noise_var, step=step, bias=bias, window=window,
                         theta0=theta0, P0=P0, start=start, dt=dt)

    def _make_model(self, na, nb, nk, dt):
        from .._ar import AR
        return AR(na, dt=dt), 0, True

    def step(self, y):  # noqa: D102 - documented on RecursiveARX
        return super().step(y)

    step.__doc__ = RecursiveARX.step.__doc__

    def run(self, y):  # noqa: D102
        return super().run(y)

    run.__doc__ = RecursiveARX.run.__doc__

    @classmethod
    def _build(cls, o):
        return cls(o["na"], method=o["method"], start=o["start"], dt=o["dt"])
