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


class RecursiveFitMixin:
    """``fit_recursive`` of :class:`~adaptid.models.NARX` (kept apart: the model module's size)."""

    def fit_recursive(self, data, u=None, estimator=None, **options):
        r"""Re-estimate the selected terms with a recursive estimator, in one compiled pass.

        The structure (the terms FROLS selected at :meth:`fit`) is kept;
        its regressors :math:`\varphi_k = [p_j(k)]_{j\in S}` do not depend on
        θ, so they are formed once and the estimator runs over them
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
            NARMAX models (``noise_lags``: the lagged residuals depend on θ;
            re-estimate the process terms of a model without them), a record
            with other signals, an estimator of another size.
        """
        from .._iddata import IDData

        self._check_fitted()
        if self.noise_lags:
            raise param_error("noise_lags", "0 for fit_recursive (a NARMAX's noise terms need "
                              "a pseudo-linear recursion)", self.noise_lags)
        recs = self._record(data, u)
        recs = recs if isinstance(recs, list) else [recs]
        Phis, Y, rows = selected_regressors(self, recs)
        trajs, ests = [], []
        for o, (r, Phi) in enumerate(zip(self.results, Phis)):
            est = make_estimator(estimator, Phi.shape[1], options,
                                 f"the {Phi.shape[1]} terms of output {r.output}")
            traj = est.run(Phi, np.ascontiguousarray(Y[:, o]))
            time = None
            if len(recs) == 1 and isinstance(recs[0], IDData) and recs[0].time is not None:
                time = np.asarray(recs[0].time)[rows]
            meta = dict(traj.meta, index=rows, names=r.terms, output=r.output)
            trajs.append(dataclasses.replace(traj, meta=meta, names=tuple(r.terms), time=time))
            ests.append(est)
        self.estimators = tuple(ests)
        return trajs[0] if self._p == 1 else tuple(trajs)
