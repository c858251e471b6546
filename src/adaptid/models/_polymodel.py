r"""Shared machinery of the polynomial input–output models (ARX, ARMAX, OE).

All three are special cases of

.. math::

    A(q)\,y_k = \sum_{i} \frac{B_i(q)}{F_i(q)}\,u^{(i)}_k + C(q)\,e_k,

with monic polynomials in the backward shift :math:`q^{-1}`
(:math:`A = 1 + a_1q^{-1} + \dots + a_{n_a}q^{-n_a}`, the same for C and F)
and :math:`B_i(q) = q^{-n_k}(b_0 + b_1q^{-1} + \dots + b_{n_b-1}q^{-n_b+1})`.
Predictions and simulations are linear filters evaluated with
:func:`scipy.signal.lfilter` (zero initial conditions: signals are taken as
zero before the first sample).
"""

from __future__ import annotations

import numpy as np

from .._lazy import lazy
from ..estimators import Trajectory
from .._validation import as_float_array, check_choice, check_int, check_scalar, param_error
from ._builders import _as_inputs, _per_input, arx_regressors
from ._polyfreq import FrequencyMethods

signal = lazy("scipy.signal")

__all__ = ["_PolyModel"]



def _python_control():
    """python-control, or an ImportError naming the extra that installs it."""
    try:
        import control
    except ImportError as err:  # pragma: no cover - depends on the extra
        raise ImportError("to_control needs python-control: pip install 'adaptid[control]'") from err
    return control

class NotFittedError(RuntimeError):
    """Raised when a model is used before ``fit``."""


def check_orders(value, name, *, low):
    """Validate an order given as one integer or one per input (count checked at fit)."""
    if np.ndim(value) == 0:
        check_int(value, name, low=low)
    else:
        for i, v in enumerate(np.ravel(value)):
            check_int(v, f"{name}[{i}]", low=low)


def _pad_to(p, L):
    out = np.zeros(L)
    out[: p.size] = p
    return out


def _poly_sub(a, b):
    L = max(a.size, b.size)
    return _pad_to(a, L) - _pad_to(b, L)


class _PolyModel(FrequencyMethods):
    """Common base; see :class:`ARX`, :class:`ARMAX`, :class:`OE`."""

    _structure = "poly"
    #: False for time-series models (AR, ARMA): ``u`` may then be None (m = 0 inputs)
    _needs_input = True

    def _init_orders(self, na, nb, nc, nf, nk, dt):
        self.na = check_int(na, "na", low=0)
        self.nc = check_int(nc, "nc", low=0)
        self.nf = check_int(nf, "nf", low=0)
        self._nb_spec, self._nk_spec = nb, nk
        self.nb, self.nk = nb, nk
        # validate the scalar / per-input specs now (number of inputs known at fit)
        check_orders(nb, "nb", low=0)
        check_orders(nk, "nk", low=0)
        self.dt = check_scalar(dt, "dt", low=0.0, low_open=True)
        self.theta = None

    # ------------------------------------------------------------ structure
    @property
    def n_params(self):
        """Number of estimated parameters d (known once the number of inputs is)."""
        self._check_fitted()
        return self.theta.size

    def _set_inputs(self, m, single):
        self._m, self._single = m, single
        self._nb = _per_input(self._nb_spec, "nb", m, low=0)
        self._nk = _per_input(self._nk_spec, "nk", m, low=0)

    def _data(self, y, u, *, fitting=False):
        """Validate (y, u) or an IDData; at fit time fix the number of inputs and the names."""
        return self._record_signals(y, u, fitting=fitting)[:2]

    def _record_signals(self, y, u, *, fitting=False):
        """(y (N,), U (N, m), experiment bounds (E + 1,)) of a record; NaN (gaps) allowed.

        At fit time the number of inputs, the names, ``dt`` and the
        experiment bounds (:mod:`._segments`) are fixed; ``nan_policy="raise"``
        refuses a NaN there.
        """
        from ._iddata import as_signals
        from ._segments import record_bounds, refuse_nan

        y, u, data = as_signals(y, u)
        if u is None and self._needs_input:
            raise param_error("u", "an input signal (or an IDData with inputs)", None,
                              exc=TypeError)
        y = as_float_array(y, "y", ndim=1, allow_nan=True)
        if u is None:
            U, single = np.zeros((y.shape[0], 0)), True
        else:
            U, single = _as_inputs(u, y.shape[0])
        bounds = record_bounds(data, y.shape[0])
        if fitting:
            if getattr(self, "_nan_policy", "omit") == "raise":
                refuse_nan((y, U), ("y", "u"))
            self._fit_bounds = bounds
            self._fit_pieces = None
            self._set_inputs(U.shape[1], single)
            if data is not None:
                self.y_name, self.u_names = data.y_names[0], data.u_names
                self.dt = data.dt
            else:
                self.y_name = "y"
                self.u_names = (() if U.shape[1] == 0 else ("u",) if single
                                else tuple(f"u{i + 1}" for i in range(U.shape[1])))
            self._fit_signals = (y, U)
            self._fit_data = data
        else:
            self._check_fitted()
            if U.shape[1] != self._m:
                raise param_error("u", f"with {self._m} input column(s) as at fit time",
                                  f"<{U.shape[1]} columns>")
        return y, U, bounds

    def _inputs(self, u):
        return self._inputs_bounds(u)[0]

    def _inputs_bounds(self, u):
        """(U (N, m), experiment bounds) of an input record (an IDData gives its inputs)."""
        self._check_fitted()
        from ._iddata import IDData
        from ._segments import record_bounds

        data = u if isinstance(u, IDData) else None
        if data is not None:
            u = u.inputs
        arr = as_float_array(getattr(u, "to_numpy", lambda: u)(), "u", ndim=(1, 2),
                             allow_nan=True)
        U = arr.reshape(-1, 1) if arr.ndim == 1 else arr
        if U.shape[1] != self._m:
            raise param_error("u", f"with {self._m} input column(s) as at fit time",
                              f"<{U.shape[1]} columns>")
        return U, record_bounds(data, U.shape[0])

    def _check_fitted(self):
        if self.theta is None:
            raise NotFittedError(f"this {type(self).__name__} is not fitted yet: call fit() "
                                 "or fit_recursive() first")

    #: True for the filter-based models: rows are formed on the runs of complete
    #: samples (each gap splits the record); False: rows touching a NaN are left out
    _splits_at_gaps = False

    def _fixed_regression(self, y, U, single):
        """ARX part of the regressors (signs: −y lags, +u lags), rows k = s … N-1.

        Formed inside each experiment of the fit (or each run of complete
        samples, for a model that splits at gaps) and stacked; ``reg.index``
        holds the rows' sample positions in (y, U), ``meta["row_bounds"]``
        the first row of each piece (also kept as ``_row_bounds`` for the
        filters of the prediction errors), ``meta["n_dropped"]`` the rows
        left out for touching a NaN.
        """
        import dataclasses

        if self.na + sum(self._nb) == 0:
            raise param_error("na + sum(nb)", ">= 1 for this model", 0)
        N = y.shape[0]
        bounds = getattr(self, "_fit_bounds", None)
        if bounds is None or bounds[-1] != N:
            bounds = np.array([0, N])
        pieces = getattr(self, "_fit_pieces", None) if self._splits_at_gaps else None
        if pieces is None or pieces[-1][1] > N:     # (kept: instrument rows on the same runs)
            pieces = self._pieces(y, U, bounds)
        self._fit_pieces = pieces
        Us = [U[a:b, 0] if single else U[a:b] for a, b in pieces]
        if len(pieces) == 1 and pieces[0] == (0, N):
            reg = arx_regressors(y, Us[0], self.na, self._nb, self._nk, nan_policy="omit")
            reg.meta["seg_index"] = reg.index
        else:
            reg = arx_regressors([y[a:b] for a, b in pieces], Us, self.na, self._nb, self._nk,
                                 nan_policy="omit")
            start = reg.meta["start"]
            pos = np.concatenate([np.arange(a, b) for a, b in pieces])
            possible = sum(max(b - a - start, 0) for a, b in zip(bounds[:-1], bounds[1:]))
            reg = dataclasses.replace(reg, index=pos[reg.index], meta=dict(
                reg.meta, n_dropped=int(possible - reg.Phi.shape[0]), sample_pos=pos,
                seg_index=reg.index))
        self._row_bounds = reg.meta["row_bounds"]
        self.n_dropped = reg.meta["n_dropped"]
        self.n_experiments = len(bounds) - 1
        Phi = reg.Phi.copy()
        Phi[:, : self.na] *= -1.0
        return reg, Phi

    def _pieces(self, y, U, bounds):
        """The (start, stop) sample ranges inside which rows are formed."""
        if not self._splits_at_gaps:
            return [(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])]
        from ._segments import complete_runs

        runs = complete_runs(~(np.isnan(y) | np.isnan(U).any(axis=1)), bounds)
        if not runs:
            raise param_error("y", "a record with complete samples", "<only NaN>")
        return runs

    # ------------------------------------------------------ parameter layout
    def _split(self, theta):
        """θ → (a, [b_i], c, f) with a, c, f excluding the leading 1."""
        raise NotImplementedError

    def _polys(self, theta=None):
        theta = self.theta if theta is None else theta
        a, bs, c, fs = self._split(theta)
        A = np.concatenate([[1.0], a])
        Bs = [np.concatenate([np.zeros(k), b]) if b.size else np.zeros(max(k, 1))
              for b, k in zip(bs, self._nk)]
        C = np.concatenate([[1.0], c])
        Fs = [np.concatenate([[1.0], f]) for f in fs]
        return A, Bs, C, Fs

    @property
    def A(self):
        r"""A polynomial, shape (na + 1,): ``[1, a1, …, a_na]`` (powers of :math:`q^{-1}`)."""
        self._check_fitted()
        return self._polys()[0]

    @property
    def B(self):
        r"""B polynomial(s) with ``nk`` leading zeros: shape (nk + nb,), or (m, L) zero-padded for m inputs."""
        self._check_fitted()
        Bs = self._polys()[1]
        if self._single:
            return Bs[0]
        L = max(b.size for b in Bs)
        return np.vstack([_pad_to(b, L) for b in Bs])

    @property
    def C(self):
        """C polynomial, shape (nc + 1,) (``[1.]`` for ARX and OE)."""
        self._check_fitted()
        return self._polys()[2]

    @property
    def F(self):
        """F polynomial(s), shape (nf + 1,) or (m, nf + 1) (``[1.]`` for ARX and ARMAX)."""
        self._check_fitted()
        Fs = self._polys()[3]
        if self._single:
            return Fs[0]
        L = max(f.size for f in Fs)
        return np.vstack([_pad_to(f, L) for f in Fs])

    # --------------------------------------------------------- statistics
    @property
    def stderr(self):
        """Standard errors √diag(cov), shape (d,)."""
        self._check_fitted()
        return np.sqrt(np.diag(self.cov))

    @property
    def loss(self):
        r"""Loss function :math:`V = \frac1N\sum_k\varepsilon_k^2` of the fit's prediction errors."""
        self._check_fitted()
        r = self.residuals
        return float(r @ r / r.size)

    @property
    def aic(self):
        r"""Akaike's information criterion of the fit (Gaussian likelihood).

        .. math::

            \mathrm{AIC} = N\log V + 2d + N(\log 2\pi + 1) = -2\log L(\hat\theta,\hat\sigma^2) + 2d,

        with N the number of prediction errors, d the number of parameters
        and :math:`V` the :attr:`loss` (the ML estimate of the noise
        variance). This is MATLAB's "raw" ``aic`` and statsmodels' OLS
        ``aic`` (which counts the regression coefficients only).
        """
        N, d, V = self.residuals.size, self.n_params, self.loss
        return float(N * np.log(V) + 2 * d + N * (np.log(2 * np.pi) + 1.0))

    @property
    def fpe(self):
        r"""Akaike's final prediction error :math:`V\,(1 + d/N)/(1 - d/N)` (Ljung 1999, eq. 16.31)."""
        N, d, V = self.residuals.size, self.n_params, self.loss
        if N <= d:
            return float("inf")
        return float(V * (1 + d / N) / (1 - d / N))

    def _set_cov_from_gradient(self, Psi, eps):
        """cov = σ̂² (ΨᵀΨ)⁻¹ by QR (asymptotic PEM covariance, Ljung 1999, eq. 9.17)."""
        from .._lstsq import lstsq

        N, d = Psi.shape
        res = lstsq(Psi, eps)
        sigma2 = float(eps @ eps) / max(N - d, 1)
        self.noise_variance = sigma2
        self.cov = sigma2 * res.unscaled_cov

    # --------------------------------------------------------- prediction
    def _hbar(self, k, A, C):
        """First k impulse-response coefficients of the noise model H = C / A."""
        imp = np.zeros(k)
        imp[0] = 1.0
        return signal.lfilter(C, A, imp)

    def predict(self, y, u=None, k=1):
        r"""k-step-ahead prediction :math:`\hat y_{t|t-k}` of the output.

        With :math:`G_i = B_i/(A F_i)`, the noise model :math:`H = C/A` and
        :math:`\bar H_k` its impulse response truncated to k terms
        (Ljung 1999, eq. 3.31):

        .. math::

            \hat y_{t|t-k} = \bar H_k H^{-1}\sum_i G_i u^{(i)}_t
                + (1 - \bar H_k H^{-1})\,y_t
            = \sum_i\frac{\bar H_k B_i}{C F_i}u^{(i)}_t + \frac{C - \bar H_k A}{C}\,y_t .

        k = 1 is the one-step predictor; for OE (H = 1) every k gives the
        simulation. Signals are taken as zero before the first sample, and
        before the first sample of each experiment of a merged IDData and
        after each NaN gap (whose samples are NaN in the result).

        Parameters
        ----------
        y : array_like, shape (N,); or IDData
            Output (or the whole record, ``u`` then omitted).
        u : array_like, shape (N,) or (N, m)
        k : int
            Prediction horizon, ``>= 1`` (default 1).

        Returns
        -------
        ndarray, shape (N,)
        """
        y, U, bounds = self._record_signals(y, u)
        k = check_int(k, "k", low=1)
        return self._by_runs(lambda yy, UU: self._predict_arrays(yy, UU, k), bounds, y, U)

    def _by_runs(self, fn, bounds, *arrays):
        """``fn`` on each run of complete samples inside each experiment (NaN elsewhere)."""
        from ._segments import complete_runs, per_segment

        N = arrays[0].shape[0]
        ok = np.ones(N, dtype=bool)
        for a in arrays:
            ok &= ~np.isnan(a.reshape(N, -1)).any(axis=1)
        if ok.all() and len(bounds) == 2:
            return fn(*arrays)
        return per_segment(fn, complete_runs(ok, bounds), N, *arrays)

    def _predict_arrays(self, y, U, k):
        """k-step prediction of one experiment without gaps (see :meth:`predict`)."""
        A, Bs, C, Fs = self._polys()
        Hk = self._hbar(k, A, C)
        out = signal.lfilter(_poly_sub(C, np.convolve(Hk, A)), C, y)
        for i in range(self._m):
            out = out + signal.lfilter(np.convolve(Hk, Bs[i]), np.convolve(C, Fs[i]), U[:, i])
        return out

    def simulate(self, u, *, noise=None):
        r"""Simulated output from the input alone (zero initial conditions).

        .. math::

            y_t = \sum_i \frac{B_i(q)}{A(q)F_i(q)}u^{(i)}_t + \frac{C(q)}{A(q)}e_t,

        the noise term only when ``noise`` (the sequence e) is given.

        Parameters
        ----------
        u : array_like, shape (N,) or (N, m); or IDData (its inputs)
        noise : array_like, shape (N,), optional

        Returns
        -------
        ndarray, shape (N,)
            For a merged IDData (or inputs with NaN gaps) the simulation
            restarts from zero at each experiment and after each gap; the
            samples of a gap are NaN.
        """
        U, bounds = self._inputs_bounds(u)
        if noise is not None:
            e = as_float_array(noise, "noise", shape=(U.shape[0],))
            return self._by_runs(self._simulate_arrays, bounds, U, e)
        return self._by_runs(self._simulate_arrays, bounds, U)

    def _simulate_arrays(self, U, e=None):
        A, Bs, C, Fs = self._polys()
        out = np.zeros(U.shape[0])
        for i in range(self._m):
            out += signal.lfilter(Bs[i], np.convolve(A, Fs[i]), U[:, i])
        if e is not None:
            out += signal.lfilter(C, A, e)
        return out

    def fit_percent(self, y, u=None, *, k=None):
        r"""Normalised fit (NRMSE, percent) of the simulation or the k-step prediction.

        ``k=None`` (default) compares ``y`` with :meth:`simulate`, an
        integer with :meth:`predict` at that horizon;
        see :func:`adaptid.diagnostics.fit_percent`.
        """
        from .._teststats import fit_percent

        y, U, bounds = self._record_signals(y, u)
        if k is None:
            y_hat = self._by_runs(self._simulate_arrays, bounds, U)
        else:
            k = check_int(k, "k", low=1)
            y_hat = self._by_runs(lambda yy, UU: self._predict_arrays(yy, UU, k), bounds, y, U)
        ok = np.isfinite(y) & np.isfinite(y_hat)     # gaps left out
        y, y_hat = y[ok], y_hat[ok]
        if not np.ptp(y) > 0:
            raise param_error("y", "not constant (the fit is relative to its variation)",
                              "<a constant signal>")
        return fit_percent(y, y_hat)

    # ------------------------------------------------------------ summary
    def summary(self, *, alpha=0.05, max_lag=25):
        r"""The fit's summary table (parameters, information criteria, fit %, residual tests).

        Computed on the estimation data by :func:`adaptid.models.model_summary`
        (which see for every number's definition).

        Parameters
        ----------
        alpha : float
            Level of the confidence limits and of the residual tests (default 0.05).
        max_lag : int
            Largest lag of the Ljung–Box and cross-correlation tests (default 25).

        Returns
        -------
        adaptid._summary.Summary
        """
        from ._summary import model_summary

        return model_summary(self, alpha=alpha, max_lag=max_lag)

    # ------------------------------------------------------------ control
    def to_control(self, form="tf"):
        r"""The input–output model :math:`G_i = B_i/(A F_i)` as a python-control system.

        Parameters
        ----------
        form : {"tf", "ss"}
            ``"tf"``: a discrete :class:`control.TransferFunction` (one input
            per column; the polynomials in :math:`q^{-1}` are padded to a
            common length and read as polynomials in z). ``"ss"``: a discrete
            :class:`control.StateSpace` (for several inputs, the parallel
            connection of each input's controllable realisation, not
            necessarily minimal).

        Returns
        -------
        control.TransferFunction or control.StateSpace
            With ``dt`` equal to the model's sample time and the input and
            output names of the data it was fitted to.

        Raises
        ------
        ImportError
            If python-control is not installed (``pip install 'adaptid[control]'``).
        """
        check_choice(form, "form", ("tf", "ss"))
        self._check_fitted()
        control = _python_control()
        A, Bs, C, Fs = self._polys()
        nums, dens = [], []
        for i in range(self._m):
            den = np.convolve(A, Fs[i])
            L = max(den.size, Bs[i].size)
            nums.append(_pad_to(Bs[i], L))
            dens.append(_pad_to(den, L))
        io = {"inputs": list(getattr(self, "u_names", ())) or None,
              "outputs": [getattr(self, "y_name", "y")]}
        if form == "tf":
            if self._m == 1:
                return control.tf(nums[0], dens[0], self.dt, **io)
            return control.tf([nums], [dens], self.dt, **io)
        blocks = [signal.tf2ss(np.trim_zeros(nb_, "f") if np.any(nb_) else np.zeros(1), db_)
                  for nb_, db_ in zip(nums, dens)]
        from scipy.linalg import block_diag

        Ass = block_diag(*[b[0] for b in blocks]) if blocks else np.zeros((0, 0))
        Bss = block_diag(*[b[1] for b in blocks])
        Css = np.hstack([b[2] for b in blocks])
        Dss = np.hstack([b[3] for b in blocks])
        return control.ss(Ass, Bss, Css, Dss, self.dt, **io)

    # -------------------------------------------------------- recursive util
    def _time_of(self, index):
        """Time stamps of the rows ``index`` when the fit's data was an IDData."""
        data = getattr(self, "_fit_data", None)
        return None if data is None else np.asarray(data.t)[index]

    def _trajectory(self, theta, error, index, names, forgetting=None):
        return Trajectory(theta=theta, error=error, skipped=np.zeros(error.shape[0], dtype=bool),
                          forgetting=forgetting, meta={"index": index, "names": names},
                          names=tuple(names), time=self._time_of(index))

    def __repr__(self):
        orders = ", ".join(f"{k}={getattr(self, k)}" for k in self._order_names)
        state = "fitted" if self.theta is not None else "not fitted"
        return f"{type(self).__name__}({orders}, dt={self.dt:g}) [{state}]"
