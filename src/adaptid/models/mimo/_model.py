r"""The MIMO ARX model object: fit, prediction, simulation, python-control."""

from __future__ import annotations

import numpy as np

from ..._validation import as_float_array, check_choice, check_int, check_scalar, param_error
from .._iddata import IDData
from ._data import input_array, one_record, records
from ._estimate import batch_fit, recursive_fit
from ._orders import check_spec, layout, resolve, stack_rows
from ._present import Presentation
from ._responses import Responses

__all__ = ["MIMOARX"]


def _shift(X, l):
    """X delayed by l samples (zeros before the first)."""
    if l == 0:
        return X
    out = np.zeros_like(X)
    if l < X.shape[0]:
        out[l:] = X[:-l]
    return out


def _compact(spec):
    return str(np.asarray(spec).tolist()).replace(" ", "")


def _entry_polynomials(a, b, c, d, minimal, tol):
    r"""Numerator and denominator (powers of z, highest first) of c(zI - a)⁻¹b + d.

    The numerator is :math:`\det(zI - a + bc) + (d - 1)\det(zI - a)`; its
    leading coefficients are :math:`d` and then, for d = 0, sums of the
    Markov parameters :math:`h_k = ca^{k-1}b`. When d = 0 the coefficients
    of the leading Markov parameters that are zero up to rounding
    (:math:`|h_k| \le \mathrm{tol}\,\|c\|\|b\|\max(1, \|a\|)^{k-1}`,
    tol as the reduction's, default :math:`n^2\varepsilon`) are set to zero,
    so that delays do not leave spurious large zeros.
    """
    if minimal:
        from ..statespace._minreal import minimal_realization

        a, b, c, _ = minimal_realization(a, b, c, tol=tol)
    n = a.shape[0]
    if not n:
        return np.array([d]), np.ones(1)
    den = np.poly(a)
    num = np.poly(a - b @ c) + (d - 1.0) * den
    if d == 0.0:
        num[0] = 0.0
        rel = n * n * np.finfo(float).eps if tol is None else tol
        scale, na, cak = np.linalg.norm(c) * np.linalg.norm(b), max(1.0, np.linalg.norm(a)), c
        for k in range(1, n + 1):
            if abs((cak @ b).item()) > rel * scale * na ** (k - 1):
                break
            num[k] = 0.0
            cak = cak @ a
        num = np.trim_zeros(num, "f")
        num = num if num.size else np.zeros(1)
    return num, den


class MIMOARX(Responses, Presentation):
    r"""ARX model with several outputs and inputs: MATLAB's ``arx`` with order matrices.

    Made by :class:`~adaptid.models.ARX` when an order is a matrix (or when
    a scalar-order ARX is fitted to data with several outputs);
    ``isinstance(model, ARX)`` is True. The model is
    :math:`A(q)y_k = B(q)u_k + e_k` with matrix polynomials in
    :math:`q^{-1}`, :math:`A(q) = I + A_1q^{-1} + \dots + A_{n_a}q^{-n_a}`,
    equation i being

    .. math::

        y^{(i)}_k + \sum_{j}\sum_{l=1}^{n_a[i,j]} a^{(ij)}_l\,y^{(j)}_{k-l}
          = \sum_{j}\sum_{l=0}^{n_b[i,j]-1} b^{(ij)}_l\,u^{(j)}_{k-n_k[i,j]-l} + e^{(i)}_k

    (Ljung 1999, sec. 4.2, eq. 4.55; MATLAB's ``arx``). Each equation is
    a least-squares regression over the common rows k = s … N − 1 of every
    experiment, :math:`s = \max(\max n_a, \max(n_k + n_b - 1))` (inputs
    with nb = 0 do not count): one QR for all outputs when the equations
    share their regressors (equal rows of na, nb, nk), else one QR per
    equation (see :mod:`adaptid.models.mimo._estimate` for the covariance).

    Parameters
    ----------
    na : int or array_like of int, shape (ny, ny)
        ``na[i, j]``: number of lags of output j in the equation of output i.
    nb : int or array_like of int, shape (ny, nu) (or (nu,))
        ``nb[i, j]``: number of coefficients of input j in equation i (0: absent).
    nk : int or array_like of int, shape (ny, nu) (or (nu,))
        Delays (default 1). Scalars and rows broadcast to the full shape
        once the data fix ny and nu.
    dt : float
        Sample time (default 1.0; an IDData gives its own).

    Attributes
    ----------
    theta : ndarray, shape (d,)
        The equations' parameters stacked, equation 1 first; within
        equation i the output lags (output by output, lag 1 first), then
        the input coefficients (input by input).
    names : tuple of str, length d
        ``a{l}_{yi}_{yj}``: coefficient of :math:`y_j(k-l)` in the equation
        of :math:`y_i`; ``b{l}_{yi}_{uj}``: coefficient of
        :math:`u_j(k-n_k[i,j]-l)` (l from 0 as the SISO ``b0``). The data's
        names (IDData ``y_names``/``u_names``) or ``y1, …``, ``u1, …``.
    cov : ndarray, shape (d, d)
        Covariance of θ including the cross-equation blocks from
        ``noise_cov``; its diagonal blocks are the equations' own
        least-squares covariances (:attr:`cov_blocks`).
    noise_cov : ndarray, shape (ny, ny)
        Innovation covariance :math:`\hat\Sigma`.
    residuals : ndarray, shape (n, ny)
        Prediction errors of the fit's rows; ``index`` and ``experiment``
        give each row's sample and experiment.
    na, nb, nk : ndarray
        The order matrices (after fit; the specs as given before).

    Examples
    --------
    >>> import numpy as np
    >>> from adaptid.models import ARX
    >>> rng = np.random.default_rng(0)
    >>> U = rng.standard_normal((500, 2)); Y = np.zeros((500, 2))
    >>> for k in range(1, 500):
    ...     Y[k] = [0.5 * Y[k-1, 0] + U[k-1, 0], 0.2 * Y[k-1, 0] + 0.3 * Y[k-1, 1] + U[k-1, 1]]
    >>> m = ARX(np.ones((2, 2), int), np.eye(2, dtype=int), 1).fit(Y, U)
    >>> isinstance(m, ARX), m.names[:2]
    (True, ('a1_y1_y1', 'a1_y1_y2'))
    >>> bool(np.allclose(m.theta, [-0.5, 0, 1, -0.2, -0.3, 1]))
    True
    """

    _order_names = ("na", "nb", "nk")

    def __init__(self, na, nb, nk=1, *, dt=1.0):
        self._specs = (check_spec(na, "na"), check_spec(nb, "nb"), check_spec(nk, "nk"))
        self.dt = check_scalar(dt, "dt", low=0.0, low_open=True)
        self.theta = None
        self._orders = None

    # -------------------------------------------------------------- orders
    def _order(self, k):
        return self._specs[k] if self._orders is None else getattr(self._orders, "na nb nk".split()[k])

    na = property(lambda self: self._order(0), doc="Order matrix na (ny, ny).")
    nb = property(lambda self: self._order(1), doc="Order matrix nb (ny, nu).")
    nk = property(lambda self: self._order(2), doc="Delay matrix nk (ny, nu).")

    @property
    def n_outputs(self) -> int:
        self._check_fitted()
        return self._orders.ny

    @property
    def n_inputs(self) -> int:
        self._check_fitted()
        return self._orders.nu

    @property
    def n_params(self) -> int:
        self._check_fitted()
        return self.theta.size

    def _check_fitted(self):
        from .._polymodel import NotFittedError

        if self.theta is None:
            raise NotFittedError("this MIMO ARX is not fitted yet: call fit() or "
                                 "fit_recursive() first")

    # ----------------------------------------------------------------- fit
    def _prepare(self, y, u):
        ex = records(y, u)
        named = [y] if not isinstance(y, list) else y
        self._dt_given = any(isinstance(v, IDData) for v in named)
        orders = resolve(*self._specs, ex.p, ex.m)
        Phis, T, index, experiment = stack_rows(list(zip(ex.Y, ex.U)), orders)
        return ex, orders, Phis, T, index, experiment

    def _store(self, fit, ex, orders, index, experiment):
        self._orders = orders
        self.y_names, self.u_names = tuple(ex.y_names), tuple(ex.u_names)
        if self._dt_given:
            self.dt = ex.dt
        self._layout = [layout(orders, i, self.y_names, self.u_names) for i in range(orders.ny)]
        sizes = np.cumsum([0] + [len(c) for c in self._layout])
        self._slices = [slice(int(a), int(b)) for a, b in zip(sizes[:-1], sizes[1:])]
        self.theta = np.concatenate(fit.thetas)
        self.names = tuple(c[3] for cols in self._layout for c in cols)
        self.cov, self.noise_cov, self.residuals = fit.cov, fit.noise_cov, fit.residuals
        self.index, self.experiment = index, experiment
        self._fit_records = ex

    def fit(self, y, u=None):
        r"""Least squares of every equation on the whole record(s).

        Parameters
        ----------
        y : IDData, (Y, U) tuple, list of them (several experiments), or ndarray (N, ny)
            The record; arrays may come as two arguments ``fit(Y, U)``.
            Several experiments are kept apart: every regressor row is
            formed inside one experiment.
        u : array_like, shape (N, nu), optional

        Returns
        -------
        self
        """
        ex, orders, Phis, T, index, experiment = self._prepare(y, u)
        self._store(batch_fit(Phis, T, orders.shared), ex, orders, index, experiment)
        return self

    def fit_recursive(self, y, u=None, estimator=None, **options):
        r"""Fit with the recursive estimators of the core, one compiled run each.

        When the equations share their regressors, one multi-output
        estimator (``n_outputs = ny``, one P for every output) runs over Φ
        and the (n, ny) targets; otherwise one single-output estimator per
        equation. σ̂² and the covariance follow :func:`adaptid.recursive_fit_stats`'
        rule (see :func:`adaptid.models.mimo._estimate.recursive_fit`).

        Parameters
        ----------
        y, u
            As :meth:`fit`.
        estimator : None, str or estimator
            None (RLS) or a method name of :func:`adaptid.estimator` made
            with ``**options`` (e.g. ``"rls", P0="diffuse"``,
            ``"window", window=200``); or, with shared regressors, an
            estimator object with ``n_params = d`` and ``n_outputs = ny``
            (a copy runs; the argument is not modified).
        **options
            Options of :func:`adaptid.estimator`.

        Returns
        -------
        Trajectory or tuple of Trajectory
            One trajectory (theta of shape (n, d, ny)) with shared
            regressors, one per equation otherwise.
        """
        ex, orders, Phis, T, index, experiment = self._prepare(y, u)
        fit, trajs, ests = recursive_fit(Phis, T, orders.shared, estimator, options)
        self._store(fit, ex, orders, index, experiment)
        self.estimator = ests[0] if orders.shared else tuple(ests)
        return trajs[0] if orders.shared else tuple(trajs)

    # ------------------------------------------------------- polynomials
    def _polymats(self, theta=None):
        """(A (La + 1, ny, ny) with A[0] = I, B (Lb, ny, nu)) in powers of q⁻¹."""
        theta = self.theta if theta is None else theta
        o = self._orders
        La = int(o.na.max())
        used = o.nb > 0
        Lb = int((o.nk + o.nb)[used].max()) if used.any() else 1
        A = np.zeros((La + 1, o.ny, o.ny))
        A[0] = np.eye(o.ny)
        B = np.zeros((Lb, o.ny, o.nu))
        for i, cols in enumerate(self._layout):
            th = theta[self._slices[i]]
            for (kind, j, l, _), v in zip(cols, th):
                if kind == "a":
                    A[l, i, j] = v
                else:
                    B[o.nk[i, j] + l, i, j] = v
        return A, B

    @property
    def A(self):
        r"""A(q) as an array (na_max + 1, ny, ny): ``A[l]`` multiplies :math:`q^{-l}`, ``A[0] = I``."""
        self._check_fitted()
        return self._polymats()[0]

    @property
    def B(self):
        r"""B(q) as an array (L, ny, nu): ``B[l]`` multiplies :math:`q^{-l}` (delays as zeros)."""
        self._check_fitted()
        return self._polymats()[1]

    # ------------------------------------------------------------ outputs
    @staticmethod
    def _forcing(B, U):
        F = np.zeros((U.shape[0], B.shape[1]))
        for l in range(B.shape[0]):
            F += _shift(U, l) @ B[l].T
        return F

    def _run(self, A, F, Y0=None, t0=0):
        from ..._kernels.layers._mimoarx import mimo_ar_recursion

        Y = np.zeros_like(F) if Y0 is None else Y0
        mimo_ar_recursion(np.ascontiguousarray(A[1:]), np.ascontiguousarray(F), t0, Y)
        return Y

    def simulate(self, u, y0=None):
        r"""Simulated outputs from the inputs: :math:`y_k = -\sum_l A_ly_{k-l} + \sum_l B_lu_{k-l}`.

        Zero initial conditions (signals zero before sample 0), or the first
        :math:`n_a` outputs taken from ``y0``. The recursion is one compiled
        loop (:mod:`adaptid._kernels.layers._mimoarx`).

        Parameters
        ----------
        u : array_like, shape (N, nu); IDData or (Y, U) (their inputs)
        y0 : array_like, shape (>= max na, ny), optional
            Outputs of the first max(na) samples (e.g. the measured record).

        Returns
        -------
        ndarray, shape (N, ny)
        """
        self._check_fitted()
        U = input_array(u, self._orders.nu)
        A, B = self._polymats()
        F = self._forcing(B, U)
        Y, t0 = np.zeros_like(F), 0
        if y0 is not None:
            L = A.shape[0] - 1
            Y0 = as_float_array(y0, "y0", ndim=(1, 2))
            Y0 = Y0.reshape(Y0.shape[0], -1)
            if Y0.shape[1] != self._orders.ny or Y0.shape[0] < min(L, F.shape[0]):
                raise param_error("y0", f"at least {L} rows of {self._orders.ny} outputs",
                                  f"<shape {Y0.shape}>")
            t0 = min(L, F.shape[0])
            Y[:t0] = Y0[:t0]
        return self._run(A, F, Y, t0)

    def predict(self, data, u=None, k=1):
        r"""k-step-ahead prediction :math:`\hat y_{t|t-k}` of every output.

        With :math:`Z_0 = y` and for h = 1 … k

        .. math::

            Z_h(t) = \sum_l B_lu_{t-l} - \sum_{l\ge1} A_l\,Z_{\max(h-l,0)}(t-l),

        :math:`Z_h(t) = \hat y_{t|t-h}` (the measured outputs up to t − h,
        predictions after; Ljung 1999, sec. 3.2). Signals are zero before
        the first sample; k = 1 is the one-step predictor
        :math:`\varphi_t^T\theta`.

        Parameters
        ----------
        data : IDData, (Y, U) tuple, or ndarray (N, ny) with ``u``
            One experiment.
        u : array_like, shape (N, nu), optional
        k : int
            Horizon >= 1 (default 1).

        Returns
        -------
        ndarray, shape (N, ny)
        """
        self._check_fitted()
        Y, U, ex = one_record(data, u)
        self._check_signals(ex)
        k = check_int(k, "k", low=1)
        A, B = self._polymats()
        F = self._forcing(B, U)
        Z = [Y]
        for h in range(1, k + 1):
            Zh = F.copy()
            for l in range(1, A.shape[0]):
                Zh -= _shift(Z[max(h - l, 0)], l) @ A[l].T
            Z.append(Zh)
        return Z[k]

    def _check_signals(self, ex):
        o = self._orders
        if (ex.p, ex.m) != (o.ny, o.nu):
            raise param_error("data", f"{o.ny} output(s) and {o.nu} input(s) as at fit time",
                              f"<{ex.p} outputs, {ex.m} inputs>")

    # ------------------------------------------------------------ control
    def realization(self, minimal=True, *, tol=None):
        r"""A state-space realisation (F, G, H, D) of :math:`A^{-1}B`: minimal by default.

        ``minimal=False`` gives the lagged-signal form: state
        :math:`x_k = [y_{k-1}; \dots; y_{k-L_a}; u_{k-1}; \dots; u_{k-L_b+1}]`,
        :math:`y_k = Hx_k + Du_k` with :math:`H = [-A_1, \dots, -A_{L_a}, B_1,
        \dots, B_{L_b-1}]`, :math:`D = B_0`, and F shifts the blocks;
        :math:`n_y L_a + n_u(L_b - 1)` states, in general more than needed
        (a decoupled MIMO model, orders that differ between entries, common
        factors of A and B).

        ``minimal=True`` (MATLAB's ``idss``/``ss`` of an ARX model followed
        by ``minreal``) reduces that realisation by orthogonal
        transformations: its controllable part by the controllability
        staircase, then the observable part of that by the dual staircase
        (Van Dooren 1981; Varga 1981; SLICOT TB01PD), see
        :func:`adaptid.models.statespace._minreal.minimal_realization`.
        The result has the Markov parameters of the model and as many
        states as its McMillan degree, up to ``tol``. It is not in a
        canonical form: the states are orthogonal combinations of the
        lagged-signal form's.

        Parameters
        ----------
        minimal : bool
            Reduce to a minimal realisation (default True).
        tol : float, optional
            Relative tolerance of the rank decisions of the reduction
            (default :math:`n^2\varepsilon`, n the lagged-signal form's order,
            which removes exact cancellations only; e.g. ``1e-8`` also
            removes near pole–zero cancellations of an estimated model).

        Returns
        -------
        tuple of ndarray
            F (n, n), G (n, nu), H (ny, n), D (ny, nu).

        References
        ----------
        P. Van Dooren (1981). The generalized eigenstructure problem in linear
        system theory. *IEEE Trans. Automatic Control* 26(1), 111–129.
        A. Varga (1981). Numerically stable algorithm for standard
        controllability form determination. *Electronics Letters* 17(2), 74–75.
        SLICOT Library, routine TB01PD.
        """
        self._check_fitted()
        F, G, H, D = self._lag_realization()
        if not minimal:
            return F, G, H, D
        from ..statespace._minreal import minimal_realization

        return minimal_realization(F, G, H, D, tol=tol)

    def _lag_realization(self):
        A, B = self._polymats()
        ny, nu = self._orders.ny, self._orders.nu
        La, Lb = A.shape[0] - 1, B.shape[0]
        nx = ny * La + nu * (Lb - 1)
        H = np.hstack([-A[l] for l in range(1, La + 1)] + [B[l] for l in range(1, Lb)]
                      + [np.zeros((ny, 0))])
        D = B[0]
        F = np.zeros((nx, nx))
        G = np.zeros((nx, nu))
        if La:
            F[:ny] = H
            G[:ny] = D
            F[ny: ny * La, : ny * (La - 1)] = np.eye(ny * (La - 1))
        if Lb > 1:
            o = ny * La
            G[o: o + nu] = np.eye(nu)
            F[o + nu:, o: o + nu * (Lb - 2)] = np.eye(nu * (Lb - 2))
        return F, G, H, D

    def to_control(self, form="tf", *, minimal=True, tol=None):
        r"""The model :math:`G = A^{-1}B` as a discrete python-control system (dt, names).

        Parameters
        ----------
        form : {"tf", "ss"}
            ``"ss"``: :class:`control.StateSpace` of :meth:`realization`
            (minimal unless ``minimal=False``). ``"tf"``: a MIMO
            :class:`control.TransferFunction`; with ``minimal=True`` entry
            (i, j) comes from the minimal realisation of the single-input
            single-output system :math:`(F, G_{:,j}, H_{i,:}, D_{ij})`,
            reduced again from the minimal realisation of the whole model,
            so that it has no common pole–zero pairs (up to ``tol``); its
            polynomials follow from that realisation (a, b, c, d) by the
            matrix determinant lemma,
            :math:`c(zI - a)^{-1}b = \det(zI - a + bc)/\det(zI - a) - 1`
            (as :func:`scipy.signal.ss2tf`). ``minimal=False`` applies the
            lemma to the lagged-signal form itself: one common denominator
            :math:`\det(zI - F)` of degree :math:`n_yL_a + n_u(L_b - 1)`,
            nothing cancelled.
        minimal : bool
            Start from the minimal realisation (default True).
        tol : float, optional
            Relative tolerance of the reductions (see :meth:`realization`).

        Returns
        -------
        control.TransferFunction or control.StateSpace
        """
        from .._polymodel import _python_control

        check_choice(form, "form", ("tf", "ss"))
        control = _python_control()
        F, G, H, D = self.realization(minimal=minimal, tol=tol)
        io = {"inputs": list(self.u_names), "outputs": list(self.y_names)}
        if form == "ss":
            return control.ss(F, G, H, D, self.dt, **io)
        nums, dens = [], []
        for i in range(H.shape[0]):
            nums.append([]), dens.append([])
            for j in range(G.shape[1]):
                num, den = _entry_polynomials(F, G[:, j:j + 1], H[i:i + 1], D[i, j],
                                              minimal, tol)
                nums[i].append(num), dens[i].append(den)
        return control.tf(nums, dens, self.dt, **io)

    def __repr__(self):
        orders = ", ".join(f"{n}={_compact(getattr(self, n))}" for n in self._order_names)
        state = "fitted" if self.theta is not None else "not fitted"
        return f"ARX({orders}, dt={self.dt:g}) [{state}, MIMO]"
