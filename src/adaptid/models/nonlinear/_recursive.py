r"""Recursive re-estimation of a selected NARX structure (``NARX.fit_recursive``)."""

from __future__ import annotations

import dataclasses

import numpy as np

from ..._validation import param_error
from ._basis import evaluate

__all__ = ["RecursiveFitMixin", "make_estimator", "selected_regressors"]


def make_estimator(estimator, d, options, what="the selected terms"):
    """A fresh recursive estimator of ``d`` parameters.

    ``estimator`` None (→ ``"rls"``) or a method name of :func:`adaptid.estimator`
    with ``options``; or an estimator instance of ``d`` parameters, copied (then no
    options).
    """
    from ...estimators._factory import estimator as build

    if estimator is None or isinstance(estimator, str):
        return build("rls" if estimator is None else estimator, d, **options)
    if options:
        raise param_error("options", "none when estimator is an instance (its own options "
                          "are used)", f"<{', '.join(sorted(options))}>", exc=TypeError)
    if not all(hasattr(estimator, a) for a in ("run", "update", "copy", "n_params")):
        raise param_error("estimator", "None, a method name of adaptid.estimator ('rls', "
                          "'window', 'kalman', 'lms', 'nlms') or an adaptid recursive estimator",
                          estimator, exc=TypeError)
    if estimator.n_params != d:
        raise param_error("estimator", f"an estimator with n_params={d} ({what})",
                          f"<n_params={estimator.n_params}>")
    if getattr(estimator, "batch_size", None) is not None or \
            getattr(estimator, "n_outputs", 1) != 1 or np.ndim(estimator.theta) != 1:
        raise param_error("estimator", "a single-stream, single-output estimator",
                          "<a batched or multi-output estimator>")
    return estimator.copy()


def selected_regressors(model, recs):
    """Per output, the regressors of its selected process terms on the fit's rows, and
    the targets: ``([Φ_o (n_rows, d_o)], Y (n_rows, p), rows)``."""
    L = model.max_lag
    Xts, targets, index = [], [], []
    for i, r in enumerate(recs):
        if (r.n_outputs, r.n_inputs) != (model._p, model._m):
            raise param_error("data" if len(recs) == 1 else f"data[{i}]",
                              f"a record with {model._p} output(s) and {model._m} input(s) "
                              "as at fit time", f"<{r.n_outputs} outputs, {r.n_inputs} inputs>")
        rows_i = np.arange(L, len(r))
        if rows_i.size < 1:
            raise param_error("data" if len(recs) == 1 else f"data[{i}]",
                              f"longer than the largest lag L={L}", f"<{len(r)} samples>")
        base = model._base(lambda j, r=r: r.outputs, r.inputs, rows_i)
        Xts.append(np.column_stack([np.ones(rows_i.size), base]))
        targets.append(r.outputs[rows_i])
        index.append(rows_i)
    Xt = np.vstack(Xts)
    Phis = [np.ascontiguousarray(evaluate(Xt, r.combos)) for r in model.results]
    return Phis, np.ascontiguousarray(np.vstack(targets)), np.concatenate(index)


def _rels(Phi, y, q, est):
    """RELS of a NARMAX: the process regressors then q lags of the a-posteriori
    residual, on the compiled pseudo-linear kernel; a Trajectory."""
    from ...estimators import KalmanRLS, RLS, SlidingWindowRLS, Trajectory
    from .._recursive import regressors_used, run_signals, signal_spec

    if not isinstance(est, (RLS, SlidingWindowRLS, KalmanRLS)):
        raise param_error("estimator", "an RLS, SlidingWindowRLS or KalmanRLS (or its name) "
                          "for a NARMAX's recursive extended least squares",
                          f"<{type(est).__name__}>")
    n = Phi.shape[1] + q
    groups = (np.zeros(n, dtype=np.int64), np.zeros(q, dtype=np.int64),
              np.arange(1, q + 1, dtype=np.int64), 1)
    spec = signal_spec(groups, 1.0, -1.0, 1.0, n)   # ε = y − φᵀθ, lagged with sign +1
    Th, E, V, _, _, Lk, n_rebuilds = run_signals(Phi, y, spec, est)
    return Trajectory(theta=Th, error=E, skipped=np.zeros(E.shape[0], dtype=bool),
                      n_rebuilds=n_rebuilds, forgetting=Lk,
                      meta={"regressors": regressors_used(Phi, V, spec)})


class RecursiveFitMixin:
    """``fit_recursive`` of :class:`~adaptid.models.NARX` (kept apart: the model module's size)."""

    def fit_recursive(self, data, u=None, estimator=None, **options):
        r"""Re-estimate the selected terms with a recursive estimator, in one compiled pass.

        The structure (the terms FROLS selected at :meth:`fit`) is kept;
        its regressors :math:`\varphi_k = [p_j(k)]_{j\in S}` do not depend on
        θ (noise terms aside: see Notes), so they are formed once and the estimator runs over them
        (:meth:`adaptid.RLS.run`: one compiled loop). With RLS, λ = 1 and a
        large P₀ the final estimate is the batch θ up to the prior; a
        forgetting factor, a window or a Kalman random walk track a plant
        whose coefficients drift:

        .. math::

            \hat\theta_k = \hat\theta_{k-1} + K_k\big(y(k) - \varphi_k^T\hat\theta_{k-1}\big),
            \qquad K_k = \frac{P_{k-1}\varphi_k}{\lambda + \varphi_k^TP_{k-1}\varphi_k}

        (RLS; Ljung (1999), eq. 11.12). The model keeps its batch fit (θ,
        covariance, summary); :class:`~adaptid.models.RecursiveNARX`
        (``RecursiveNARX(model).run(...)``, then ``to_model()``) gives a model
        with the recursive estimate.

        Parameters
        ----------
        data : IDData, list of IDData, (y, u) tuple, or y (array_like)
            As :meth:`fit`: the rows k = L … N − 1 (of each record in turn,
            for several records, the estimator continuing across them).
        u : array_like, optional
        estimator : str or estimator, optional
            ``None`` (:class:`~adaptid.RLS`), a method name of
            :func:`adaptid.estimator` (``"rls"``, ``"window"``, ``"kalman"``,
            ``"lms"``, ``"nlms"``) built with ``**options`` and the number
            of selected terms d, or an estimator instance of d parameters
            (copied; the argument is not modified). Several outputs: one
            estimator per output (an instance then needs every output's d).
        **options
            The method's options (``forgetting``, ``window``,
            ``process_cov``, ``step``, ``P0``, ``theta0``, …).

        Returns
        -------
        Trajectory or tuple of Trajectory
            ``theta[i]`` after row i (sample ``meta["index"][i]``), the
            a-priori errors in ``error``; ``names`` the terms. One per output
            for several outputs. The estimators are kept as ``estimators``.

        Raises
        ------
        ValueError
            A record with other signals, an estimator of another size; for a
            NARMAX, several records or a gradient estimator.

        Notes
        -----
        NARMAX (``noise_lags`` q): the regressor ends with the lagged
        residuals :math:`\varepsilon(k-1), …, \varepsilon(k-q)`, which the
        recursion forms from its own estimates, the a-posteriori
        :math:`\varepsilon(k) = y(k) - \varphi_k^T\hat\theta_k` (recursive
        extended least squares, Söderström & Stoica (1989), sec. 9.4; 0
        before the first row), in the compiled pseudo-linear kernel of
        ARMAX with an RLS, SlidingWindowRLS or KalmanRLS (its settings read;
        ``estimators`` then holds the estimator as built, not advanced);
        ``meta["regressors"]`` holds the regressor rows it formed.
        """
        from .._iddata import IDData

        self._check_fitted()
        recs = self._record(data, u)
        recs = recs if isinstance(recs, list) else [recs]
        if self.noise_lags and len(recs) > 1:
            raise param_error("data", "one record for a NARMAX (noise_lags > 0): its lagged "
                              "residuals restart with each record", f"<{len(recs)} records>")
        Phis, Y, rows = selected_regressors(self, recs)
        trajs, ests = [], []
        for o, (r, Phi) in enumerate(zip(self.results, Phis)):
            d = Phi.shape[1] + self.noise_lags
            est = make_estimator(estimator, d, options, f"the {d} terms of output {r.output}")
            if self.noise_lags:
                traj = _rels(Phi, np.ascontiguousarray(Y[:, o]), self.noise_lags, est)
            else:
                traj = est.run(Phi, np.ascontiguousarray(Y[:, o]))
            time = None
            if len(recs) == 1 and isinstance(recs[0], IDData) and recs[0].time is not None:
                time = np.asarray(recs[0].time)[rows]
            meta = dict(traj.meta, index=rows, names=r.terms, output=r.output)
            trajs.append(dataclasses.replace(traj, meta=meta, names=tuple(r.terms), time=time))
            ests.append(est)
        self.estimators = tuple(ests)
        return trajs[0] if self._p == 1 else tuple(trajs)
