r"""``adaptid fleet`` with the model options of ``adaptid fit`` (``--arx``, ``--oe``, …).

Without ``--method`` (or with ``--method batch``) every device's record is
fitted by the model object's ``fit``, as ``adaptid fit`` does for one record
(least squares for ARX/FIR/AR, prediction errors for ARMA/ARMAX/OE/BJ): one
row per device with the model's θ, standard errors, σ̂², RMS residual and
the number of samples. With a recursive ``--method`` (``rls``, ``window``,
``kalman``, ``lms``, ``nlms``) the ARX/FIR/AR regressors of each device,
in the model objects' sign convention and names, go to
:func:`adaptid.fleet.identify` (:class:`ModelRegressors`), which runs the
estimator over every device on Dask and adds its change test; the
pseudo-linear models have no fixed regressors and are fitted in batch only.
"""

from __future__ import annotations

import numpy as np

from ._errors import CLIError
from ._problem import PSEUDO_LINEAR, Structure, model_names, polynomial_form

__all__ = ["ModelRegressors", "fleet_structure", "fleet_method", "fit_devices"]


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


def _device_fit(s: Structure, part, label):
    """The model object of ``s`` fitted to one device's rows."""
    from adaptid import IDData

    from ._modelfit import model_object

    y = part[s.y].to_numpy(dtype=np.float64)
    U = part[s.u].to_numpy(dtype=np.float64) if s.u else None
    if not np.isfinite(y).all() or (U is not None and not np.isfinite(U).all()):
        raise CLIError(f"device {label!r}: missing values in the columns used; a batch model "
                       "fit needs a complete record (use --method rls --nan skip to skip them)")
    try:
        data = IDData(y, U, dt=s.dt if s.dt is not None else 1.0, y_names=s.y, u_names=s.u)
        model = model_object(s.kind, s, data.dt)
        model.fit(data.y if s.kind == "arma" else data)
    except (ValueError, np.linalg.LinAlgError) as e:
        raise CLIError(f"device {label!r}: --{s.kind}: {e}") from None
    return model


def fit_devices(frame, group, s: Structure, *, time=None):
    """One batch model fit per device; a DataFrame indexed by device (sorted).

    Columns: the model's parameter names, ``stderr_<name>``, ``n_samples``
    (residuals), ``n_skipped`` (0), ``sigma2`` (the model's noise variance),
    ``rms`` (RMS residual).
    """
    import pandas as pd

    for col in [group, s.y, *(s.u or ()), *([time] if time else [])]:
        if col not in frame.columns:
            raise CLIError(f"column {col!r} is not in the data (columns: "
                           f"{', '.join(map(str, frame.columns[:20]))})")
    rows, labels = [], []
    for label, part in frame.groupby(group, sort=True):
        if time is not None:
            part = part.sort_values(time, kind="stable")
        m = _device_fit(s, part, label)
        res = np.asarray(m.residuals, dtype=np.float64)
        row = dict(zip(m.names, map(float, m.theta)))
        row.update({f"stderr_{n}": float(se) for n, se in zip(m.names, m.stderr)})
        row.update(n_samples=int(res.size), n_skipped=0, sigma2=float(m.noise_variance),
                   rms=float(np.sqrt(np.mean(res ** 2))))
        rows.append(row)
        labels.append(label)
    return pd.DataFrame(rows, index=pd.Index(labels, name=group))


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
    if s.kind in PSEUDO_LINEAR:
        raise CLIError(f"--method {method} is not available with fleet --{s.kind}: its regressors "
                       "are filtered with the running estimate; fit it in batch (no --method)")
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
