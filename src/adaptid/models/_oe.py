r"""The output-error model :math:`y_k = \frac{B(q)}{F(q)}u_k + e_k`."""

from __future__ import annotations

import numpy as np

from .._lazy import lazy
from .._validation import check_int
from ._builders import _per_input
from ._pem import _PseudoLinearModel
from ._polymodel import check_orders

signal = lazy("scipy.signal")

__all__ = ["OE"]


class OE(_PseudoLinearModel):
    r"""Output-error model, identified by pseudo-linear regression.

    .. math::

        y_k = \sum_{i=1}^{m}\frac{B_i(q)}{F_i(q)}u^{(i)}_k + e_k,\qquad
        \theta = [b^{(1)}, \dots, b^{(m)},\ f^{(1)}, \dots, f^{(m)}],

    with :math:`b^{(i)} = [b_0..b_{n_{b,i}-1}]` and
    :math:`f^{(i)} = [f_1..f_{n_{f,i}}]` (MATLAB's ``oe`` layout), and the
    noise-free outputs :math:`w^{(i)}_k = B_i(q)/F_i(q)\,u^{(i)}_k`. The
    predictor is :math:`\hat y_k = \sum_i w^{(i)}_k = \varphi_k^T\theta`,
    :math:`\varphi_k` holding, per input, :math:`u^{(i)}_{k-n_{k,i}}, \dots,
    u^{(i)}_{k-n_{k,i}-n_{b,i}+1}` and then, per input,
    :math:`-w^{(i)}_{k-1}, \dots, -w^{(i)}_{k-n_{f,i}}` — a pseudo-linear
    regression on the model's own simulated outputs, which (unlike ARX,
    whose regressor holds the noisy y) is not correlated with the noise, so
    the estimate is consistent for white or coloured e (when
    :math:`1/F_i(e^{i\omega}) - 1/2` is strictly positive real for the
    recursive version):

    * :meth:`fit_recursive` — recursive pseudo-linear regression (RPLR,
      Landau's output-error algorithm; Ljung 1999, sec. 11.3; Söderström &
      Stoica 1989, sec. 9.4), one compiled pass with any core estimator;
    * :meth:`fit` — batch: the Steiglitz–McBride iteration (ARX fits by
      :func:`adaptid.lstsq` on y and u prefiltered by 1/F̂), started from
      the plain ARX estimate. With several inputs, each input's
      Steiglitz–McBride step is fitted to y minus the other inputs' current
      simulated outputs, input after input, until θ settles (backfitting).

    :meth:`fit` then (``refine=True``, the default) minimises
    :math:`\sum_k(y_k - \sum_i w^{(i)}_k(\theta))^2`
    with :func:`scipy.optimize.least_squares` (analytic gradient:
    :math:`\partial w^{(i)}/\partial b^{(i)}_j = u^{(i)}_{k-n_{k,i}-j}/F_i(q)`,
    :math:`\partial w^{(i)}/\partial f^{(i)}_j = -w^{(i)}_{k-j}/F_i(q)`).
    The rows are the samples k = s … N-1, :math:`s = \max_i(n_{k,i} + n_{b,i}) - 1`,
    with w = 0 before the first row.

    Parameters
    ----------
    nb, nf, nk : int or sequence of int
        Orders (``nb >= 1``, ``nf >= 0``) and input delays (``>= 0``): one
        integer for every input or one per input.
    dt : float
        Sample time (default 1.0).

    References
    ----------
    .. [1] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
       Prentice Hall, 1999.
    .. [2] T. Söderström, P. Stoica, *System Identification*, Prentice Hall,
       1989.
    .. [3] K. Steiglitz, L. E. McBride, "A technique for the identification
       of linear systems", *IEEE Trans. Automatic Control* 10(4), 1965.
    """

    _order_names = ("nb", "nf", "nk")
    _alpha, _beta, _sgn = 0.0, 1.0, -1.0

    def __init__(self, nb, nf, nk=1, *, dt=1.0):
        check_orders(nb, "nb", low=1)
        check_orders(nf, "nf", low=0)
        self._init_orders(0, nb, 0, 0, nk, dt)
        self.nf = nf
        self._nf_spec = nf

    def _set_inputs(self, m, single):
        super()._set_inputs(m, single)
        self._nf = _per_input(self._nf_spec, "nf", m, low=0)
        self._nd = sum(self._nf)

    def _groups(self, nfix):
        col = np.concatenate([np.full(b, i) for i, b in enumerate(self._nb)] +
                             [np.full(f, i) for i, f in enumerate(self._nf)]).astype(np.int64)
        dyn_group = np.concatenate([np.full(f, i) for i, f in enumerate(self._nf)]).astype(np.int64)
        dyn_lag = np.concatenate([np.arange(1, f + 1) for f in self._nf]).astype(np.int64)
        return col, dyn_group, dyn_lag, self._m

    def _split(self, theta):
        bs, o = [], 0
        for b in self._nb:
            bs.append(theta[o: o + b])
            o += b
        fs = []
        for f in self._nf:
            fs.append(theta[o: o + f])
            o += f
        return np.zeros(0), bs, np.zeros(0), fs

    def _names(self):
        names = []
        for i, b in enumerate(self._nb):
            names += [f"b{j}" if self._single else f"b{i}_{j}" for j in range(b)]
        for i, f in enumerate(self._nf):
            names += [f"f{j}" if self._single else f"f{i}_{j}" for j in range(1, f + 1)]
        return tuple(names)

    def _errors(self, theta, Phi_fix, Y):
        _, bs, _, fs = self._split(theta)
        w_sum = np.zeros(Y.shape[0])
        psi_b, psi_f = [], []
        o = 0
        for b, f in zip(bs, fs):
            F = np.concatenate([[1.0], f])
            cols = Phi_fix[:, o: o + b.size]
            o += b.size
            w = self._filt(F, cols @ b)
            w_sum += w
            psi_b.append(self._filt(F, cols))
            psi_f.append(self._filt(F, -self._lag(w, f.size)) if f.size else np.zeros((w.size, 0)))
        return Y - w_sum, np.hstack(psi_b + psi_f)

    def fit(self, y, u=None, *, refine=True, n_iter=30, tol=1e-8, nan_policy="omit"):
        r"""Batch fit: Steiglitz–McBride iterations, then prediction-error refinement.

        Iteration (one input): filter y and u by :math:`1/\hat F`, fit
        :math:`\hat F(q)y^F_k = \hat B(q)u^F_k + e_k` by least squares, repeat
        until θ changes by less than ``tol·(1 + |θ|)`` or ``n_iter`` times.
        Several inputs: one such step per input in turn, on
        :math:`y - \sum_{j\ne i} \hat B_j/\hat F_j\,u^{(j)}` (each sweep
        over the inputs counts as one iteration).

        Parameters
        ----------
        y : array_like, shape (N,); pandas Series; or IDData (``u`` then omitted)
        u : array_like, shape (N,) or (N, m); pandas
        refine : bool
            Refine by minimising :math:`\sum(y - w(\theta))^2` from the
            Steiglitz–McBride estimate (default True, as MATLAB's ``oe``;
            False gives the Steiglitz–McBride estimate alone).
        n_iter : int
            Largest number of iterations (default 30).
        tol : float
        nan_policy : {"omit", "raise"}
            ``"omit"`` (default): NaN samples are gaps: the record is split at each run of NaN into separate experiments (the filters restart after each gap)
            (``n_dropped`` counts the rows lost, and ``summary()`` reports
            it). ``"raise"``: a NaN in y or u is refused (ValueError naming
            the signal).

        Returns
        -------
        self
        """
        from .._lstsq import lstsq
        from ._builders import arx_regressors

        from ._segments import check_nan_policy

        self._nan_policy = check_nan_policy(nan_policy)
        y, U = self._data(y, u, fitting=True)
        self._check_inputs(U)
        n_iter = check_int(n_iter, "n_iter", low=1)
        reg, Phi_fix = self._fixed_regression(y, U, self._single)
        # Steiglitz-McBride on the experiments and runs between gaps, filters restarted in each
        y, U, sb = self._segment_signals(y, U)
        from ._segments import lfilter_segments

        def pieces(x):
            return [x[a:b] for a, b in zip(sb[:-1], sb[1:])]

        m = self._m
        Fs = [np.ones(1) for _ in range(m)]
        Bs = [np.zeros(1) for _ in range(m)]
        W = np.zeros((m, y.shape[0]))          # each input's simulated output
        parts = [None] * m                     # [b_i, f_i] per input
        theta = None
        for _ in range(n_iter if self._nd else 1):
            for i in range(m):
                nb, nf, nk = self._nb[i], self._nf[i], self._nk[i]
                target = y - (W.sum(axis=0) - W[i])
                yf = lfilter_segments([1.0], Fs[i], target, sb)
                uf = lfilter_segments([1.0], Fs[i], U[:, i], sb)
                regf = arx_regressors(pieces(yf), pieces(uf), nf, nb, nk)
                th = np.asarray(lstsq(regf.Phi, regf.y).theta)
                b, f = th[nf:], -th[:nf]
                parts[i] = (b, f)
                Fs[i] = np.concatenate([[1.0], f])
                Bs[i] = np.concatenate([np.zeros(nk), b])
                W[i] = lfilter_segments(Bs[i], Fs[i], U[:, i], sb)
            new = np.concatenate([p[0] for p in parts] + [p[1] for p in parts])
            done = theta is not None and np.max(np.abs(new - theta)) < tol * (1 + np.max(np.abs(new)))
            theta = new
            if done:
                break
        if refine:
            theta = self._refine(theta, Phi_fix, reg.y)
        self._finish(theta, Phi_fix, reg.y, reg)
        return self
