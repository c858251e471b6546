r"""Sparse regression of dynamics: sequentially thresholded least squares and SINDy."""

from __future__ import annotations

import itertools
import warnings

import numpy as np

from ..._exceptions import AdaptidWarning
from ..._summary import Summary, parameter_rows
from ..._validation import as_float_array, check_choice, check_int, check_scalar, param_error
from .._iddata import IDData
from .._polymodel import NotFittedError
from ..._lazy import pyplot

__all__ = ["stlsq", "SINDy", "polynomial_library"]


def _ridge(A, b, alpha):
    """argmin ‖b − Aw‖² + α‖w‖² (augmented least squares; plain lstsq for α = 0)."""
    if alpha > 0:
        n = A.shape[1]
        A = np.vstack([A, np.sqrt(alpha) * np.eye(n)])
        b = np.concatenate([b, np.zeros(n)])
    return np.linalg.lstsq(A, b, rcond=None)[0]


def stlsq(Theta, dX, threshold, alpha=0.0, max_iter=20):
    r"""Sequentially thresholded (ridge) least squares (STLSQ).

    The sparse regression of SINDy (Brunton, Proctor & Kutz 2016), step for
    step as pysindy's ``STLSQ`` with its defaults (``unbias=True``,
    ``normalize_columns=False``), so that the same Θ and derivative give
    the same coefficients:

    1. :math:`\xi^{(0)}` = least squares on all columns (no ridge, not thresholded);
    2. for each target, ridge regression on the columns still in the
       support :math:`S`,

       .. math:: \xi_S = \arg\min_w \lVert \dot x - \Theta_S w\rVert_2^2 + \alpha\lVert w\rVert_2^2

       (α unscaled), then coefficients with :math:`|\xi_j| <` ``threshold``
       are set to zero and leave the support;
    3. repeat 2 until no support changes (or nothing was ever removed),
       at most ``max_iter`` times;
    4. the final support (:math:`|\xi_j| > 10^{-14}`) is refitted by least
       squares without ridge.

    Parameters
    ----------
    Theta : array_like, shape (N, n)
        Library Θ(X), one column per candidate function.
    dX : array_like, shape (N,) or (N, p)
        Targets (derivatives, or the next states of a map).
    threshold : float
        ≥ 0.
    alpha : float
        Ridge weight ≥ 0 (default 0: thresholded least squares).
    max_iter : int
        ≥ 1 (default 20).

    Returns
    -------
    ndarray, shape (n,) or (n, p)
        The coefficients Ξ with :math:`\dot X \approx \Theta\,\Xi`.

    Warns
    -----
    AdaptidWarning
        If the threshold removes every term of a target, or the support is
        still changing after ``max_iter`` iterations.

    References
    ----------
    .. [1] S. L. Brunton, J. L. Proctor and J. N. Kutz, "Discovering
       governing equations from data by sparse identification of nonlinear
       dynamical systems", *PNAS* 113(15), 3932–3937, 2016.
       https://doi.org/10.1073/pnas.1517384113
    .. [2] pysindy, ``pysindy/optimizers/stlsq.py`` and ``base.py`` (v2.1).

    Examples
    --------
    >>> import numpy as np
    >>> from adaptid.models import stlsq
    >>> rng = np.random.default_rng(0)
    >>> Theta = rng.standard_normal((100, 5))
    >>> xi = stlsq(Theta, Theta @ [0, 2.0, 0, -1.0, 0] + 1e-3 * rng.standard_normal(100), 0.1)
    >>> np.flatnonzero(xi).tolist()
    [1, 3]
    """
    Theta = as_float_array(Theta, "Theta", ndim=2)
    dX = as_float_array(dX, "dX", ndim=(1, 2))
    single = dX.ndim == 1
    Y = dX.reshape(dX.shape[0], -1)
    if Y.shape[0] != Theta.shape[0]:
        raise param_error("dX", f"with N={Theta.shape[0]} rows (as Theta)", f"<{Y.shape[0]} rows>")
    threshold = check_scalar(threshold, "threshold", low=0.0)
    alpha = check_scalar(alpha, "alpha", low=0.0)
    max_iter = check_int(max_iter, "max_iter", low=1)
    n, p = Theta.shape[1], Y.shape[1]
    coef = np.linalg.lstsq(Theta, Y, rcond=None)[0]           # (n, p), step 1
    ind = np.ones((n, p), dtype=bool)
    n_selected = ind.sum()
    previous = coef
    optvar = np.zeros((n, p))
    for _ in range(max_iter):
        if not ind.any():
            warnings.warn(f"threshold {threshold} eliminated all coefficients", AdaptidWarning,
                          stacklevel=2)
            optvar = np.zeros((n, p))
            break
        optvar = np.zeros((n, p))
        for i in range(p):
            if not ind[:, i].any():
                warnings.warn(f"threshold {threshold} eliminated all coefficients of target {i}",
                              AdaptidWarning, stacklevel=2)
                continue
            c = np.zeros(n)
            c[ind[:, i]] = _ridge(Theta[:, ind[:, i]], Y[:, i], alpha)
            big = np.abs(c) >= threshold
            c[~big] = 0.0
            optvar[:, i] = c
            ind[:, i] = big
        unchanged = np.array_equal(optvar != 0, previous != 0)
        previous = optvar
        if ind.sum() == n_selected or unchanged:
            break
    else:
        warnings.warn(f"STLSQ did not converge after {max_iter} iterations", AdaptidWarning,
                      stacklevel=2)
    support = np.abs(optvar) > 1e-14                           # step 4: refit without ridge
    out = np.zeros((n, p))
    for i in range(p):
        if support[:, i].any():
            out[support[:, i], i] = np.linalg.lstsq(Theta[:, support[:, i]], Y[:, i],
                                                    rcond=None)[0]
    return out[:, 0] if single else out


def polynomial_library(X, degree, names):
    r"""Θ(X): the monomials of degree 0 … D of the columns of X, pysindy's order and names.

    By degree, then ``combinations_with_replacement`` (scikit-learn's
    ``PolynomialFeatures``): ``1, x0, x1, x0^2, x0 x1, x1^2, …``.

    Returns
    -------
    Theta : ndarray, shape (N, n_features)
    feature_names : list of str
    combos : list of tuple of int
    """
    X = np.asarray(X, dtype=np.float64)
    combos = [c for d in range(degree + 1)
              for c in itertools.combinations_with_replacement(range(X.shape[1]), d)]
    Theta = np.ones((X.shape[0], len(combos)))
    feat = []
    for j, c in enumerate(combos):
        for i in c:
            Theta[:, j] *= X[:, i]
        feat.append(" ".join(f"{names[i]}^{c.count(i)}" if c.count(i) > 1 else names[i]
                             for i in sorted(set(c))) or "1")
    return Theta, feat, combos


class SINDy:
    r"""Sparse identification of nonlinear dynamics (SINDy) with STLSQ.

    Continuous time (``discrete_time=False``): :math:`\dot x(t) = \Xi^T\Theta(z(t))`,
    the derivative estimated from the samples; discrete time: the map
    :math:`x(k+1) = \Xi^T\Theta(z(k))`. The library Θ is the polynomials
    up to ``degree`` (pysindy's ``PolynomialLibrary`` order and names) in

    .. math:: z(k) = [x(k), x(k-1), …, x(k-\mathrm{lags}), u(k)],

    so lagged terms are allowed (pysindy cannot use them; its issue #606).
    Rows are k = lags … (N − 1 continuous, N − 2 discrete). Ξ is
    :func:`stlsq` of (Θ, target); the least-squares refit of each
    equation's support also gives standard errors (:meth:`summary`).

    Parameters
    ----------
    degree : int
        Largest degree ≥ 1 (default 2).
    lags : int
        Past states in the library ≥ 0 (default 0).
    differentiation : {"finite", "savgol"}
        Continuous time: second-order finite differences
        (:func:`numpy.gradient`, ``edge_order=2``; pysindy's
        ``FiniteDifference()``) or after a Savitzky–Golay smoothing
        (window 11, order 3; pysindy's ``SmoothedFiniteDifference()``).
    discrete_time : bool
        Fit a map x(k+1) = f(z(k)) (default False).
    threshold, alpha, max_iter :
        Of :func:`stlsq` (defaults 0.1, 0.0, 20).

    Attributes
    ----------
    coefficients : ndarray, shape (n_states, n_features)
        One row per equation (pysindy's ``coefficients()`` layout).
    feature_names : list of str
    state_names : tuple of str

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.integrate import solve_ivp
    >>> from adaptid.models import SINDy
    >>> f = lambda t, z: [-2 * z[0], z[0] ** 2 - z[1]]
    >>> t = np.linspace(0, 5, 2001)
    >>> X = solve_ivp(f, (0, 5), [1.0, 0.5], t_eval=t, rtol=1e-10, atol=1e-12).y.T
    >>> print("\n".join(SINDy(degree=2, threshold=0.05).fit(X, t).equations()))
    x0' = -2.000 x0
    x1' = -1.000 x1 + 1.000 x0^2
    """

    def __init__(self, degree=2, lags=0, differentiation="finite", discrete_time=False,
                 threshold=0.1, alpha=0.0, max_iter=20):
        self.degree = check_int(degree, "degree", low=1)
        self.lags = check_int(lags, "lags", low=0)
        self.differentiation = check_choice(differentiation, "differentiation",
                                            ("finite", "savgol"))
        self.discrete_time = bool(discrete_time)
        self.threshold = check_scalar(threshold, "threshold", low=0.0)
        self.alpha = check_scalar(alpha, "alpha", low=0.0)
        self.max_iter = check_int(max_iter, "max_iter", low=1)
        self.coefficients = None

    # ------------------------------------------------------------ data
    def _variables(self, X, U):
        """z rows for k = lags … N − 1, shape (N − lags, n·(lags + 1) + m)."""
        N, L = X.shape[0], self.lags
        parts = [X[L - j: N - j] for j in range(L + 1)]
        if U.shape[1]:
            parts.append(U[L:])
        return np.hstack(parts)

    def _var_names(self):
        if self.discrete_time or self.lags:
            names = [f"{s}[k]" if j == 0 else f"{s}[k-{j}]" for j in range(self.lags + 1)
                     for s in self.state_names]
        else:
            names = list(self.state_names)
        return names + list(self.input_names)

    def derivative(self, X, t):
        """The derivative estimate of ``differentiation``, shape like X."""
        from scipy.signal import savgol_filter

        if self.differentiation == "savgol":
            X = savgol_filter(X, window_length=11, polyorder=3, axis=0)
        return np.gradient(X, t, axis=0, edge_order=2)

    def fit(self, X, t=1.0, u=None):
        r"""Build Θ and the target, and solve by :func:`stlsq`.

        Parameters
        ----------
        X : array_like, shape (N, n); or IDData (outputs are the states,
            inputs the controls, ``dt`` the sample time; ``t``, ``u`` omitted)
        t : float or array_like, shape (N,)
            Sample time, or the sample instants (continuous time).
        u : array_like, shape (N,) or (N, m), optional
            Control inputs, added to the library's variables.

        Returns
        -------
        self
        """
        if isinstance(X, IDData):
            data = X
            if data.n_experiments > 1:      # derivatives would reach across the boundary
                raise param_error("X", "an IDData of one experiment (fit each experiment of a "
                                  "merged record apart)", f"<{data.n_experiments} experiments>")
            X, U, t = as_float_array(data.outputs, "X"), as_float_array(data.inputs, "u"), data.dt
            self.state_names, self.input_names = data.y_names, data.u_names if U.shape[1] else ()
        else:
            X = as_float_array(X, "X", ndim=(1, 2))
            X = X.reshape(X.shape[0], -1)
            U = (np.zeros((X.shape[0], 0)) if u is None
                 else as_float_array(u, "u", ndim=(1, 2)).reshape(X.shape[0], -1))
            self.state_names = tuple(f"x{i}" for i in range(X.shape[1]))
            self.input_names = tuple(f"u{i}" for i in range(U.shape[1]))
        N, L = X.shape[0], self.lags
        if N < L + 3:
            raise param_error("X", f"at least lags + 3 = {L + 3} samples", f"<{N} samples>")
        if np.ndim(t) == 0:
            t = check_scalar(t, "t", low=0.0, low_open=True)
        else:
            t = as_float_array(t, "t", shape=(N,))
            if not np.all(np.diff(t) > 0):
                raise param_error("t", "strictly increasing time stamps", "<not increasing>")
        self.dt = t if np.ndim(t) == 0 else float(np.mean(np.diff(t)))
        Z = self._variables(X, U)
        if self.discrete_time:
            Z, target = Z[:-1], X[L + 1:]
        else:
            target = self.derivative(X, t)[L:]
        Theta, self.feature_names, self._combos = polynomial_library(Z, self.degree,
                                                                     self._var_names())
        self.coefficients = stlsq(Theta, target, self.threshold, self.alpha,
                                  self.max_iter).reshape(Theta.shape[1], -1).T
        self._Theta, self._target = Theta, target
        return self

    def _check_fitted(self):
        if self.coefficients is None:
            raise NotFittedError("this SINDy is not fitted yet: call fit() first")

    # ------------------------------------------------------------ use
    def _rhs(self, Z):
        Theta = polynomial_library(Z, self.degree, self._var_names())[0]
        return Theta @ self.coefficients.T

    def predict(self, X, u=None):
        r"""Θ(z) Ξ on a record: the derivatives (continuous) or the next states (discrete).

        Parameters
        ----------
        X : array_like, shape (N, n)
        u : array_like, shape (N, m), optional

        Returns
        -------
        ndarray, shape (N − lags, n)
            Row i belongs to sample k = lags + i (its prediction of
            x(k + 1) in discrete time).
        """
        self._check_fitted()
        X = as_float_array(X, "X", ndim=(1, 2))
        X = X.reshape(X.shape[0], -1)
        U = self._controls(u, X.shape[0])
        return self._rhs(self._variables(X, U))

    def _controls(self, u, N):
        m = len(self.input_names)
        if m == 0:
            return np.zeros((N, 0))
        if u is None:
            raise param_error("u", f"controls with {m} column(s) as at fit time", None,
                              exc=TypeError)
        return as_float_array(u, "u", ndim=(1, 2)).reshape(N, m)

    def simulate(self, x0, n_steps=None, *, t=None, u=None):
        r"""Simulate the identified model.

        Discrete time: iterate the map from the ``lags + 1`` initial states
        ``x0`` (oldest first) for ``n_steps`` samples in all. Continuous time
        (``lags == 0``): integrate :math:`\dot x = \Xi^T\Theta(x)` from ``x0``
        over the instants ``t`` (:func:`scipy.integrate.solve_ivp`, LSODA,
        rtol 1e-10; without inputs).

        Parameters
        ----------
        x0 : array_like, shape (n,) or (lags + 1, n)
        n_steps : int
            Discrete time: number of samples returned (initial ones included).
        t : array_like, shape (T,)
            Continuous time: the instants.
        u : array_like, shape (n_steps, m), optional
            Discrete time: the controls.

        Returns
        -------
        ndarray, shape (n_steps, n) or (T, n)
        """
        self._check_fitted()
        n = len(self.state_names)
        if self.discrete_time:
            n_steps = check_int(n_steps, "n_steps", low=self.lags + 1)
            X0 = as_float_array(x0, "x0", ndim=(1, 2)).reshape(-1, n)
            if X0.shape[0] != self.lags + 1:
                raise param_error("x0", f"{self.lags + 1} initial state(s) of {n}",
                                  f"<shape {X0.shape}>")
            U = self._controls(u, n_steps)
            X = np.zeros((n_steps, n))
            X[: self.lags + 1] = X0
            for k in range(self.lags, n_steps - 1):
                z = np.concatenate([X[k - j] for j in range(self.lags + 1)] + [U[k]])
                X[k + 1] = self._rhs(z[None, :])[0]
            return X
        if self.lags or self.input_names:
            raise param_error("model", "a continuous-time model without lags or inputs to "
                              "simulate", "<lags or inputs>")
        from scipy.integrate import solve_ivp

        t = as_float_array(t, "t", ndim=1)
        x0 = as_float_array(x0, "x0", shape=(n,))
        sol = solve_ivp(lambda _, x: self._rhs(x[None, :])[0], (t[0], t[-1]), x0, t_eval=t,
                        method="LSODA", rtol=1e-10, atol=1e-12)
        return sol.y.T

    # ------------------------------------------------------------ reports
    def equations(self, precision=3):
        """One string per state: ``"x0' = -10.000 x0 + 10.000 x1"`` (pysindy's format)."""
        self._check_fitted()
        out = []
        lhs = "{}[k+1]" if self.discrete_time else "{}'"
        for name, row in zip(self.state_names, self.coefficients):
            terms = [f"{c:.{precision}f} {f}" for c, f in zip(row, self.feature_names) if c != 0]
            out.append(f"{lhs.format(name)} = " + (" + ".join(terms) if terms else
                                                   f"{0:.{precision}f}"))
        return out

    def print(self, precision=3):
        """Print :meth:`equations`."""
        print("\n".join(self.equations(precision)))

    def summary(self, *, alpha=0.05):
        r"""The nonzero coefficients with standard errors, t and p of each equation's refit.

        The final step of :func:`stlsq` is least squares on each equation's
        support; its covariance :math:`\hat\sigma^2(\Theta_S^T\Theta_S)^{-1}`
        (:func:`adaptid.lstsq`) gives the errors (conditional on the support).

        Returns
        -------
        Summary
        """
        from ..._lstsq import lstsq

        self._check_fitted()
        names, rows = [], []
        st = {"N": self._Theta.shape[0], "features": self._Theta.shape[1],
              "threshold": self.threshold, "alpha": self.alpha,
              "time": "discrete" if self.discrete_time else "continuous"}
        for i, (s, row) in enumerate(zip(self.state_names, self.coefficients)):
            sup = np.flatnonzero(row)
            st[f"terms ({s})"] = sup.size
            if not sup.size:
                continue
            n = self._Theta.shape[0]
            try:
                res = lstsq(self._Theta[:, sup], self._target[:, i])
            except ValueError:  # a rank-deficient support: no standard errors
                rows.append(parameter_rows(row[sup], np.full(sup.size, np.nan), n - sup.size,
                                           alpha))
            else:
                rows.append(parameter_rows(row[sup], np.asarray(res.stderr), n - sup.size,
                                           alpha))
            lhs = f"{s}[k+1]" if self.discrete_time else f"{s}'"
            names += [f"{lhs}: {self.feature_names[j]}" for j in sup]
            r = self._target[:, i] - self._Theta[:, sup] @ row[sup]
            st[f"R^2 ({s})"] = 1 - (r @ r) / np.sum((self._target[:, i]
                                                     - self._target[:, i].mean()) ** 2)
        params = np.vstack(rows) if rows else np.zeros((0, 6))
        return Summary(title=f"SINDy(degree={self.degree}, lags={self.lags})",
                       names=tuple(names), params=params, stats=st, alpha=alpha,
                       notes=("stderr: least squares on each equation's support (given the "
                              "support)",))

    def to_frame(self):
        """Ξ as a DataFrame: one row per feature, one column per equation."""
        self._check_fitted()
        import pandas as pd

        lhs = [f"{s}[k+1]" if self.discrete_time else f"{s}'" for s in self.state_names]
        return pd.DataFrame(self.coefficients.T, index=pd.Index(self.feature_names, name="term"),
                            columns=lhs)

    def plot(self, *, fig=None):
        """The coefficients Ξ as an image (features × equations) → Figure."""
        self._check_fitted()
        plt = pyplot()
        fig = plt.figure(figsize=(3 + len(self.state_names), 1 + 0.25 * len(self.feature_names))) \
            if fig is None else fig
        ax = fig.subplots()
        lim = float(np.max(np.abs(self.coefficients))) or 1.0
        im = ax.imshow(self.coefficients.T, cmap="RdBu_r", vmin=-lim, vmax=lim, aspect="auto")
        ax.set_yticks(np.arange(len(self.feature_names)), labels=self.feature_names)
        ax.set_xticks(np.arange(len(self.state_names)), labels=list(self.state_names))
        fig.colorbar(im, ax=ax, label="coefficient")
        return fig

    def __repr__(self):
        state = "fitted" if self.coefficients is not None else "not fitted"
        return (f"SINDy(degree={self.degree}, lags={self.lags}, discrete_time={self.discrete_time},"
                f" threshold={self.threshold:g}) [{state}]")
