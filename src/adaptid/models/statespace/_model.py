r"""The discrete-time state-space model in innovation form."""

from __future__ import annotations

import numpy as np

from ..._validation import as_float_array, check_int, check_scalar, param_error
from ._present import StateSpacePresentation
from ._signals import Experiments, experiments, input_matrix, recurse

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
    cov : array_like, shape (d, d), optional
        Covariance of θ = [A, B, C, D, K] (each matrix row by row,
        d = n² + nm + pn + pm + np); see :meth:`estimate_cov`.

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
    >>> m.step_response(3).response
    array([0. , 1. , 1.5])
    """

    def __init__(self, A, B, C, D=None, K=None, *, noise_cov=None, dt=1.0, y_names=None,
                 u_names=None, singular_values=None, info=None, cov=None):
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
        self._fit_dask = None  # the same when they are Dask arrays (read chunk by chunk)
        self._cov_tried = False   # cov computed from _fit_data once, on first use
        self.cov = cov

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
    @property
    def cov(self):
        r"""Covariance of θ = [A, B, C, D, K] (each row by row), shape (d, d), or None.

        Models from :func:`~adaptid.models.n4sid` and :func:`~adaptid.models.okid`
        compute it on first use from their estimation data
        (:meth:`estimate_cov`, the predictor's initial state estimated; a
        Dask record is read chunk by chunk, three times);
        a model built from matrices has none unless ``cov`` was given.
        """
        data = self._fit_data if self._fit_data is not None else self._fit_dask
        if self._cov is None and data is not None and not self._cov_tried:
            self._cov_tried = True
            self._cov = self.estimate_cov(data)
        return self._cov

    @cov.setter
    def cov(self, value):
        self._cov = None if value is None else _matrix(value, "cov", (self._d, self._d))

    @property
    def _d(self):
        from ._uncertainty import n_params

        return n_params(self.order, self.n_inputs, self.n_outputs)

    def estimate_cov(self, data, *, x0="estimate", feedthrough=None, max_memory=None):
        r"""Covariance of θ = [A, B, C, D, K] from the one-step prediction errors on ``data``.

        The prediction-error covariance of the full parameterisation at this
        model's matrices: with :math:`\psi_k = \partial\varepsilon_k/\partial\theta`
        (exact sensitivities of the Kalman predictor, one compiled recursion)
        and :math:`\hat\Lambda = \frac1N\sum\varepsilon_k\varepsilon_k^\mathsf T`,

        .. math::

            \operatorname{Cov}\hat\theta \approx
            \Bigl(\sum_k\psi_k^\mathsf T\hat\Lambda^{-1}\psi_k\Bigr)^{+}
            \qquad(\hat\lambda\,(J^\mathsf TJ)^{+}\text{ for one output}),

        Ljung (1999), eq. 9.17 and sec. 9.4. The full parameterisation is
        over-parameterised (similarity transformations leave the predictor
        unchanged), so the Moore–Penrose pseudo-inverse is used: its null
        space holds the n² similarity directions, along which G, the step
        response and the poles do not change, so their propagated standard
        deviations are well defined (Ljung 1999, sec. 9.4, remark on
        over-parameterised models; McKelvey & Helmersson 1997, on full
        parameterisations). The predictor's initial state of each experiment
        is a nuisance parameter (least squares) unless ``x0="zero"``.

        The memory does not grow with N: the Jacobian
        :math:`\tilde J` (N p rows, d + n·(experiments) columns) is never
        formed whole. The record is read in chunks of
        :math:`N_c = \max(1, \lfloor M/8p(d + n)\rfloor)` samples,
        M = ``max_memory`` — a pass for the initial states, one for
        :math:`\hat\Lambda`, one for the sensitivities, whose state is carried
        from chunk to chunk — and the triangular factor R of :math:`\tilde J` is
        updated by a QR of :math:`[R;\ \tilde J_c]` per chunk (equal to the QR
        of the whole :math:`\tilde J` to rounding). The Dask record of a model
        fitted on Dask arrays (its :attr:`cov`) is read the same way.

        Parameters
        ----------
        data : IDData, (y, u) tuple, or a list of them
        x0 : {"estimate", "zero"}
        feedthrough : bool, optional
            Whether D is free (default: as estimated, ``info["feedthrough"]``,
            else whether D is non-zero).
        max_memory : int, optional
            Bytes for the Jacobian rows of one chunk, :math:`N_c\,p\,(d + n)`
            float64 (default 32 MiB). The peak memory of the call is a few
            times this (the chunk's rows times the basis of the identifiable
            directions, whitened, then reduced in place) plus the record;
            smaller chunks cost only time (more, smaller steps).

        Returns
        -------
        ndarray, shape (d, d)
            d = n² + nm + pn + pm + np; zero rows and columns for a fixed D.

        References
        ----------
        L. Ljung (1999). *System Identification: Theory for the User*, 2nd ed.
        Prentice Hall. Sec. 9.4.
        T. McKelvey, A. Helmersson (1997). System identification using an
        over-parametrized model class — improving the optimization algorithm.
        *Proc. 36th IEEE CDC*, 2984–2989. :doi:`10.1109/CDC.1997.657907`.
        """
        from ..._validation import check_choice
        from ._uncertainty import MAX_MEMORY, prediction_error_cov

        ex = data if isinstance(data, Experiments) else experiments(data)
        self._check_signals(ex)
        x0 = check_choice(x0, "x0", ("estimate", "zero"))
        if feedthrough is None:
            feedthrough = bool(self.info.get("feedthrough", np.any(self.D != 0)))
        budget = MAX_MEMORY if max_memory is None else check_int(max_memory, "max_memory",
                                                                 low=1)
        cov, _ = prediction_error_cov(self, ex, x0=x0, feedthrough=bool(feedthrough),
                                      max_memory=budget)
        return cov

    def poles(self):
        r"""Eigenvalues of A with first-order standard deviations (:class:`~adaptid.models.Roots`).

        For a simple eigenvalue λ with right and left eigenvectors v, w:
        :math:`\partial\lambda/\partial A_{ij} = \bar w_iv_j/(w^\mathsf Hv)`
        (no standard deviations without :attr:`cov`). ``Roots`` converts to an
        array (``np.asarray(model.poles())``) and has ``.real``/``.imag``.
        """
        from ._uncertainty import poles_sd

        return poles_sd(self, self.cov)

    def zeros(self):
        r"""Invariant zeros with first-order standard deviations.

        The finite generalised eigenvalues z of
        :math:`[A, B; -C, -D]\,v = z\,[I, 0; 0, 0]\,v`;
        for a simple zero with right and left eigenvectors v, w,
        :math:`\partial z = w^\mathsf H(\partial F)v/(w^\mathsf HEv)`.

        Returns
        -------
        Roots or list of lists of Roots
            One ``Roots`` for a square system (p = m), else ``[output][input]``
            the zeros of each channel.
        """
        from ._uncertainty import zeros_sd

        return zeros_sd(self, self.cov)

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

    def _layout(self, X):
        """(T, p, m) or (F, p, m) → (T,) for one input and output, else (p, m, T)."""
        if X is None:
            return None
        return X[:, 0, 0] if X.shape[1:] == (1, 1) else np.moveaxis(X, 0, -1)

    def step_response(self, T=None):
        r"""Step response with its standard deviation per sample (from :attr:`cov`).

        The output at samples 0 … T − 1 after a unit step on each input at
        sample 0 from a zero state (the cumulated Markov parameters); the
        standard deviation is the first-order propagation of :attr:`cov`
        with the exact sensitivities of the simulation (similarity invariant).

        Parameters
        ----------
        T : int, optional
            Number of samples; default ten times the slowest time constant
            :math:`-1/\ln\max|\lambda(A)|` within [20, 2000] (2000 for a pole
            on or outside the unit circle).

        Returns
        -------
        StepResponse
            ``response`` and ``sd`` of shape (T,) for one input and output,
            (p, m, T) otherwise.
        """
        from ..frequency._step import StepResponse, check_length, default_length
        from ._uncertainty import step_sd

        if T is None:
            T = default_length([1.0], np.poly(self.A) if self.order else [1.0])
        else:
            T = check_length(T)
        s, sd = step_sd(self, T, self.cov)
        return StepResponse(np.arange(T) * self.dt, self._layout(s), self._layout(sd),
                            dt=self.dt, y_names=self.y_names, u_names=self.u_names)

    def freqresp(self, w=None):
        r"""Frequency response :math:`G(e^{i\omega\,dt}) = C(zI - A)^{-1}B + D` with its sd.

        With :math:`R = (zI - A)^{-1}` the derivatives are analytic,
        :math:`\partial G/\partial A_{ij} = (CR)_{:,i}(RB)_{j,:}`,
        :math:`\partial G/\partial B_{ij} = (CR)_{:,i}e_j^\mathsf T`,
        :math:`\partial G/\partial C_{ij} = e_i(RB)_{j,:}`,
        :math:`\partial G/\partial D_{ij} = e_ie_j^\mathsf T`; the
        covariance of (Re G, Im G) is :math:`J\Sigma J^\mathsf T` (Σ = :attr:`cov`)
        and the standard deviations of :math:`|G|` and :math:`\arg G` follow
        by the delta method (MATLAB's convention, see
        :meth:`adaptid.models.ARX.freqresp`). G is similarity invariant, so
        the null directions of the pseudo-inverse Σ do not enter.

        Parameters
        ----------
        w : array_like, shape (F,), optional
            Angular frequencies in rad per time unit of ``dt`` (as MATLAB's
            ``freqresp`` and python-control); ``w·dt = π`` is the Nyquist
            frequency. Default MATLAB's 128 points
            :math:`\frac{k}{128}\frac{\pi}{dt}`, k = 1 … 128.

        Returns
        -------
        FrequencyResponse
            ``response`` of shape (F,) for one input and output, else
            (p, m, F); ``magnitude_sd``/``phase_sd`` when :attr:`cov` is known.
            ``np.asarray(fr)`` is ``fr.response``.
        """
        from ..frequency._response import FrequencyResponse, default_grid
        from ._uncertainty import freqresp_sd

        if w is None:
            w = default_grid(self.dt)
        w = as_float_array(w, "w", ndim=(0, 1)).reshape(-1)
        G, msd, psd = freqresp_sd(self, w, self.cov)
        return FrequencyResponse(w, self._layout(G), self.dt, magnitude_sd=self._layout(msd),
                                 phase_sd=self._layout(psd), y_names=self.y_names,
                                 u_names=self.u_names)

    def rsample(self, n, seed=None):
        r"""n models with θ drawn from :math:`N(\hat\theta, \Sigma)`: MATLAB's ``rsample``.

        Σ = :attr:`cov` is singular (the similarity directions, a fixed D):
        the draws vary only in the directions it spans. Each model carries
        this model's ``cov``, ``noise_cov``, names and ``info``.

        Parameters
        ----------
        n : int
            Number of models, ``>= 1``.
        seed : int or numpy.random.Generator, optional

        Returns
        -------
        list of StateSpaceModel
        """
        from ._uncertainty import pack, unpack

        n = check_int(n, "n", low=1)
        cov = self.cov
        if cov is None:
            raise param_error("self", "a model with a parameter covariance (cov)", "<cov None>")
        rng = np.random.default_rng(seed)
        theta = pack(self.A, self.B, self.C, self.D, self.K)
        out = []
        for th in rng.multivariate_normal(theta, cov, size=n, method="eigh"):
            A, B, C, D, K = unpack(th, self.order, self.n_inputs, self.n_outputs)
            mdl = StateSpaceModel(A, B, C, D, K, noise_cov=self.noise_cov, dt=self.dt,
                                  y_names=self.y_names, u_names=self.u_names, info=self.info,
                                  cov=cov)
            out.append(mdl)
        return out

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
    def minreal(self, tol=None):
        r"""A minimal realisation of the model (MATLAB's ``minreal``), as a new model.

        The states that neither the inputs nor the innovations reach, or
        that the outputs do not see, are removed: the realisation
        :math:`(A, [B\ K], C, [D\ I])` of the input and noise channels
        together is reduced by orthogonal staircase transformations (its
        controllable part, then the observable part of that; Van Dooren
        1981; SLICOT TB01PD), see
        :func:`adaptid.models.statespace._minreal.minimal_realization`.
        Both the deterministic part and the predictor keep their Markov
        parameters; ``noise_cov``, ``dt``, names and ``info`` are kept,
        the parameter covariance is not (it belongs to the old coordinates).

        Parameters
        ----------
        tol : float, optional
            Relative tolerance of the rank decisions: a singular value
            counts when it exceeds ``tol`` times the larger Frobenius norm
            of A and [B K] (of A and C in the dual pass); default
            :math:`n^2\varepsilon`, which removes exact redundancy only.

        Returns
        -------
        StateSpaceModel

        References
        ----------
        P. Van Dooren (1981). The generalized eigenstructure problem in linear
        system theory. *IEEE Trans. Automatic Control* 26(1), 111–129.

        Examples
        --------
        >>> from adaptid.models import StateSpaceModel
        >>> m = StateSpaceModel([[0.5, 0.0], [0.0, 0.8]], [[1.0], [0.0]], [[1.0, 1.0]])
        >>> m.minreal().order
        1
        """
        from ._minreal import minimal_realization

        m, p = self.n_inputs, self.n_outputs
        A, BK, C, _ = minimal_realization(self.A, np.hstack([self.B, self.K]), self.C,
                                          tol=tol)
        return StateSpaceModel(A, BK[:, :m], C, self.D, BK[:, m:m + p],
                               noise_cov=self.noise_cov, dt=self.dt, y_names=self.y_names,
                               u_names=self.u_names, singular_values=self.singular_values,
                               info=dict(self.info, minreal=True))

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
