r"""Streaming NARX: a selected polynomial structure identified one sample at a time."""

from __future__ import annotations

import re
from types import SimpleNamespace

import numpy as np

from ..._validation import as_float_array, check_choice, check_int, param_error
from ...estimators._statefile import StateFileMethods
from ._basis import evaluate
from ._recursive import make_estimator
from ._results import term_name

__all__ = ["RecursiveNARX", "parse_term"]

_STARTS = ("filled", "zero")
_FACTOR = re.compile(r"(.+\(k(?:-\d+)?\))(?:\^(\d+))?\Z")


def parse_term(term, base_names):
    """The sorted index tuple of a term name (``"u1(k-2)*y1(k-1)"``, ``"y(k-1)^2"``,
    ``"1"``) over [1, base variables]; a ValueError naming ``terms`` if unknown."""
    if not isinstance(term, str):
        raise param_error("terms", "term names (str)", term, exc=TypeError)
    t = term.replace(" ", "")
    if t == "1":
        return ()
    idx = []
    for factor in t.split("*"):
        m = _FACTOR.match(factor)
        if m is None or m.group(1) not in base_names:
            shown = ", ".join(base_names[:8]) + (", ..." if len(base_names) > 8 else "")
            raise param_error("terms", f"'1' or products of the base variables ({shown}), "
                              "powers as '^p'", term)
        idx += [base_names.index(m.group(1)) + 1] * int(m.group(2) or 1)
    return tuple(sorted(idx))


def _shell(ylag, ulag, degree, nk, y_names, u_names, dt, outputs):
    """A NARX with the given structure and, per output, (combos, θ, terms): what
    :meth:`RecursiveNARX.to_model` returns (no batch statistics: cov NaN)."""
    from ._narx import NARX, NARXResult

    m = NARX(ylag, ulag, degree, nk=nk)
    m._p, m._m = len(y_names), len(u_names)
    m.y_names, m.u_names, m.dt = tuple(y_names), tuple(u_names), dt
    results = []
    for name, (combos, theta, terms) in zip(y_names, outputs):
        d = len(terms)
        nan = np.full(d, np.nan)
        results.append(NARXResult(
            output=name, terms=tuple(terms), combos=np.asarray(combos, dtype=np.intp).reshape(
                d, degree), theta=np.asarray(theta, dtype=np.float64).reshape(d),
            cov=np.full((d, d), np.nan), err=nan, residuals=np.zeros(0), path=None,
            n_candidates=0, lsq=SimpleNamespace(tvalues=nan, pvalues=nan), _model=m))
    m.results = tuple(results)
    m.index = np.zeros(0, dtype=np.intp)
    return m


class RecursiveNARX(StateFileMethods):
    r"""Streaming polynomial NARX: the selected terms re-estimated sample by sample.

    The structure — the terms :math:`p_j` of one output :math:`y_o`,
    products of lagged outputs and inputs — is fixed (selected by
    :meth:`NARX.fit <adaptid.models.NARX.fit>` or given); θ is tracked by a
    core recursive estimator (:func:`adaptid.estimator`) over the
    regressors this object forms from its lag buffers:

    .. math::

        \varphi_k = [p_j(k)]_{j\in S},\qquad
        \hat y_o(k) = \varphi_k^T\hat\theta_{k-1},\qquad
        \hat\theta_k = \hat\theta_{k-1} + K_k\big(y_o(k) - \hat y_o(k)\big)

    (RLS by default: :math:`K_k = P_{k-1}\varphi_k/(\lambda +
    \varphi_k^TP_{k-1}\varphi_k)`, Ljung (1999), eq. 11.12).

    With ``start="filled"`` (default) no update is made until the buffers
    hold measured data (L samples, L the largest lag, counted from
    construction or :meth:`reset`): :meth:`step` then returns the unchanged θ
    and ``yhat = NaN``, and :meth:`run` over a whole record equals
    ``NARX.fit_recursive`` with the same estimator bit for bit. With
    ``start="zero"`` the unknown past is taken as 0 from the first sample.

    Parameters
    ----------
    model : NARX
        A fitted NARX without noise terms; its structure (lags, delay,
        signal names, the terms of output ``output``) is used, not its θ
        (give ``theta0=model.theta`` to start from it).
    output : int or str
        The output tracked (index or name; default the first).
    estimator : str or estimator, optional
        ``None`` (:class:`~adaptid.RLS`), a method name of
        :func:`adaptid.estimator` built with ``**options``, or an instance of
        d parameters (copied).
    start : {"filled", "zero"}
    **options
        The estimator's options (``forgetting``, ``window``, ``P0``,
        ``theta0``, …).

    Attributes
    ----------
    terms : tuple of str
    n_params : int
    estimator : the core estimator
    max_lag : int

    See Also
    --------
    from_terms : the same from term names, without a fitted model.

    Examples
    --------
    >>> import numpy as np
    >>> from adaptid.models import NARX, RecursiveNARX
    >>> rng = np.random.default_rng(0)
    >>> u = rng.uniform(-1, 1, 400); y = np.zeros(400)
    >>> for k in range(1, 400):
    ...     y[k] = 0.5 * y[k - 1] + u[k - 1] - 0.3 * u[k - 1] * y[k - 1]
    >>> obj = RecursiveNARX(NARX(1, 1, 2).fit((y, u)), forgetting=0.99)
    >>> theta, yhat = obj.step(y[0], u[0])
    >>> res = obj.run((y[1:], u[1:]))
    >>> bool(np.allclose(res.theta[-1], [1.0, 0.5, -0.3], atol=1e-6))
    True
    """

    _kind = "RecursiveNARX"
    _STATE_FILE_ARRAYS = {"ybuf": "ybuf", "ubuf": "ubuf"}

    def __init__(self, model, *, output=0, estimator=None, start="filled", **options):
        from ._narx import NARX

        if not isinstance(model, NARX):
            raise param_error("model", "a fitted adaptid.models.NARX (or use "
                              "RecursiveNARX.from_terms)", model, exc=TypeError)
        model._check_fitted()
        if model.noise_lags:
            raise param_error("model", "a NARX without noise terms (noise_lags=0)",
                              f"<noise_lags={model.noise_lags}>")
        outs = [(r.combos, r.theta, r.terms) for r in model.results]
        self._setup(model.ylag, model.ulag, model.degree, model.nk, model.y_names,
                    model.u_names, model.dt, outs, output)
        self.start = check_choice(start, "start", _STARTS)
        self._est = make_estimator(estimator, self.n_params, options,
                                   f"the {self.n_params} terms of output {self.output}")
        self.reset()

    @classmethod
    def from_terms(cls, terms, ylag, ulag, *, nk=1, y_names=("y",), u_names=("u",),
                   output=0, estimator=None, start="filled", dt=1.0, **options):
        """A streaming NARX of given terms.

        Parameters
        ----------
        terms : sequence of str
            Names as :attr:`NARX.terms <adaptid.models.NARX.terms>` writes
            them (``"1"``, ``"y(k-1)"``, ``"u(k-1)*y(k-1)"``, ``"u(k-2)^3"``),
            of the base variables the lags, the delay and the names give.
        ylag, ulag, nk : int
            As :class:`~adaptid.models.NARX`.
        y_names, u_names : str or sequence of str
            The signals (``u_names=()`` for a time series).
        output : int or str
            The output these terms explain.
        estimator, start, **options
            As the constructor.
        dt : float

        Returns
        -------
        RecursiveNARX
        """
        from ._narx import NARX

        y_names = (y_names,) if isinstance(y_names, str) else tuple(y_names)
        u_names = (u_names,) if isinstance(u_names, str) else tuple(u_names)
        if not y_names:
            raise param_error("y_names", "at least one output name", y_names)
        probe = NARX(ylag, ulag, 1, nk=nk)
        probe._p, probe._m, probe.y_names, probe.u_names = (len(y_names), len(u_names),
                                                            y_names, u_names)
        names = probe._base_names()
        if isinstance(terms, str) or not len(terms):
            raise param_error("terms", "a non-empty sequence of term names", terms,
                              exc=TypeError if isinstance(terms, str) else ValueError)
        tuples = [parse_term(t, names) for t in terms]
        D = max([len(t) for t in tuples] + [1])
        combos = np.array([(0,) * (D - len(t)) + t for t in tuples], dtype=np.intp)
        canon = [term_name(c, names) for c in combos]
        outs = [(np.zeros((0, D), dtype=np.intp), [], ())] * len(y_names)
        obj = cls.__new__(cls)
        o = obj._output_index(output, y_names)
        outs[o] = (combos, np.zeros(len(canon)), tuple(canon))
        obj._setup(ylag, ulag, D, nk, y_names, u_names, dt, outs, o)
        obj.start = check_choice(start, "start", _STARTS)
        obj._est = make_estimator(estimator, obj.n_params, options, "the terms")
        obj.reset()
        return obj

    # ------------------------------------------------------------ structure
    @staticmethod
    def _output_index(output, y_names):
        if isinstance(output, str):
            if output not in y_names:
                raise param_error("output", f"one of {list(y_names)}", output)
            return list(y_names).index(output)
        return check_int(output, "output", low=0, high=len(y_names) - 1)

    def _setup(self, ylag, ulag, degree, nk, y_names, u_names, dt, outs, output):
        from ._narx import NARX

        self.ylag, self.ulag, self.degree, self.nk = ylag, ulag, degree, nk
        self._p, self._m = len(y_names), len(u_names)
        self.y_names, self.u_names = tuple(y_names), tuple(u_names)
        self.dt = dt
        self._outs = [(np.asarray(c, dtype=np.intp), np.asarray(t, dtype=np.float64),
                       tuple(n)) for c, t, n in outs]
        self._o = self._output_index(output, self.y_names)
        self.output = self.y_names[self._o]
        self._combos, _, self.terms = self._outs[self._o]
        self.n_params = len(self.terms)
        if self.n_params == 0:
            raise param_error("terms", f"at least one term for output {self.output}", 0)
        probe = NARX(ylag, ulag, 1, nk=nk)
        probe._p, probe._m = self._p, self._m
        self.max_lag = probe.max_lag
        self._yb, self._ub = probe._base_layout()
        self._Lu = max([j for _, j in self._ub] + [0])
        n_base = len(self._yb) + len(self._ub)
        for c, t, n in self._outs:
            if c.shape != (len(n), degree) or t.shape != (len(n),) or \
                    (c.size and (c.min() < 0 or c.max() > n_base)):
                raise param_error("terms", f"index tuples of length {degree} into the "
                                  f"{n_base} base variables, one per term and θ",
                                  f"<combos of shape {c.shape}, {t.size} values>")

    @property
    def estimator(self):
        """The core estimator (read it; :meth:`step` and :meth:`run` update it)."""
        return self._est

    @property
    def theta(self):
        """The current estimate, shape (n,) (a copy)."""
        return np.array(self._est.theta, dtype=np.float64).reshape(-1)

    def reset(self):
        """Back to the prior (θ₀, P₀) with zero lag buffers and the sample count at 0."""
        self._est.reset()
        self._ybuf = np.zeros((self.ylag, self._p))   # row j-1: y(k-j)
        self._ubuf = np.zeros((self._Lu, self._m))    # row j-1: u(k-j)
        self._count = 0

    # ------------------------------------------------------------ regressors
    def _signals(self, y, u):
        """(Y (N, p), U (N, m), dt or None) of one record: IDData, (y, u) or arrays."""
        from .._iddata import IDData

        if isinstance(y, IDData):
            if u is not None:
                raise param_error("u", "None when y is an IDData", "<an array>", exc=TypeError)
            rec = y
        else:
            if isinstance(y, tuple) and u is None:
                if len(y) != 2:
                    raise param_error("y", "an IDData, a (y, u) pair or an array",
                                      f"<tuple of {len(y)}>", exc=TypeError)
                y, u = y
            rec = IDData(y, u)
        if getattr(rec, "n_experiments", 1) > 1:  # the lag buffers would run across them
            raise param_error("y", "one experiment (run each: data.experiment(k))",
                              f"<a merged record of {rec.n_experiments} experiments>")
        if (rec.n_outputs, rec.n_inputs) != (self._p, self._m):
            raise param_error("y", f"a record with {self._p} output(s) and {self._m} input(s)",
                              f"<{rec.n_outputs} outputs, {rec.n_inputs} inputs>")
        dt = y.dt if isinstance(y, IDData) else None
        return rec.outputs.reshape(len(rec), -1), rec.inputs.reshape(len(rec), -1), dt

    def _regressors(self, Y, U):
        """Φ (N, d) of the samples following the buffers, and the new buffers."""
        N = Y.shape[0]
        Yext = np.vstack([self._ybuf[::-1], Y])
        Uext = np.vstack([self._ubuf[::-1], U])
        k = np.arange(N)
        cols = [np.ones(N)] + [Yext[self.ylag + k - j, i] for i, j in self._yb] \
            + [Uext[self._Lu + k - j, i] for i, j in self._ub]
        Phi = evaluate(np.column_stack(cols), self._combos)
        return (np.ascontiguousarray(Phi, dtype=np.float64), Yext[::-1][: self.ylag].copy(),
                Uext[::-1][: self._Lu].copy())

    # ------------------------------------------------------------ use
    def step(self, y, u=None):
        r"""One sample: the prediction :math:`\hat y_o(k)`, then the update with :math:`y_o(k)`.

        Parameters
        ----------
        y : float or array_like, shape (p,)
            The outputs y(k) (every output: the lagged ones enter the terms).
        u : float or array_like, shape (m,)
            The inputs u(k) (none for a time series).

        Returns
        -------
        theta : ndarray, shape (n,)
            The estimate after y(k) is used (a copy).
        yhat : float
            :math:`\varphi_k^T\hat\theta_{k-1}`, made before y(k) is used (NaN
            while ``start="filled"`` waits).
        """
        from ..streaming._arx import _row_dot

        Y = as_float_array(y, "y").reshape(1, -1)
        if Y.shape[1] != self._p:
            raise param_error("y", f"{self._p} output value(s) of one sample", f"<shape "
                              f"{np.shape(y)}>")
        if self._m == 0 and u is not None:
            raise param_error("u", "None (the model has no input)", "<an array>", exc=TypeError)
        U = np.zeros((1, 0)) if self._m == 0 else as_float_array(u, "u").reshape(1, -1)
        if U.shape[1] != self._m:
            raise param_error("u", f"{self._m} input value(s) of one sample",
                              f"<shape {np.shape(u)}>")
        Phi, ybuf, ubuf = self._regressors(Y, U)
        if self.start == "filled" and self._count < self.max_lag:
            yhat = np.nan
        else:
            th = np.array(self._est.theta, dtype=np.float64).reshape(1, -1)
            yhat = float(_row_dot(Phi, th)[0])
            self._est.update(Phi[0], Y[0, self._o])
        self._ybuf, self._ubuf = ybuf, ubuf
        self._count += 1
        return self.theta, yhat

    def run(self, y, u=None):
        """A record at once: equal bit for bit to one :meth:`step` per sample.

        The regressors are formed in NumPy from the buffers and the record,
        and the core estimator runs over them in one compiled pass; the
        object continues from the record's end.

        Parameters
        ----------
        y : IDData, (y, u) tuple, or array_like, shape (N,) or (N, p)
        u : array_like, shape (N,) or (N, m), optional

        Returns
        -------
        StreamResult
            ``theta`` (N, n) after each sample, ``yhat`` (N,) before it, the
            terms as ``names``.
        """
        from ..streaming._arx import StreamResult, _row_dot

        Y, U, dt = self._signals(y, u)
        N = Y.shape[0]
        Phi, ybuf, ubuf = self._regressors(Y, U)
        first = min(max(self.max_lag - self._count, 0), N) if self.start == "filled" else 0
        theta = np.empty((N, self.n_params))
        th_prev = np.empty((N, self.n_params))
        yhat = np.full(N, np.nan)
        before = self.theta
        theta[:first] = before
        if first < N:
            traj = self._est.run(Phi[first:], np.ascontiguousarray(Y[first:, self._o]))
            Th = np.asarray(traj.theta, dtype=np.float64).reshape(N - first, -1)
            theta[first:] = Th
            th_prev[first] = before
            th_prev[first + 1:] = Th[:-1]
            yhat[first:] = _row_dot(Phi[first:], th_prev[first:])
        self._ybuf, self._ubuf = ybuf, ubuf
        self._count += N
        if dt is not None:
            self.dt = float(dt)
        return StreamResult(theta=theta, yhat=yhat, names=self.terms)

    def to_model(self):
        """The :class:`~adaptid.models.NARX` with the current θ for the tracked output.

        The other outputs keep the θ of the model this object was built from
        (an object of :meth:`from_terms` needs terms for every output, so
        it converts with one output only). The model has no batch
        statistics (its ``cov`` is NaN); it predicts, simulates, prints its
        equations and exports to C (:func:`adaptid.codegen.to_c`).
        """
        if any(len(n) == 0 for _, _, n in self._outs):
            raise param_error("to_model", "terms for every output (built from terms of one "
                              f"output of {self._p})", "<outputs without terms>")
        outs = list(self._outs)
        outs[self._o] = (self._combos, self.theta, self.terms)
        return _shell(self.ylag, self.ulag, self.degree, self.nk, self.y_names, self.u_names,
                      self.dt, outs)

    # ---------------------------------------------------- state files
    def get_state(self) -> dict:
        """Everything needed to resume exactly: the core estimator's state, the lag
        buffers, the structure and the sample count (plain values, float64 arrays)."""
        opts = {"ylag": self.ylag, "ulag": self.ulag, "degree": self.degree, "nk": self.nk,
                "y_names": list(self.y_names), "u_names": list(self.u_names),
                "dt": self.dt, "output": self._o, "start": self.start, "count": self._count,
                "outputs": [{"combos": c.tolist(), "theta": [float(v) for v in t],
                             "terms": list(n)} for c, t, n in self._outs]}
        return {"estimator": self._kind, "format": self._STATE_FORMAT,
                "n_params": max(self.n_params, self.ylag, self._p, self._Lu, self._m, 1),
                "options": opts, "inner": self._est.get_state(),
                "ybuf": self._ybuf.copy(), "ubuf": self._ubuf.copy()}

    @classmethod
    def from_state(cls, state: dict):
        """Rebuild from :meth:`get_state`'s dict (exact round trip)."""
        from ...estimators._statefile import estimator_from_state

        cls._check_state(state)
        try:
            o = dict(state["options"])
            outs = [(np.asarray(d["combos"], dtype=np.intp).reshape(-1, o["degree"]),
                     d["theta"], tuple(d["terms"])) for d in o["outputs"]]
            obj = cls.__new__(cls)
            obj._setup(o["ylag"], o["ulag"], o["degree"], o["nk"], o["y_names"], o["u_names"],
                       o["dt"], outs, o["output"])
            obj.start = check_choice(o["start"], "state['options']['start']", _STARTS)
            obj._est = estimator_from_state(state["inner"])
            ybuf = np.array(state["ybuf"], dtype=np.float64)
            ubuf = np.array(state["ubuf"], dtype=np.float64)
            count = o["count"]
        except (KeyError, TypeError) as err:
            raise param_error("state", "a complete dict from get_state()",
                              f"<{type(err).__name__}: {err}>") from None
        if ybuf.shape != (obj.ylag, obj._p) or ubuf.shape != (obj._Lu, obj._m):
            raise param_error("state", "lag buffers of the model's structure "
                              f"({(obj.ylag, obj._p)}, {(obj._Lu, obj._m)})",
                              f"<shapes {ybuf.shape}, {ubuf.shape}>")
        if obj._est.n_params != obj.n_params:
            raise param_error("state['inner']", f"an estimator of {obj.n_params} parameters",
                              f"<{obj._est.n_params} parameters>")
        if type(count) is not int or count < 0:
            raise param_error("state['options']['count']", "an integer >= 0", count)
        obj._ybuf, obj._ubuf, obj._count = ybuf, ubuf, count
        return obj

    def __repr__(self):
        return (f"RecursiveNARX(output={self.output!r}, terms={list(self.terms)}, "
                f"start={self.start!r}, n_updates={self._est.n_updates})")
