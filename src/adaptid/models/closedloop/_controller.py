r"""The known controller of a loop, as polynomials in the backward shift.

Convention (Ljung 1999, sec. 13.4): negative feedback

.. math::

    u_k = r_k - C(q)\,y_k,\qquad C(q) = \frac{X(q)}{Y(q)},

X and Y polynomials in :math:`q^{-1}` with Y monic (``Y[0] = 1`` after
normalisation).
"""

from __future__ import annotations

import numbers

import numpy as np

from ..._lazy import lazy
from ..._validation import as_float_array, param_error

signal = lazy("scipy.signal")

__all__ = ["as_controller", "controller_output"]

_EXPECTED = ("a gain (number), a pair (num, den) of polynomials in q^-1, or a discrete "
             "SISO control.TransferFunction")


def _from_transfer_function(tf):
    """(X, Y) in q⁻¹ from a discrete SISO python-control TransferFunction (powers of z)."""
    if getattr(tf, "ninputs", 1) != 1 or getattr(tf, "noutputs", 1) != 1:
        raise param_error("controller", "a SISO transfer function",
                          f"<{tf.noutputs}x{tf.ninputs} system>")
    dt = tf.dt
    if dt is None or dt is False or (not isinstance(dt, bool) and dt == 0):
        raise param_error("controller", "a discrete-time transfer function (dt > 0)",
                          "<a continuous-time system>")
    num = np.trim_zeros(np.asarray(tf.num[0][0], dtype=np.float64), "f")
    den = np.trim_zeros(np.asarray(tf.den[0][0], dtype=np.float64), "f")
    if num.size > den.size:
        raise param_error("controller", "a proper transfer function (deg num <= deg den)",
                          "<an improper one>")
    # num(z)/den(z) with deg den = n: divide both by z^n -> polynomials in q^-1
    return np.r_[np.zeros(den.size - max(num.size, 1)), num if num.size else [0.0]], den


def as_controller(controller):
    """(X, Y): the controller as numerator and monic denominator in q⁻¹.

    Raises
    ------
    ValueError
        Naming ``controller`` for anything else, a zero or non-finite
        leading denominator coefficient, or non-finite coefficients.
    """
    if isinstance(controller, (bool, np.bool_)):
        raise param_error("controller", _EXPECTED, controller)
    if isinstance(controller, (numbers.Real, np.floating, np.integer)):
        k = float(controller)
        if not np.isfinite(k):
            raise param_error("controller", "a finite gain", controller)
        X, Y = np.array([k]), np.array([1.0])
    elif hasattr(controller, "num") and hasattr(controller, "den"):
        X, Y = _from_transfer_function(controller)
    elif isinstance(controller, (tuple, list)) and len(controller) == 2:
        X = as_float_array(controller[0], "controller num", ndim=1)
        Y = as_float_array(controller[1], "controller den", ndim=1)
        if X.size == 0 or Y.size == 0:
            raise param_error("controller", "non-empty num and den", controller)
    else:
        raise param_error("controller", _EXPECTED, controller)
    if not (np.all(np.isfinite(X)) and np.all(np.isfinite(Y))):
        raise param_error("controller", "finite coefficients", "<non-finite coefficients>")
    if Y[0] == 0:
        raise param_error("controller", "a denominator with a non-zero leading coefficient "
                          "(a causal controller)", f"<den = {Y.tolist()}>")
    return X / Y[0], Y / Y[0]


def controller_output(X, Y, r, y):
    r"""The controller's output :math:`r - (X/Y)\,y` (zero initial conditions)."""
    return r - signal.lfilter(X, Y, y)
