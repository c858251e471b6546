r"""``adaptid fleet`` with the model options of ``adaptid fit`` (``--arx``, ``--oe``, …).

Every path runs on Dask, one task per partition of whole devices (each
device's rows in ``--time`` order), and returns one row per device:

* Without ``--method`` (or with ``--method batch``) each device's record is
  fitted by the model object's ``fit`` (:func:`device_model`), as ``adaptid
  fit`` does for one record: least squares for ARX/FIR/AR, prediction
  errors for ARMA/ARMAX/OE/BJ; the columns are the model's θ (its names),
  ``stderr_<name>``, ``n_samples``, ``n_skipped``, ``sigma2`` and ``rms``
  (:func:`adaptid.fleet.fit_models`).
* ``--arma``/``--armax``/``--oe``/``--bj`` with a recursive ``--method``
  (``rls``, ``window``, ``kalman``, ``lms``, ``nlms``) run the streaming
  object (:class:`adaptid.models.RecursiveARMAX` …, ``start="filled"``,
  the estimator of ``--method`` and its options) over each device, as
  ``adaptid fit`` runs it for one record (the numbers of ``fit_recursive``):
  the same columns plus the change test (``change``, ``change_stat``,
  ``change_pvalue``, ``change_at``) on the regression the recursion formed
  (``--change-test a-priori``: on the stream's a-priori errors), and
  ``--tracks`` written as the ARX path writes them
  (:func:`adaptid.fleet.fit_models`). ``--nan skip`` is refused there: the
  recursion needs a complete record.
* ``--arx``/``--fir``/``--ar`` with a recursive ``--method``: the
  regressors of each device, in the model objects' sign convention and
  names, go to :func:`adaptid.fleet.identify` (:class:`ModelRegressors`),
  which runs the estimator over every device and adds its change test.
"""

from __future__ import annotations

import numpy as np

from ._errors import CLIError
from ._problem import PSEUDO_LINEAR, Structure, model_names, polynomial_form

__all__ = ["ModelRegressors", "fleet_structure", "fleet_method", "uses_fit_models",
           "device_model"]


def fleet_structure(y, u, orders: dict, dt) -> Structure | None:
    """The model option given to ``fleet`` (None for --phi/--model), checked as ``fit`` does."""
    given = {k: v for k, v in orders.items() if v is not None}
    if not given:
        if u is not None or dt is not None:
            raise CLIError(("--u" if u is not None else "--dt") + " applies with a model option "
                           "(--arx, --fir, --ar, --arma, --armax, --oe, --bj)")
        return None
    from ._problem import split_names

    s = Structure(y=y, u=split_names(u, "--u"), dt=dt, **given)
    s.check()
    return s


class ModelRegressors:
    """``model(device_rows) -> Regression`` for :func:`adaptid.fleet.identify`.

    The ARX/FIR/AR regressors of one device (:func:`adaptid.models.arx_regressors`,
    :func:`~adaptid.models.fir_regressors`) with the output lags negated, so
    that θ and its names are those of :class:`adaptid.models.ARX` /
    :class:`~adaptid.models.AR` (``a1``, ``b0``, ``b1_0``). A plain class
    (picklable) for the workers of a cluster.
    """

    def __init__(self, kind, orders, y, u):
        self.kind, self.orders, self.y, self.u = kind, tuple(orders), y, list(u or ())
        na, nb = self._na_nb()
        self.names = tuple(model_names(na, len(self.u), nb))

    def _na_nb(self):
        o = self.orders
        return {"arx": (o[0], o[1]), "fir": (0, o[0]), "ar": (o[0], 0)}[self.kind]

    def __call__(self, part):
        from adaptid import models

        y = part[self.y].to_numpy(dtype=np.float64)
        U = part[self.u].to_numpy(dtype=np.float64) if self.u else None
        u = None if U is None else U[:, 0] if U.shape[1] == 1 else U
        o = self.orders
        if self.kind == "arx":
            reg = models.arx_regressors(y, u, o[0], o[1], o[2])
        elif self.kind == "fir":
            reg = models.fir_regressors(y, u, o[0], o[1])
        else:
            reg = models.arx_regressors(y, np.zeros(len(y)), o[0], 0, 1)
        na, nb = self._na_nb()
        names, Phi = polynomial_form(reg.Phi, na, self.u, nb)
        return models.Regression(Phi=np.ascontiguousarray(Phi), y=np.asarray(reg.y, dtype=float),
                                 names=tuple(names), index=np.asarray(reg.index))


def uses_fit_models(s: Structure, method: str) -> bool:
    """Whether the model option runs by :func:`adaptid.fleet.fit_models` (a model object per
    device): every batch fit, and the pseudo-linear models with a recursive method."""
    return method == "batch" or s.kind in PSEUDO_LINEAR


def device_model(s: Structure, method: str, options: dict, nan_policy: str):
    """The object :func:`adaptid.fleet.fit_models` copies to every device.

    ``batch``: the model object of ``adaptid fit`` (``ARX`` …, ``BJ``, not
    fitted). A recursive method: the streaming object (``RecursiveARMA``,
    ``RecursiveARMAX``, ``RecursiveOE``, ``RecursiveBJ``; ``start="filled"``)
    with the algorithm, options and prior of the estimator that
    :func:`adaptid.estimator` builds from ``method`` and ``options``, as
    ``adaptid fit`` runs it.
    """
    from adaptid import models

    from ._engine import MethodSpec
    from ._modelfit import model_object, n_params

    dt = s.dt if s.dt is not None else 1.0
    if method == "batch":
        return model_object(s.kind, s, dt)
    if nan_policy == "skip":
        raise CLIError(f"--nan skip is not available with fleet --{s.kind} --method {method}: "
                       "the streaming model needs a complete record per device")
    est = MethodSpec(method=method, **options).make(n_params(s.kind, s.orders, len(s.u or ())),
                                                    "raise")
    cls = {"arma": models.RecursiveARMA, "armax": models.RecursiveARMAX,
           "oe": models.RecursiveOE, "bj": models.RecursiveBJ}[s.kind]
    try:
        return cls(*s.orders, start="filled", dt=dt)._use_core(est)
    except ValueError as e:
        raise CLIError(f"--{s.kind}: {e}") from None


def check_fleet_method(s: Structure, method: str | None, given: dict) -> str:
    """The method of a fleet with a model option, by the rule of ``adaptid fit``.

    ``batch`` unless ``--method`` says otherwise or an option that only a
    recursive run has is given (``given``: flag -> value; then ``rls``).
    """
    if method is None:
        from ._modelfit import default_method

        method = default_method(s, given)
    if method == "batch":
        if given.get("--tracks") is not None:
            raise CLIError("--tracks needs a recursive --method (rls, window, kalman, lms, nlms): "
                           "a batch model fit has no per-sample track")
        return "batch"
    return method


def fleet_method(*, y, u, phi, model, dt, method, orders: dict, given: dict):
    """``fleet``'s model option (a Structure or None) and its method, checked.

    ``orders``: the text of each model option (``--arx`` …), ``given``: the
    estimator options and ``--tracks`` (flag -> value). A batch fit takes no
    estimator option; ``--method batch`` needs a model option.
    """
    from adaptid.estimators._factory import METHODS

    from ._engine import check_options
    from ._problem import ORDER_LABELS, parse_orders

    structure = fleet_structure(y, u, {k: parse_orders(v, f"--{k}", ORDER_LABELS[k])
                                       for k, v in orders.items()}, dt)
    method = None if method is None else method.strip().lower()
    if structure is not None:
        if phi is not None or model is not None:
            raise CLIError(f"--{structure.kind} cannot be combined with "
                           + ("--phi" if phi is not None else "--model"))
        method = check_fleet_method(structure, method, given)
    method = method or "rls"
    if method not in METHODS and not (method == "batch" and structure is not None):
        raise CLIError(f"--method must be one of {', '.join(METHODS)} for fleet, got {method!r}"
                       " (batch: with a model option only)")
    if method == "batch":   # a batch model fit per device takes no estimator option
        check_options("batch", tuple((f, given.get(f)) for f in (
            "--window", "--forgetting", "--process-cov", "--noise-var", "--step", "--eps")))
        if given.get("--P0") is not None:
            raise CLIError("--P0 does not apply to a batch model fit (no prior); add --method rls")
    return structure, method
