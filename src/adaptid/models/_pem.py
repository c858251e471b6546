r"""Shared parts of the pseudo-linear models (ARMAX, OE): prediction errors,
their gradient, the recursive fit and the prediction-error refinement."""

from __future__ import annotations

import numpy as np

from .._lazy import lazy
from ._polymodel import _PolyModel
from ._recursive import regressors_used, run_signals, signal_spec

signal = lazy("scipy.signal")
optimize = lazy("scipy.optimize")

__all__ = ["_PseudoLinearModel", "lagmat", "stabilize"]


def lagmat(x, n):
    """Columns x[t-1], …, x[t-n] (zeros before the start), shape (len(x), n)."""
    N = x.shape[0]
    out = np.zeros((N, n))
    for j in range(1, n + 1):
        out[j:, j - 1] = x[: N - j] if j < N else 0.0
    return out


def stabilize(p):
    """Reflect the roots of a monic polynomial in q⁻¹ into the unit disc."""
    if p.size <= 1:
        return p
    r = np.roots(p)
    bad = np.abs(r) > 1.0
    if not bad.any():
        return p
    r[bad] = 1.0 / np.conj(r[bad])
    return np.real(np.poly(r))


class _PseudoLinearModel(_PolyModel):
    """Models whose regressor holds signals computed from the estimate."""

    # subclass: _nd (number of dynamic columns), _alpha, _beta, _sgn,
    # _errors(theta, Phi_fix, Y) -> (eps, Psi), _names()

    _splits_at_gaps = True

    def _prepare(self, y, u):
        y, U = self._data(y, u, fitting=True)
        self._check_inputs(U)
        reg, Phi = self._fixed_regression(y, U, self._single)
        return reg, Phi

    def _check_inputs(self, U):
        pass

    def _groups(self, nfix):
        """(col_group, dyn_group, dyn_lag, G) of the recursion: by default one
        signal formed from all columns, lagged 1 … _nd times."""
        nd = self._nd
        return (np.zeros(nfix + nd, dtype=np.int64), np.zeros(nd, dtype=np.int64),
                np.arange(1, nd + 1, dtype=np.int64), 1)

    def _signal_spec(self, nfix):
        """The recursion's signals and dynamic columns (see ``run_signals``)."""
        groups = self._groups(nfix)
        return signal_spec(groups, self._alpha, self._beta, self._sgn,
                           nfix + np.asarray(groups[1]).shape[0])

    def _finish(self, theta, Phi_fix, Y, reg):
        self.theta = np.asarray(theta, dtype=np.float64)
        eps, Psi = self._errors(self.theta, Phi_fix, Y)
        self.residuals = eps
        self._set_cov_from_gradient(Psi, eps)
        self.index = reg.index
        self.names = self._names()

    def _refine(self, theta, Phi_fix, Y, max_nfev=None):
        """Minimise Σ ε(θ)² (the prediction-error criterion) from ``theta``."""
        def fun(th):
            return self._errors(th, Phi_fix, Y)[0]

        def jac(th):
            return -self._errors(th, Phi_fix, Y)[1]

        sol = optimize.least_squares(fun, theta, jac=jac, method="trf", x_scale="jac",
                                     max_nfev=max_nfev)
        self.refine_result = sol
        return self._stable(sol.x)

    def _stable(self, theta):
        return theta

    def fit_recursive(self, y, u=None, estimator=None, *, refine=False):
        r"""Recursive pseudo-linear regression in one compiled pass.

        The regressor of sample k contains signals built from the estimates
        up to k-1 (see the class description), so Φ cannot be precomputed;
        a numba kernel runs the whole recursion with the algorithm of
        ``estimator``, on the U-D factors of P as the core estimators do
        (Bierman's update, so a diffuse prior costs no accuracy):

        .. math::

            \varepsilon_k = y_k - \varphi_k^T\hat\theta_{k-1},\quad
            K_k = \frac{P_{k-1}\varphi_k}{\lambda r_2 + \varphi_k^TP_{k-1}\varphi_k},\quad
            \hat\theta_k = \hat\theta_{k-1} + K_k\varepsilon_k,\quad
            P_k = \frac{P_{k-1} - K_k\varphi_k^TP_{k-1}}{\lambda} + R_1,

        with λ the (constant) forgetting factor of an :class:`~adaptid.RLS`
        or :class:`~adaptid.SlidingWindowRLS` (whose window also removes the
        sample k - M with weight :math:`\lambda^M`), or
        :math:`\lambda = 1`, :math:`r_2 = R_2`, :math:`R_1` of a
        :class:`~adaptid.KalmanRLS` (:math:`r_2 = 1`, :math:`R_1 = 0`
        otherwise). Söderström & Stoica (1989), sec. 9.4 (RPLR). A window
        removal that would lose definiteness is replaced, as in
        :class:`~adaptid.SlidingWindowRLS`, by an exact re-solve of the window
        from a buffer of the regressors used (the estimator's starting θ, P
        as the prior), with a :class:`~adaptid.DefinitenessLossWarning`;
        ``Trajectory.n_rebuilds`` counts them.

        Parameters
        ----------
        y : array_like, shape (N,); or IDData (``u`` then omitted)
            May hold several experiments (a merged IDData) and NaN gaps
            (see Notes).
        u : array_like, shape (N,) or (N, m)
        estimator : RLS, SlidingWindowRLS or KalmanRLS, optional
            Read, not modified: its options and current θ, P are the
            starting point. An RLS may carry a forgetting strategy of
            :mod:`adaptid.forgetting` or ``P_max``: its step is then the one
            :class:`~adaptid.RLS` takes, and ``Trajectory.forgetting`` holds
            the λₖ applied. Default: RLS with θ₀ = 0, P₀ = 10⁴ I, no forgetting.
            With ``P0="diffuse"`` (RLS, KalmanRLS, a fresh SlidingWindowRLS)
            the start is exact: until the regressors formed so far have full
            rank θ is the minimum-norm least-squares solution on them (the
            diffuse Kalman filter's estimate for KalmanRLS) and
            ``Trajectory.identified`` is False; from then on θ is the exact
            (forgotten or windowed) least-squares solution on the regressors
            the recursion formed, with no prior term (``P`` is inf while
            not identified).
        refine : bool
            Follow with the prediction-error refinement (see :meth:`fit`).

        Returns
        -------
        Trajectory
            Row i is the estimate after row i of the regression (sample
            ``meta["index"][i]``); ``error`` the a-priori errors;
            ``meta["regressors"]`` (N, d) the regressor rows the recursion
            formed (fixed columns, then the lagged signals);
            ``meta["row_bounds"]`` the first row of each piece (and the
            number of rows), ``meta["n_dropped"]`` the rows lost to gaps
            (as the model's ``n_dropped``). The model takes the final
            estimate; ``cov`` is the prediction-error covariance at it.

        Notes
        -----
        **Several experiments and gaps.** A merged record
        (:meth:`IDData.merge <adaptid.IDData.merge>`) or one with NaN
        samples is run piece by piece, the pieces being the experiments
        split at each run of NaN into the runs of complete samples (as
        :meth:`fit` splits them). The rows of each piece are formed inside
        it (from its sample :math:`s = \max(n_a, n_k + n_b - 1)` on), and
        the lagged signals the recursion builds (residuals, simulated
        outputs) restart from zero at its first row, as the
        prediction-error filters of :meth:`fit` restart per experiment
        (Ljung (1999), sec. 14.2). The estimator's state (θ, P, the
        window buffer, the diffuse state, the forgetting) runs on from one
        piece to the next, so the result equals running the pieces one
        after the other with the final θ, P of each handed to the next.
        Still one compiled call: the kernel takes the pieces' row bounds.
        """
        self._nan_policy = "omit"           # gaps split the record into runs (see fit)
        reg, Phi_fix = self._prepare(y, u)
        rb = np.asarray(self._row_bounds, dtype=np.int64)
        Ik = np.empty(reg.y.shape[0])
        spec = self._signal_spec(Phi_fix.shape[1])
        Th, E, V, theta, P, Lk, n_rebuilds = run_signals(Phi_fix, reg.y, spec, estimator, Ik,
                                                         row_bounds=rb)
        diffuse = bool(getattr(estimator, "diffuse", False))
        theta = self._stable(theta)
        if refine:
            theta = self._refine(theta, Phi_fix, reg.y)
        self._finish(theta, Phi_fix, reg.y, reg)
        self.P = P
        import dataclasses

        traj = self._trajectory(Th, E, reg.index, self.names, Lk)
        traj.meta.update(regressors=regressors_used(Phi_fix, V, spec, rb), row_bounds=rb,
                         n_dropped=self.n_dropped, n_experiments=self.n_experiments)
        return dataclasses.replace(traj, n_rebuilds=n_rebuilds,
                                   identified=(Ik != 0.0) if diffuse else None)

    def _filt(self, den, X, num=(1.0,)):
        """num/den filter of the rows, restarted at each experiment and gap."""
        from ._segments import lfilter_segments

        return lfilter_segments(list(num), den, X, getattr(self, "_row_bounds", None))

    def _lag(self, x, n):
        """Columns x[t-1], …, x[t-n] of the rows, zero before each experiment and gap."""
        from ._segments import lagmat_segments

        return lagmat_segments(x, n, getattr(self, "_row_bounds", None))

    def _segment_signals(self, y, U):
        """(y, U) on the fit's pieces, concatenated, and their sample bounds."""
        pieces = self._fit_pieces
        pos = np.concatenate([np.arange(a, b) for a, b in pieces])
        sb = np.concatenate([[0], np.cumsum([b - a for a, b in pieces])]).astype(np.int64)
        return y[pos], U[pos], sb
