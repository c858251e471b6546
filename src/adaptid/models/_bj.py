r"""The Box–Jenkins model :math:`y_k = \frac{B(q)}{F(q)}u_k + \frac{C(q)}{D(q)}e_k`."""

from __future__ import annotations

import numpy as np

from .._lazy import lazy
from .._validation import as_float_array, check_int
from ._builders import _per_input
from ._pem import _PseudoLinearModel, stabilize
from ._polymodel import _poly_sub, check_orders

signal = lazy("scipy.signal")

__all__ = ["BJ"]


def _lf(num, den, X, row_bounds=None):
    """Filter the columns of X (none: an empty (N, 0) array)."""
    from ._segments import lfilter_segments

    return lfilter_segments(num, den, X, row_bounds) if X.shape[1] else X


class BJ(_PseudoLinearModel):
    r"""Box–Jenkins model: independently parametrised plant and noise.

    .. math::

        y_k = \frac{B(q)}{F(q)}u_k + \frac{C(q)}{D(q)}e_k,\qquad
        \theta = [b_0..b_{n_b-1},\ c_1..c_{n_c},\ d_1..d_{n_d},\ f_1..f_{n_f}]

    (MATLAB's ``bj`` parameter order), with
    :math:`B(q) = q^{-n_k}(b_0 + \dots + b_{n_b-1}q^{-n_b+1})` and monic C, D,
    F. With the noise-free output :math:`w = B/F\,u`, the noise
    :math:`v = y - w` and the prediction error
    :math:`\varepsilon = D/C\,v`, the one-step predictor is pseudo-linear,
    :math:`\hat y_k = \varphi_k^T\theta` with

    .. math::

        \varphi_k = [u_{k-n_k}, \dots, u_{k-n_k-n_b+1},\
                     \varepsilon_{k-1}, \dots, \varepsilon_{k-n_c},\
                     -v_{k-1}, \dots, -v_{k-n_d},\
                     -w_{k-1}, \dots, -w_{k-n_f}]

    (Ljung 1999, eq. 4.44 and sec. 10.3):

    * :meth:`fit_recursive` — recursive pseudo-linear regression on these
      signals, each formed a posteriori from the current estimate (MATLAB's
      ``recursiveBJ``; Ljung 1999, sec. 11.3), one compiled pass with any
      core estimator (RLS with any forgetting strategy, SlidingWindowRLS,
      KalmanRLS);
    * :meth:`fit` — prediction-error minimisation of
      :math:`\sum_k\varepsilon_k^2(\theta)` (:func:`scipy.optimize.least_squares`,
      analytic gradient), started from B, F of the Steiglitz–McBride output-error
      estimate (:class:`OE`, refined) and C, D of the Hannan–Rissanen ARMA fit of its
      residual v. PEM is consistent (and for Gaussian e asymptotically
      efficient) where ARX, and ARMAX with its shared denominator, are biased.

    Roots of C, D and F outside the unit circle are reflected inside. The
    rows are the samples k = s … N-1, :math:`s = \max_i(n_{k,i} + n_{b,i}) - 1`, with the
    signals zero before the first row; ``cov`` is the asymptotic
    prediction-error covariance :math:`\hat\sigma^2(\Psi^T\Psi)^{-1}`
    (Ljung 1999, eq. 9.17).

    Several inputs (as :class:`OE`): :math:`y = \sum_i B_i/F_i\,u^{(i)} + C/D\,e`,
    θ = [b⁽¹⁾ … b⁽ᵐ⁾, c, d, f⁽¹⁾ … f⁽ᵐ⁾], one simulated output
    :math:`w^{(i)}` per input in the regressor, w their sum.

    Parameters
    ----------
    nb : int or sequence of int
        Number of B coefficients (per input), ``>= 1``.
    nc, nd : int
        Orders of C and D, ``>= 0``.
    nf : int or sequence of int
        Order of F (per input), ``>= 0``.
    nk : int or sequence of int
        Input delay (per input), ``>= 0`` (default 1).
    dt : float
        Sample time (default 1.0).

    References
    ----------
    .. [1] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
       Prentice Hall, 1999.
    .. [2] G. E. P. Box, G. M. Jenkins, *Time Series Analysis: Forecasting
       and Control*, Holden-Day, 1970.
    .. [3] K. Steiglitz, L. E. McBride, "A technique for the identification
       of linear systems", *IEEE Trans. Automatic Control* 10(4), 1965.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import lfilter
    >>> from adaptid.models import BJ
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal(4000); e = 0.3 * rng.standard_normal(4000)
    >>> y = lfilter([0, 1.0, 0.5], [1, -0.7], u) + lfilter([1, 0.4], [1, -0.9], e)
    >>> m = BJ(2, 1, 1, 1).fit(y, u)
    >>> m.names
    ('b0', 'b1', 'c1', 'd1', 'f1')
    >>> bool(np.allclose(m.theta, [1.0, 0.5, 0.4, -0.9, -0.7], atol=0.05))
    True
    """

    _order_names = ("nb", "nc", "nd", "nf", "nk")

    def __init__(self, nb, nc, nd, nf, nk=1, *, dt=1.0):
        check_orders(nb, "nb", low=1)
        check_orders(nf, "nf", low=0)
        self._init_orders(0, nb, nc, 0, nk, dt)
        self.nd = check_int(nd, "nd", low=0)
        self.nf = nf
        self._nf_spec = nf

    def _set_inputs(self, m, single):
        super()._set_inputs(m, single)
        self._nf = _per_input(self._nf_spec, "nf", m, low=0)
        self._nd = self.nc + self.nd + sum(self._nf)

    # ------------------------------------------------------------ layout
    def _parts(self, theta):
        """θ → ([b_i], c, d, [f_i]) (MATLAB's order: all B, C, D, all F)."""
        bs, o = [], 0
        for nb in self._nb:
            bs.append(theta[o: o + nb])
            o += nb
        c = theta[o: o + self.nc]
        o += self.nc
        d = theta[o: o + self.nd]
        o += self.nd
        fs = []
        for nf in self._nf:
            fs.append(theta[o: o + nf])
            o += nf
        return bs, c, d, fs

    def _split(self, theta):
        bs, c, _, fs = self._parts(theta)
        return np.zeros(0), bs, c, fs

    def _names(self):
        names = []
        for i, nb in enumerate(self._nb):
            names += [f"b{j}" if self._single else f"b{i}_{j}" for j in range(nb)]
        names += [f"c{j}" for j in range(1, self.nc + 1)]
        names += [f"d{j}" for j in range(1, self.nd + 1)]
        for i, nf in enumerate(self._nf):
            names += [f"f{j}" if self._single else f"f{i}_{j}" for j in range(1, nf + 1)]
        return tuple(names)

    @property
    def D(self):
        """D polynomial (noise denominator), shape (nd + 1,)."""
        self._check_fitted()
        return np.concatenate([[1.0], self._parts(self.theta)[2]])

    def _signal_spec(self, nfix):
        # signals: g < m: w_g (input g's simulated output), m: v = y − Σ w, m+1: ε
        m, nc, nd = self._m, self.nc, self.nd
        nbs, nfs = sum(self._nb), sum(self._nf)
        n = nbs + nc + nd + nfs
        owner = np.r_[np.concatenate([np.full(b, i) for i, b in enumerate(self._nb)]),
                      np.full(nc + nd, -1),
                      np.concatenate([np.full(f, i) for i, f in enumerate(self._nf)]
                                     + [np.zeros(0)])].astype(np.int64)
        mix = np.zeros((m + 2, n))
        for i in range(m):
            mix[i, owner == i] = 1.0
        mix[m, owner >= 0] = -1.0
        mix[m + 1, :] = -1.0
        alpha = np.r_[np.zeros(m), 1.0, 1.0]
        dyn_group = np.r_[np.full(nc, m + 1), np.full(nd, m),
                          np.concatenate([np.full(f, i) for i, f in enumerate(self._nf)]
                                         + [np.zeros(0)])].astype(np.int64)
        dyn_lag = np.r_[np.arange(1, nc + 1), np.arange(1, nd + 1),
                        np.concatenate([np.arange(1, f + 1) for f in self._nf]
                                       + [np.zeros(0)])].astype(np.int64)
        dyn_sgn = np.r_[np.ones(nc), -np.ones(nd + nfs)]
        return alpha, mix, dyn_group, dyn_lag, dyn_sgn

    # ------------------------------------------------- prediction errors
    def _errors(self, theta, Phi_fix, Y):
        r"""ε = D/C (y − Σ B_i/F_i u_i) and ψ = −∂ε/∂θ (Ljung 1999, eq. 10.54)."""
        bs, c, d, fs = self._parts(np.asarray(theta, dtype=np.float64))
        C = np.concatenate([[1.0], c])
        D = np.concatenate([[1.0], d])
        rb = getattr(self, "_row_bounds", None)
        ws, psi_b, psi_f, o = [], [], [], 0
        for b, f in zip(bs, fs):
            F = np.concatenate([[1.0], f])
            cols = Phi_fix[:, o: o + b.size]
            o += b.size
            w = self._filt(F, cols @ b)
            ws.append(w)
            CF = np.convolve(C, F)
            psi_b.append(_lf(D, CF, cols, rb))
            psi_f.append(-_lf(D, CF, self._lag(w, f.size), rb))
        v = Y - np.sum(ws, axis=0)
        eps = self._filt(C, v, num=D)
        psi_c = _lf([1.0], C, self._lag(eps, self.nc), rb)
        psi_d = -_lf([1.0], C, self._lag(v, self.nd), rb)
        return eps, np.hstack(psi_b + [psi_c, psi_d] + psi_f)

    def _refine(self, theta, Phi_fix, Y, max_nfev=None):
        # a trial step may put a root of C or F outside the unit circle: the
        # filtered errors then overflow, least_squares rejects the step (an
        # inf cost) and shrinks its trust region; that is not worth a warning
        with np.errstate(over="ignore", invalid="ignore"):
            return super()._refine(theta, Phi_fix, Y, max_nfev=max_nfev)

    def _stable(self, theta):
        theta = np.array(theta, dtype=np.float64)
        o = sum(self._nb)
        for k in [self.nc, self.nd] + list(self._nf):
            theta[o: o + k] = stabilize(np.concatenate([[1.0], theta[o: o + k]]))[1:]
            o += k
        return theta

    # ------------------------------------------------------------- fit
    def fit(self, y, u=None, *, refine=True, n_iter=30, arx_order=None, max_nfev=None,
            nan_policy="omit"):
        r"""Batch fit: Steiglitz–McBride + Hannan–Rissanen start, prediction-error minimisation.

        1. B, F: :meth:`OE.fit` (Steiglitz–McBride iterations, least squares
           on y and u prefiltered by :math:`1/\hat F`, then its output-error
           minimisation, which unlike Steiglitz–McBride stays consistent
           for coloured noise);
        2. C, D: :meth:`ARMA.fit` of :math:`\hat v = y - \hat B/\hat F\,u`
           (Hannan–Rissanen, no refinement);
        3. with ``refine=True`` (default): minimise
           :math:`\sum_k\varepsilon_k^2(\theta)`,
           :math:`\varepsilon = \frac{D}{C}\big(y - \frac{B}{F}u\big)`, by
           :func:`scipy.optimize.least_squares` with the analytic gradient
           :math:`\psi_b = \frac{D}{CF}u_{k-n_k-j}`,
           :math:`\psi_c = \varepsilon_{k-j}/C`,
           :math:`\psi_d = -v_{k-j}/C`,
           :math:`\psi_f = -\frac{D}{CF}w_{k-j}` (Ljung 1999, sec. 10.3).

        Parameters
        ----------
        y : array_like, shape (N,) or (N, 1); pandas; IDData; or a (y, u) tuple
            Output, or the whole record (``u`` then omitted): an IDData, a
            ``(y, u)`` tuple, or a DataFrame with the output column first
            and the inputs after it (the one input convention, see
            :meth:`ARX.fit`).
        u : array_like, shape (N,) or (N, m); pandas; optional
        refine : bool
            Run step 3 (default True); False keeps the start estimate.
        n_iter : int
            Steiglitz–McBride iterations at most (default 30).
        arx_order : int, optional
            Long AR order of the Hannan–Rissanen step.
        max_nfev : int, optional
            Function evaluations of the minimisation at most.
        nan_policy : {"omit", "raise"}
            ``"omit"`` (default): NaN samples are gaps: the record is split at each run of NaN into separate experiments (the filters restart after each gap)
            (``n_dropped`` counts the rows lost, and ``summary()`` reports
            it). ``"raise"``: a NaN in y or u is refused (ValueError naming
            the signal).

        Returns
        -------
        self
        """
        from ._ar import ARMA
        from ._oe import OE
        from ._segments import check_nan_policy, segment_record

        self._nan_policy = check_nan_policy(nan_policy)
        y, U = self._data(y, u, fitting=True)
        reg, Phi_fix = self._fixed_regression(y, U, self._single)
        # the start estimates on the experiments and runs between gaps, kept apart
        rec = segment_record(y, U, self._fit_pieces)
        with np.errstate(over="ignore", invalid="ignore"):  # rejected trial steps, see _refine
            oe = OE(self._nb_spec, self._nf_spec, self._nk_spec).fit(rec, n_iter=n_iter,
                                                                     refine=True)
        nbs = sum(self._nb)
        c, d = np.zeros(self.nc), np.zeros(self.nd)
        if self.nc + self.nd:
            w = np.full(y.size, np.nan)          # the OE simulation, restarted in each piece
            for a, b in self._fit_pieces:
                w[a:b] = oe.simulate(U[a:b])
            vrec = segment_record(y - w, np.zeros((y.size, 0)), self._fit_pieces)
            if self.nd:
                arma = ARMA(self.nd, self.nc).fit(vrec, refine=False, arx_order=arx_order)
                d, c = arma.theta[: self.nd], arma.theta[self.nd:]
            else:  # MA noise: Hannan-Rissanen of an ARMA(1, nc), keeping its C
                arma = ARMA(1, self.nc).fit(vrec, refine=False, arx_order=arx_order)
                c = arma.theta[1:]
        theta = self._stable(np.r_[oe.theta[:nbs], c, d, oe.theta[nbs:]])
        if refine:
            theta = self._refine(theta, Phi_fix, reg.y, max_nfev=max_nfev)
        self._finish(theta, Phi_fix, reg.y, reg)
        return self

    # ------------------------------------------------------ prediction
    def predict(self, y, u, k=1):
        r"""k-step-ahead prediction with the noise model H = C/D.

        .. math::

            \hat y_{t|t-k} = \frac{\bar H_k D B}{C F}u_t + \frac{C - \bar H_k D}{C}\,y_t,

        :math:`\bar H_k` the impulse response of C/D truncated to k terms
        (Ljung 1999, eq. 3.31); signals zero before the first sample.

        Parameters
        ----------
        y : array_like, shape (N,)
        u : array_like, shape (N,) or (N, m)
        k : int
            Horizon, ``>= 1`` (default 1).

        Returns
        -------
        ndarray, shape (N,)
        """
        y, U, bounds = self._record_signals(y, u)
        k = check_int(k, "k", low=1)
        return self._by_runs(lambda yy, UU: self._predict_arrays(yy, UU, k), bounds, y, U)

    def _predict_arrays(self, y, U, k):
        _, Bs, C, Fs = self._polys()
        D = self.D
        HD = np.convolve(self._hbar(k, D, C), D)
        out = signal.lfilter(_poly_sub(C, HD), C, y)
        for i in range(self._m):
            out = out + signal.lfilter(np.convolve(HD, Bs[i]), np.convolve(C, Fs[i]), U[:, i])
        return out

    def simulate(self, u, *, noise=None):
        r"""Simulated output :math:`B/F\,u` (plus :math:`C/D\,e` when ``noise`` = e is given).

        Parameters
        ----------
        u : array_like, shape (N,) or (N, m)
        noise : array_like, shape (N,), optional

        Returns
        -------
        ndarray, shape (N,)
        """
        U, bounds = self._inputs_bounds(u)
        if noise is not None:
            e = as_float_array(noise, "noise", shape=(U.shape[0],))
            return self._by_runs(self._simulate_arrays, bounds, U, e)
        return self._by_runs(self._simulate_arrays, bounds, U)

    def _simulate_arrays(self, U, e=None):
        _, Bs, C, Fs = self._polys()
        out = np.zeros(U.shape[0])
        for i in range(self._m):
            out += signal.lfilter(Bs[i], Fs[i], U[:, i])
        if e is not None:
            out = out + signal.lfilter(C, self.D, e)
        return out
