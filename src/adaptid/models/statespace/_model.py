r"""The discrete-time state-space model in innovation form."""

from __future__ import annotations

import numpy as np

from ..._validation import as_float_array, check_int, check_scalar, param_error
from ._present import StateSpacePresentation
from ._signals import experiments, input_matrix, recurse

__all__ = ["StateSpaceModel"]


def _matrix(value, name, shape):
    arr = as_float_array(value, name, ndim=(0, 1, 2))
    if arr.size == 0 and 0 in shape:
        return np.zeros(shape)
    arr = arr.reshape(shape) if arr.size == shape[0] * shape[1] and arr.ndim < 2 else arr
    if arr.shape != shape:
        raise param_error(name, f"of shape {shape}", f"<shape {arr.shape}>")
    return arr


class StateSpaceModel(StateSpacePresentation):
    r"""A linear time-invariant model in innovation (Kalman predictor) form.

    .. math::

        x_{k+1} = A x_k + B u_k + K e_k,\qquad y_k = C x_k + D u_k + e_k,
        \qquad \operatorname{E} e_k e_k^\mathsf T = \Sigma_e,

    with n states, m inputs and p outputs; :math:`e_k` is the innovation
    (the one-step prediction error of the steady-state Kalman filter).
    Returned by :func:`~adaptid.models.n4sid`, :func:`~adaptid.models.era`
    and :func:`~adaptid.models.okid`; it can also be built from matrices.

    Parameters
    ----------
    A : array_like, shape (n, n)
    B : array_like, shape (n, m)
    C : array_like, shape (p, n)
    D : array_like, shape (p, m), optional
        Default zero (no direct feedthrough).
    K : array_like, shape (n, p), optional
        Innovation gain; default zero (an output-error model).
    noise_cov : array_like, shape (p, p), optional
        Innovation covariance :math:`\Sigma_e`; default zero.
    dt : float
        Sample time (default 1.0).
    y_names, u_names : sequence of str, optional
    singular_values : array_like, optional
        The singular values the order was read from (subspace methods, ERA).

    Attributes
    ----------
    A, B, C, D, K, noise_cov : ndarray
    dt : float
    y_names, u_names : tuple of str
    singular_values : ndarray or None
    order : int
        n, the number of states.
    info : dict
        How the model was obtained (method, horizon, number of samples, …).

    Examples
    --------
    >>> import numpy as np
    >>> from adaptid.models import StateSpaceModel
    >>> m = StateSpaceModel([[0.5]], [[1.0]], [[1.0]])
    >>> m.markov(3)[:, 0, 0]      # D, CB, CAB
    array([0. , 1. , 0.5])
    >>> m.step_response(3)[:, 0, 0]
    array([0. , 1. , 1.5])
    """

    def __init__(self, A, B, C, D=None, K=None, *, noise_cov=None, dt=1.0, y_names=None,
                 u_names=None, singular_values=None, info=None):
        A = np.atleast_2d(as_float_array(A, "A", ndim=(0, 1, 2)))
        n = A.shape[0]
        if A.shape != (n, n):
            raise param_error("A", "a square matrix", f"<shape {A.shape}>")
        B = as_float_array(B, "B", ndim=(1, 2))
        B = B.reshape(-1, 1) if B.ndim == 1 else B
        if B.shape[0] != n:
            raise param_error("B", f"with n={n} rows (as A)", f"<shape {B.shape}>")
        C = np.atleast_2d(as_float_array(C, "C", ndim=(1, 2)))
        if C.shape[1] != n:
            raise param_error("C", f"with n={n} columns (as A)", f"<shape {C.shape}>")
        m, p = B.shape[1], C.shape[0]
        self.A, self.B, self.C = A, B, C
        self.D = np.zeros((p, m)) if D is None else _matrix(D, "D", (p, m))
        self.K = np.zeros((n, p)) if K is None else _matrix(K, "K", (n, p))
        self.noise_cov = np.zeros((p, p)) if noise_cov is None else _matrix(noise_cov, "noise_cov",
                                                                            (p, p))
        self.dt = check_scalar(dt, "dt", low=0.0, low_open=True)
        self.y_names = _names(y_names, "y", p, "y_names")
        self.u_names = _names(u_names, "u", m, "u_names")
        self.singular_values = (None if singular_values is None
                                else np.asarray(singular_values, dtype=np.float64))
        self.info = dict(info or {})
        self._fit_data = None  # Experiments the model was estimated from (for summary)

    # ---------------------------------------------------------------- sizes
    @property
    def order(self) -> int:
        """Number of states n."""
        return self.A.shape[0]

    @property
    def n_inputs(self) -> int:
        return self.B.shape[1]

    @property
    def n_outputs(self) -> int:
        return self.C.shape[0]

    # ----------------------------------------------------------- responses
    def poles(self):
        """Eigenvalues of A, shape (n,)."""
        return np.linalg.eigvals(self.A)

    def markov(self, n):
        r"""Markov parameters (impulse response) :math:`D, CB, CAB, \dots, CA^{n-2}B`.

        Parameters
        ----------
        n : int
            Number of them, ≥ 1.

        Returns
        -------
        ndarray, shape (n, p, m)
            ``markov[0] = D``, ``markov[k] = C A^{k-1} B``.
        """
        n = check_int(n, "n", low=1)
        out = np.empty((n, self.n_outputs, self.n_inputs))
        out[0] = self.D
        CA = self.C.copy()
        for k in range(1, n):
            out[k] = CA @ self.B
            CA = CA @ self.A
        return out

    def step_response(self, n):
        """Step response at samples 0 … n − 1, shape (n, p, m) (cumulated Markov parameters)."""
        return np.cumsum(self.markov(n), axis=0)

    def freqresp(self, w):
        r"""Frequency response :math:`G(e^{i\omega\,dt}) = C(zI - A)^{-1}B + D`.

        Parameters
        ----------
        w : array_like, shape (F,)
            Angular frequencies in rad per time unit of ``dt`` (as MATLAB's
            ``freqresp`` and python-control); ``w·dt = π`` is the Nyquist frequency.

        Returns
        -------
        ndarray of complex, shape (F, p, m)
        """
        w = as_float_array(w, "w", ndim=(0, 1)).reshape(-1)
        z = np.exp(1j * w * self.dt)
        n = self.order
        M = z[:, None, None] * np.eye(n) - self.A  # (F, n, n)
        X = np.linalg.solve(M, np.broadcast_to(self.B.astype(complex), (w.size, n, self.n_inputs)))
        return self.C @ X + self.D

    # ---------------------------------------------------------- simulation
    def _x0(self, x0):
        if x0 is None:
            return np.zeros(self.order)
        return as_float_array(x0, "x0", shape=(self.order,))

    def simulate(self, u, x0=None):
        r"""Output of the deterministic part for an input.

        :math:`x_{k+1} = Ax_k + Bu_k`, :math:`y_k = Cx_k + Du_k` (no innovation).

        Parameters
        ----------
        u : array_like, shape (N, m) or (N,) for one input; IDData; or (y, u) tuple
            The input (an IDData or a tuple gives its inputs).
        x0 : array_like, shape (n,), or "estimate", optional
            Initial state: zero by default; ``"estimate"`` fits it by least
            squares to the outputs of ``u`` (then an IDData or a (y, u)
            tuple), see :meth:`estimate_x0`.

        Returns
        -------
        ndarray, shape (N, p)
        """
        if isinstance(x0, str):
            if x0 != "estimate":
                raise param_error("x0", "an array of shape (n,), None or 'estimate'", x0)
            x0 = self.estimate_x0(u)
        if isinstance(u, tuple):
            u = u[1]
        U = input_matrix(u, self.n_inputs)
        X = recurse(self.A, U @ self.B.T, self._x0(x0))
        return X @ self.C.T + U @ self.D.T

    def _x0_regressor(self, N):
        """(N, p, n): row k is C A^k (the free response to each initial state)."""
        P = recurse(self.A, np.zeros((N, self.order, self.order)), np.eye(self.order))
        return self.C @ P

    def estimate_x0(self, data):
        r"""Initial state that best explains a record's outputs (least squares).

        .. math::

            \hat x_0 = \arg\min_{x_0}\sum_k \lVert y_k - C A^k x_0 - y^{(0)}_k\rVert^2,

        :math:`y^{(0)}` the simulation from a zero state (one ``lstsq`` of N·p
        rows and n columns).

        Parameters
        ----------
        data : IDData or (y, u) tuple

        Returns
        -------
        ndarray, shape (n,)
        """
        ex = experiments(data)
        if len(ex.Y) != 1:
            raise param_error("data", "one experiment", f"<{len(ex.Y)} experiments>")
        self._check_signals(ex)
        Y, U = ex.Y[0], ex.U[0]
        r = Y - self.simulate(U)
        Phi = self._x0_regressor(Y.shape[0]).reshape(-1, self.order)
        return np.linalg.lstsq(Phi, r.reshape(-1), rcond=None)[0]

    def _check_signals(self, ex):
        if (ex.p, ex.m) != (self.n_outputs, self.n_inputs):
            raise param_error("data", f"{self.n_outputs} output(s) and {self.n_inputs} input(s)",
                              f"<{ex.p} outputs, {ex.m} inputs>")

    def _signals(self, data, u):
        if u is None:
            ex = experiments(data)
        else:
            ex = experiments((data, u))
        if len(ex.Y) != 1:
            raise param_error("data", "one experiment", f"<{len(ex.Y)} experiments>")
        self._check_signals(ex)
        return ex.Y[0], ex.U[0]

    def predict(self, data, u=None, k=1, *, x0=None):
        r"""k-step-ahead prediction :math:`\hat y_{t|t-k}` through the Kalman predictor.

        The one-step predictor (k = 1) is the innovation form run on the data:

        .. math::

            \hat x_{t+1|t} = A\hat x_{t|t-1} + Bu_t + K(y_t - C\hat x_{t|t-1} - Du_t),\qquad
            \hat y_{t|t-1} = C\hat x_{t|t-1} + Du_t ;

        for k > 1 the state :math:`\hat x_{t-k+1|t-k}` is propagated k − 1
        steps with the measured inputs and no innovation:
        :math:`\hat y_{t|t-k} = C\hat x_{t|t-k} + Du_t`,
        :math:`\hat x_{s+1|t-k} = A\hat x_{s|t-k} + Bu_s`. The first k − 1
        predictions start from the initial state.

        Parameters
        ----------
        data : IDData, (y, u) tuple, or ndarray of shape (N, p) (then ``u`` given)
        u : array_like, shape (N, m), optional
        k : int
            Horizon ≥ 1 (default 1).
        x0 : array_like, shape (n,), optional
            :math:`\hat x_{0|-1}` (default zero).

        Returns
        -------
        ndarray, shape (N, p)
        """
        Y, U = self._signals(data, u)
        k = check_int(k, "k", low=1)
        A, B, C, D, K = self.A, self.B, self.C, self.D, self.K
        Abar = A - K @ C
        inj = U @ (B - K @ D).T + Y @ K.T
        X = recurse(Abar, inj, self._x0(x0))  # x̂(t|t-1)
        BU = U @ B.T
        for _ in range(k - 1):
            Xn = np.empty_like(X)
            Xn[0] = self._x0(x0)
            Xn[1:] = X[:-1] @ A.T + BU[:-1]
            X = Xn
        return X @ C.T + U @ D.T

    # -------------------------------------------------------------- control
    def to_control(self):
        """The model as a discrete python-control ``StateSpace`` (A, B, C, D; dt; names).

        Raises
        ------
        ImportError
            If python-control is not installed (``pip install 'adaptid[control]'``).
        """
        try:
            import control
        except ImportError as err:  # pragma: no cover - depends on the extra
            raise ImportError("to_control needs python-control: "
                              "pip install 'adaptid[control]'") from err
        return control.ss(self.A, self.B, self.C, self.D, self.dt,
                          inputs=list(self.u_names), outputs=list(self.y_names))

    def __repr__(self):
        how = self.info.get("method")
        how = f", {how}" if how else ""
        return (f"StateSpaceModel(order={self.order}, outputs={list(self.y_names)}, "
                f"inputs={list(self.u_names)}, dt={self.dt:g}{how})")


def _names(given, prefix, count, what):
    if given is None:
        return (prefix,) if count == 1 else tuple(f"{prefix}{i + 1}" for i in range(count))
    names = (given,) if isinstance(given, str) else tuple(str(g) for g in given)
    if len(names) != count:
        raise param_error(what, f"{count} name(s)", f"<{len(names)} names>")
    return names
