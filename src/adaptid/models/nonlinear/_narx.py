r"""Polynomial NARX models with FROLS structure selection."""

from __future__ import annotations

import numpy as np

from ..._validation import as_float_array, check_choice, check_int, param_error
from .._iddata import IDData, u_with_iddata_error
from .._polymodel import NotFittedError
from ..._kernels.layers._narx import narx_simulate, narx_terms
from ._basis import MonomialBasis
from ._frols import CRITERIA, criteria, frols
from ._recursive import RecursiveFitMixin
from ._results import NARXResult, term_name

__all__ = ["NARX", "NARXResult"]


def _lagged(e, q):
    """[e(k-1) … e(k-q)] of a series, zeros before its start; shape (len(e), q)."""
    E = np.zeros((e.size, q))
    for j in range(1, q + 1):
        E[j:, j - 1] = e[:-j]
    return E


class NARX(RecursiveFitMixin):
    r"""Polynomial NARX model with structure selection by FROLS.

    .. math::

        y_i(k) = \sum_{j \in S_i} \theta_{ij}\, p_j(k) + e_i(k),

    where the candidates :math:`p_j` are the constant and all products
    (with repetition) of up to ``degree`` of the base variables
    :math:`y_l(k-1) … y_l(k-n_y)` (every output l) and
    :math:`u_l(k-n_k) … u_l(k-n_k-n_u+1)` (every input l):
    :math:`\binom{n + D}{D}` candidates for n base variables and degree D.
    The rows are the samples k = L … N − 1, L the largest lag (no assumed
    initial values). For each output the set :math:`S_i` is chosen by
    forward regression with orthogonal least squares (FROLS, the largest
    error reduction ratio first; :func:`~adaptid.models.nonlinear._frols.frols`)
    and θ is the least-squares fit on it (:func:`adaptid.lstsq`: covariance,
    standard errors, t and p).

    The number of terms is ``n_terms`` or, when that is None, the global
    minimum of ``criterion`` over the FROLS path d = 1 … ``max_terms``,
    with V = SSR/N:

    .. math::

        \mathrm{AIC} = N\log V + 2d,\quad \mathrm{BIC} = N\log V + d\log N,\quad
        \mathrm{FPE} = N\log V + N\log\tfrac{N+d}{N-d},\quad
        \mathrm{LILC} = N\log V + 2d\log\log N .

    (sysidentpy stops at the first local minimum of a criterion computed
    with the centred residual variance; here the global minimum on the path
    with Ljung's loss.)

    Parameters
    ----------
    ylag : int
        :math:`n_y \ge 0`, output lags 1 … n_y.
    ulag : int
        :math:`n_u \ge 0`, input lags :math:`n_k … n_k + n_u - 1`.
    degree : int
        Largest degree D ≥ 1 of a product (default 2).
    nk : int
        Input delay ≥ 0 (default 1).
    selection : {"frols"}
        Structure selection.
    n_terms : int, optional
        Terms per output; None selects by ``criterion``.
    criterion : {"aic", "bic", "fpe", "lilc"}
        Default "aic".
    max_terms : int
        Longest FROLS path searched by the criterion (default 30; capped
        at the number of candidates and N − 1).
    noise_lags : int
        q ≥ 0 (default 0). NARMAX: after the selection of the process terms,
        the linear noise terms e(k−1) … e(k−q) are added and θ is
        re-estimated by extended least squares — the regression on the
        process terms and the lagged residuals of the previous fit, iterated
        until θ changes by less than 1e-9 relative (at most 100 times;
        residuals before the first row are 0). ``n_terms`` counts the
        process terms only. Simulation ignores the noise terms; k-step
        predictions use the one-step errors up to t − k.
    max_memory : int, optional
        Bytes for the products of the first D − 1 factors of every
        candidate, kept between FROLS steps (default 256 MiB). The N × M
        candidate matrix is never formed; past this budget the products are
        recomputed in row blocks at each step (slower, same terms and θ).

    Attributes
    ----------
    terms : tuple of str (one output) or tuple of tuples (several)
        ``"1"``, ``"y(k-1)"``, ``"u1(k-2)*y1(k-1)"``, ``"y(k-1)^2"`` (the
        data's signal names).
    err, theta, stderr, cov : ndarray (one output) or tuples of them
    results : tuple of NARXResult
        One per output (``result`` is the first).
    index : ndarray, shape (N - L,)
        The fit's rows (of each experiment in turn, for several).
    max_lag : int
        L.

    Notes
    -----
    The error reduction ratio of a candidate p after the chosen terms is
    :math:`(\tilde p^Ty)^2/(\tilde p^T\tilde p\; y^Ty)`, :math:`\tilde p`
    its part orthogonal to them (y is not centred, as in sysidentpy with
    ``order_selection=False``, whose terms, ERR and θ these match). A
    candidate whose orthogonal part keeps less than 1e-10 of its squared
    norm counts as dependent and is not chosen; losses below 1e-20·yᵀy
    count as equal in the criteria, so that noise-free data give the exact
    model rather than round-off terms.

    References
    ----------
    .. [1] S. A. Billings, S. Chen and M. J. Korenberg, "Identification of
       MIMO non-linear systems using a forward-regression orthogonal
       estimator", *Int. J. Control* 49(6), 2157–2189, 1989.
       https://doi.org/10.1080/00207178908559767
    .. [2] S. A. Billings, *Nonlinear System Identification: NARMAX Methods
       in the Time, Frequency, and Spatio-Temporal Domains*, Wiley, 2013,
       ch. 3. https://doi.org/10.1002/9781118535561
    .. [3] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
       1999, sec. 16.4.

    Examples
    --------
    >>> import numpy as np
    >>> from adaptid.models import NARX
    >>> rng = np.random.default_rng(0)
    >>> u = rng.uniform(-1, 1, 400); y = np.zeros(400)
    >>> for k in range(1, 400):
    ...     y[k] = 0.5 * y[k - 1] + u[k - 1] - 0.3 * u[k - 1] * y[k - 1]
    >>> m = NARX(1, 1, 2).fit((y, u))
    >>> m.terms
    ('u(k-1)', 'y(k-1)', 'u(k-1)*y(k-1)')
    >>> bool(np.allclose(m.theta, [1.0, 0.5, -0.3]))
    True
    """

    def __init__(self, ylag, ulag, degree=2, *, nk=1, selection="frols", n_terms=None,
                 criterion="aic", max_terms=30, noise_lags=0, max_memory=None):
        self.ylag = check_int(ylag, "ylag", low=0)
        self.ulag = check_int(ulag, "ulag", low=0)
        self.degree = check_int(degree, "degree", low=1)
        self.nk = check_int(nk, "nk", low=0)
        self.selection = check_choice(selection, "selection", ("frols",))
        self.n_terms = None if n_terms is None else check_int(n_terms, "n_terms", low=1)
        self.criterion = check_choice(criterion, "criterion", CRITERIA)
        self.max_terms = check_int(max_terms, "max_terms", low=1)
        self.noise_lags = check_int(noise_lags, "noise_lags", low=0)
        self.max_memory = None if max_memory is None else check_int(max_memory, "max_memory",
                                                                    low=1)
        self.results = None
        self._fit_record = None

    # ----------------------------------------------------------- data
    @staticmethod
    def _pieces(data):
        """A record's experiments, each split at its NaN gaps (list of IDData)."""
        if data.n_experiments == 1 and not (np.isnan(data.outputs).any()
                                            or np.isnan(data.inputs).any()):
            return [data]
        from .._segments import record_pieces

        return record_pieces(data)

    @staticmethod
    def _record(data, u=None):
        if isinstance(data, IDData):
            if u is not None:
                raise param_error("u", "None when data is an IDData", "<an array>", exc=TypeError)
            pieces = NARX._pieces(data)
            return pieces if len(pieces) > 1 else pieces[0]
        if isinstance(data, (list, tuple)) and data and all(isinstance(d, IDData) for d in data):
            if u is not None:
                raise param_error("u", "None when data are IDData records", "<an array>",
                                  exc=TypeError)
            first = data[0]
            for i, d in enumerate(data[1:], 1):
                if (d.n_outputs, d.n_inputs) != (first.n_outputs, first.n_inputs):
                    raise param_error(f"data[{i}]", f"a record with {first.n_outputs} output(s) "
                                      f"and {first.n_inputs} input(s) as data[0]",
                                      f"<{d.n_outputs} outputs, {d.n_inputs} inputs>")
            return [piece for d in data for piece in NARX._pieces(d)]
        if isinstance(data, tuple) and u is None:
            if len(data) != 2:
                raise param_error("data", "an IDData or a (y, u) pair", f"<tuple of {len(data)}>",
                                  exc=TypeError)
            data, u = data
        return NARX._record(IDData(data, u))

    @property
    def max_lag(self):
        """L: the largest lag (the first fitted row)."""
        ul = self.nk + self.ulag - 1 if self.ulag and self._m else 0
        return max(self.ylag, ul)

    def _base_layout(self):
        """(output index, lag) and (input index, lag) of each base variable, in order."""
        yb = [(i, j) for i in range(self._p) for j in range(1, self.ylag + 1)]
        ub = [(i, j) for i in range(self._m) for j in range(self.nk, self.nk + self.ulag)]
        return yb, ub

    def _base_names(self):
        yb, ub = self._base_layout()
        def lag(j):
            return "k" if j == 0 else f"k-{j}"
        return ([f"{self.y_names[i]}({lag(j)})" for i, j in yb]
                + [f"{self.u_names[i]}({lag(j)})" for i, j in ub])

    def _base(self, Ysrc, U, rows):
        """Base variables at ``rows``; Ysrc(lag) → the output array used for that lag."""
        yb, ub = self._base_layout()
        cols = [Ysrc(j)[rows - j, i] for i, j in yb] + [U[rows - j, i] for i, j in ub]
        if not cols:
            return np.zeros((rows.size, 0))
        return np.column_stack(cols)

    def _check_fitted(self):
        if self.results is None:
            raise NotFittedError("this NARX is not fitted yet: call fit() first")

    # ----------------------------------------------------------- fit
    def fit(self, data, u=None):
        r"""Select the terms and estimate θ for every output.

        Parameters
        ----------
        data : IDData, list of IDData, (y, u) tuple, or y (array_like, shape (N,) or (N, p))
            The record; with an array, ``u`` gives the inputs (shape (N,)
            or (N, m), or None for a time series). Several experiments (a
            list of records with the same signals, or a merged IDData): the
            rows k = L … N_i − 1 of each are stacked (no lag reaches across
            records; the names and ``dt`` are the first record's; the
            summary then gives no fit % on the estimation data). NaN samples
            split a record into the runs between them, as experiments.
        u : array_like, optional

        Returns
        -------
        self
        """
        from ..._lstsq import lstsq

        recs = self._record(data, u)
        recs = recs if isinstance(recs, list) else [recs]
        rec = recs[0]
        self._p, self._m = rec.n_outputs, rec.n_inputs
        self.y_names, self.u_names, self.dt = rec.y_names, rec.u_names, rec.dt
        n_base = self._p * self.ylag + self._m * self.ulag
        if n_base == 0:
            raise param_error("ylag + ulag", ">= 1 lagged variable for the data's signals", 0)
        L = self.max_lag
        blocks, targets, index, lengths = [], [], [], []
        for i, r in enumerate(recs):
            rows_i = np.arange(L, len(r))
            if rows_i.size < 1:
                raise param_error("data" if len(recs) == 1 else f"data[{i}]",
                                  f"longer than the largest lag L={L}", f"<{len(r)} samples>")
            blocks.append(self._base(lambda j, r=r: r.outputs, r.inputs, rows_i))
            targets.append(r.outputs[rows_i])
            index.append(rows_i)
            lengths.append(rows_i.size)
        Yrows = np.vstack(targets)
        rows = np.concatenate(index)
        basis = MonomialBasis(np.vstack(blocks), self.degree, budget=self.max_memory)
        M = basis.M
        if rows.size <= 2:
            raise param_error("data", f"longer than the largest lag L={L} plus 2 samples",
                              f"<{len(rec)} samples>")
        names = self._base_names()
        results = []
        for o in range(self._p):
            y = np.ascontiguousarray(Yrows[:, o])
            yty = float(y @ y)
            if not yty > 0:
                raise param_error("data", "outputs that are not all zero on the fitted rows",
                                  f"<output {self.y_names[o]} all zero>")
            if self.n_terms is not None:
                if self.n_terms > min(M, rows.size - 1):
                    raise param_error("n_terms", f"<= {min(M, rows.size - 1)} (the candidates "
                                      "and the rows allow)", self.n_terms)
                path = frols(basis, y, self.n_terms)
                d, info = path.selected.size, None
                if d < self.n_terms:
                    import warnings

                    from ..._exceptions import AdaptidWarning

                    warnings.warn(f"only {d} of n_terms={self.n_terms} candidates of output "
                                  f"{self.y_names[o]} are linearly independent on the data",
                                  AdaptidWarning, stacklevel=2)
            else:
                cap = min(self.max_terms, M, rows.size - 1)
                path = frols(basis, y, cap)
                info = criteria(path.ssr, rows.size, yty)
                d = int(np.argmin(info[self.criterion])) + 1
                info = dict(info, ssr=path.ssr, chosen=d)
            sel = path.selected[:d]
            Phi = basis.columns(sel)
            res, iters = lstsq(Phi, y), 0
            if self.noise_lags:
                res, iters = self._els(Phi, y, res, lengths)
            combos = basis.combos[sel]
            e_name = "e" if self._p == 1 else f"e_{self.y_names[o]}"
            results.append(NARXResult(
                output=self.y_names[o],
                terms=tuple(term_name(c, names) for c in combos)
                + tuple(f"{e_name}(k-{j})" for j in range(1, self.noise_lags + 1)),
                combos=combos, theta=np.asarray(res.theta, dtype=np.float64).reshape(-1),
                cov=np.asarray(res.cov), err=path.err[:d], residuals=np.asarray(res.residuals),
                path=info, n_candidates=M, lsq=res,
                criterion=None if info is None else self.criterion, _model=self,
                noise_lags=self.noise_lags, iterations=iters))
        self.results = tuple(results)
        self.index = rows
        self._fit_record = (rec.outputs, rec.inputs) if len(recs) == 1 else None
        return self

    def _els(self, Phi, y, res, lengths, *, max_iter=100, rtol=1e-9):
        """Extended least squares on [Φ, e(k-1) … e(k-q)], the residuals of the previous fit."""
        import warnings

        from ..._exceptions import AdaptidWarning
        from ..._lstsq import lstsq

        q = self.noise_lags
        e = np.asarray(res.residuals)
        theta = None
        for it in range(1, max_iter + 1):
            E = np.vstack([_lagged(part, q) for part in np.split(e, np.cumsum(lengths)[:-1])])
            res = lstsq(np.hstack([Phi, E]), y)
            new = np.asarray(res.theta).reshape(-1)
            if theta is not None and np.linalg.norm(new - theta) <= rtol * (1 + np.linalg.norm(new)):
                return res, it
            theta, e = new, np.asarray(res.residuals)
        warnings.warn(f"extended least squares did not converge in {max_iter} iterations",
                      AdaptidWarning, stacklevel=3)
        return res, max_iter

    # ----------------------------------------------------------- attributes
    def _per_output(self, attr):
        self._check_fitted()
        vals = tuple(getattr(r, attr) for r in self.results)
        return vals[0] if self._p == 1 else vals

    @property
    def result(self):
        """The first (or only) output's :class:`NARXResult`."""
        self._check_fitted()
        return self.results[0]

    terms = property(lambda self: self._per_output("terms"),
                     doc="Selected terms (tuple per output for several outputs).")
    err = property(lambda self: self._per_output("err"), doc="ERR of the selected terms.")
    theta = property(lambda self: self._per_output("theta"), doc="Estimated parameters.")
    stderr = property(lambda self: self._per_output("stderr"), doc="Standard errors.")
    cov = property(lambda self: self._per_output("cov"), doc="Parameter covariance.")
    residuals = property(lambda self: np.column_stack([r.residuals for r in self.results])
                         if self._p > 1 else self._per_output("residuals"),
                         doc="One-step prediction errors of the fit's rows.")

    # ----------------------------------------------------------- evaluation
    def _signals(self, y, u, what):
        if isinstance(y, IDData):
            if u is not None:
                raise u_with_iddata_error(u)
            y, u = y.outputs, y.inputs
        Y = as_float_array(getattr(y, "to_numpy", lambda: y)(), what, ndim=(1, 2))
        Y = Y.reshape(Y.shape[0], -1)
        if Y.shape[1] != self._p:
            raise param_error(what, f"with {self._p} output column(s) as at fit time",
                              f"<{Y.shape[1]} columns>")
        U = self._inputs(u, Y.shape[0])
        return Y, U

    def _inputs(self, u, N=None):
        if self._m == 0:
            return np.zeros((N if N is not None else 0, 0))
        if isinstance(u, IDData):
            u = u.inputs
        if u is None:
            raise param_error("u", f"an input signal with {self._m} column(s)", None,
                              exc=TypeError)
        U = as_float_array(getattr(u, "to_numpy", lambda: u)(), "u", ndim=(1, 2))
        U = U.reshape(U.shape[0], -1)
        if U.shape[1] != self._m:
            raise param_error("u", f"with {self._m} input column(s) as at fit time",
                              f"<{U.shape[1]} columns>")
        if N is not None and U.shape[0] != N:
            raise param_error("u", f"with {N} rows (as y)", f"<{U.shape[0]} rows>")
        return U

    def _term_table(self):
        """(combos (T, D) int64, θ (T,), start (p + 1,)): every output's process terms
        in one table, output after output (the compiled simulator's layout)."""
        combos = np.ascontiguousarray(np.vstack([r.combos for r in self.results]),
                                      dtype=np.int64)
        theta = np.concatenate([r.theta[: r.n_process] for r in self.results])
        start = np.cumsum([0] + [r.n_process for r in self.results]).astype(np.int64)
        return combos, np.ascontiguousarray(theta, dtype=np.float64), start

    def _process(self, Xt, r):
        """The process part of output r's prediction on the rows of Xt (compiled sums)."""
        out = np.empty(Xt.shape[0])
        narx_terms(np.ascontiguousarray(Xt, dtype=np.float64),
                   np.ascontiguousarray(r.combos, dtype=np.int64),
                   np.ascontiguousarray(r.theta[: r.n_process], dtype=np.float64), out)
        return out

    def _out(self, Y):
        return Y[:, 0].copy() if self._p == 1 else Y

    def predict(self, y, u=None, k=1):
        r"""k-step-ahead prediction :math:`\hat y(t\,|\,t-k)` from measured outputs and inputs.

        Each prediction runs the model k steps from the measured outputs up
        to t − k (the inputs are known); the first L samples are the
        measured ones. Computed for all t at once, k vectorised passes.
        With noise terms (``noise_lags``) the one-step errors ε solve
        :math:`C(q)\,\varepsilon = y - \text{process part}`
        (:math:`C = 1 + c_1q^{-1} + …`, ε = 0 before row L), and
        e(t − j) is ε(t − j) when j ≥ k and its mean 0 otherwise.

        Parameters
        ----------
        y : array_like, shape (N,) or (N, p); or IDData (then ``u`` omitted)
        u : array_like, shape (N,) or (N, m)
        k : int
            Horizon ≥ 1 (default 1: the one-step predictor of the fit).

        Returns
        -------
        ndarray, shape (N,) or (N, p)
        """
        self._check_fitted()
        Y, U = self._signals(y, u, "y")
        k = check_int(k, "k", low=1)
        N, L = Y.shape[0], self.max_lag
        rows = np.arange(L, N)
        Xt1 = self._Xt(self._base(lambda j: Y, U, rows))
        eps = []   # one-step errors of the NARMAX terms: C(q) ε = y − process part
        for r in self.results:
            if r.noise_lags:
                from scipy.signal import lfilter

                c = r.theta[r.n_process:]
                resid = Y[L:, list(self.y_names).index(r.output)] - self._process(Xt1, r)
                eps.append(lfilter([1.0], np.concatenate([[1.0], c]), resid))
            else:
                eps.append(None)
        preds = [Y]
        for h in range(1, k + 1):
            Xt = Xt1 if h == 1 else self._Xt(self._base(lambda j, h=h: preds[max(h - j, 0)],
                                                          U, rows))
            Yh = Y.copy()
            for o, r in enumerate(self.results):
                Yh[L:, o] = self._process(Xt, r)
                if eps[o] is not None:  # e(t - j) is known for j >= h, else its mean 0
                    E = _lagged(eps[o], r.noise_lags)
                    E[:, : h - 1] = 0.0
                    Yh[L:, o] += E @ r.theta[r.n_process:]
            preds.append(Yh)
        return self._out(preds[k])

    @staticmethod
    def _Xt(X):
        return np.column_stack([np.ones(X.shape[0]), X])

    def simulate(self, u, y0=None):
        r"""Free-run simulation from the inputs and L initial outputs.

        .. math::

            \hat y(k) = \sum_{j\in S} \theta_j\, p_j\big(\hat y(k-1), …, u(k-n_k), …\big),
            \qquad k = L, …, N-1,

        with :math:`\hat y(k) = y_0(k)` for k < L.

        Parameters
        ----------
        u : array_like, shape (N,) or (N, m); IDData (its inputs and,
            unless ``y0`` is given, its first L outputs); or, for a model
            without inputs, the number of samples N
        y0 : array_like, shape (≥ L,) or (≥ L, p), optional
            Initial outputs (the first L rows are used, e.g. the measured
            record); default zeros.

        Returns
        -------
        ndarray, shape (N,) or (N, p)
        """
        self._check_fitted()
        if isinstance(u, IDData):
            if y0 is None:
                y0 = u.outputs
            u = u.inputs
        L = self.max_lag
        if self._m:
            U = self._inputs(u)
            N = U.shape[0]
        else:
            N = check_int(u, "u (the number of samples of a time series)", low=1)
            U = np.zeros((N, 0))
        Y = np.zeros((N, self._p))
        if y0 is not None:
            Y0 = as_float_array(y0, "y0", ndim=(1, 2)).reshape(np.shape(y0)[0], -1)
            if Y0.shape[1] != self._p or Y0.shape[0] < min(L, N):
                raise param_error("y0", f"at least {L} rows of {self._p} output(s)",
                                  f"<shape {Y0.shape}>")
            Y[:min(L, N)] = Y0[:min(L, N)]
        yb, ub = self._base_layout()
        Xu = (np.column_stack([U[np.arange(N) - j, i] for i, j in ub]) if ub
              else np.zeros((N, 0)))
        combos, theta, start = self._term_table()
        with np.errstate(over="ignore", invalid="ignore"):
            narx_simulate(Y, np.ascontiguousarray(Xu),
                          np.array([i for i, _ in yb], dtype=np.int64),
                          np.array([j for _, j in yb], dtype=np.int64),
                          combos, theta, start, L)
        return self._out(Y)

    #: compare() passes the measured record as y0 to simulate (the first L outputs)
    _simulate_needs_y0 = True

    # ----------------------------------------------------------- reports
    def to_equations(self, *, precision=6):
        """The model as text, one line per output: ``"y(k) = 0.5 y(k-1) + 1 u(k-1) - 0.3 …"``.

        Parameters
        ----------
        precision : int
            Significant digits of the coefficients (default 6).

        Returns
        -------
        str
        """
        self._check_fitted()
        lines = []
        for r in self.results:
            parts = []
            for i, (th, t) in enumerate(zip(r.theta, r.terms)):
                mag = f"{abs(th):.{precision}g}"
                body = mag if t == "1" else f"{mag} {t}"
                sign = "-" if th < 0 else "+"
                parts.append(("-" + body if sign == "-" else body) if i == 0 else f"{sign} {body}")
            lines.append(f"{r.output}(k) = " + (" ".join(parts) if parts else "0"))
        return "\n".join(lines)

    def summary(self, *, alpha=0.05, max_lag=25):
        """:meth:`NARXResult.summary` of the output (a tuple of them for several outputs)."""
        self._check_fitted()
        s = tuple(r.summary(alpha=alpha, max_lag=max_lag) for r in self.results)
        return s[0] if self._p == 1 else s

    def to_frame(self):
        """:meth:`NARXResult.to_frame`; several outputs: one frame with an ``output`` index level."""
        self._check_fitted()
        if self._p == 1:
            return self.results[0].to_frame()
        import pandas as pd

        return pd.concat({r.output: r.to_frame() for r in self.results}, names=["output"])

    def plot(self, *, fig=None):
        """:meth:`NARXResult.plot` of the first output → Figure."""
        self._check_fitted()
        return self.results[0].plot(fig=fig)

    def __repr__(self):
        state = "fitted" if self.results is not None else "not fitted"
        sel = f"n_terms={self.n_terms}" if self.n_terms else f"criterion={self.criterion!r}"
        if self.noise_lags:
            sel += f", noise_lags={self.noise_lags}"
        return (f"NARX(ylag={self.ylag}, ulag={self.ulag}, degree={self.degree}, nk={self.nk}, "
                f"{sel}) [{state}]")
