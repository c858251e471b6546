"""One place for argument checking, so that messages never drift.

Every message has the form ``"<name> must be <expected>, got <found>"``.
"""

from __future__ import annotations

import math
import numbers
import operator

import numpy as np

__all__ = [
    "param_error",
    "as_float_array",
    "check_scalar",
    "check_choice",
    "check_spd",
    "check_int",
]


def _describe(value) -> str:
    if isinstance(value, np.ndarray):
        return f"array of shape {value.shape} and dtype {value.dtype}"
    text = repr(value)
    if len(text) > 60:
        text = text[:57] + "..."
    return text


def param_error(name: str, expected: str, got, *, exc=ValueError) -> Exception:
    """Build the one error message template: ``name must be expected, got got``."""
    if isinstance(got, str) and got.startswith("<") and got.endswith(">"):
        found = got[1:-1]  # a description rather than a value
    else:
        found = _describe(got)
    return exc(f"{name} must be {expected}, got {found}")


def as_float_array(x, name: str, *, ndim=None, shape=None, finite=True,
                   allow_nan=False, copy=False) -> np.ndarray:
    """Convert ``x`` to a C-contiguous float64 array and check it.

    Parameters
    ----------
    x : array_like
        The value.
    name : str
        Argument name for messages.
    ndim : int or tuple of int, optional
        Allowed numbers of dimensions.
    shape : tuple, optional
        Expected shape; ``None`` entries match any length.
    finite : bool
        Reject NaN and infinity.
    allow_nan : bool
        With ``finite=True``, still allow NaN (but not infinity).
    copy : bool
        Always return a new array.

    Raises
    ------
    TypeError
        If ``x`` is not real-valued numeric data.
    ValueError
        On a wrong number of dimensions, shape or non-finite values.
    """
    if isinstance(x, np.ndarray) and x.dtype == np.float64:
        arr = x
    else:
        try:
            probe = np.asarray(x)
        except Exception as err:  # ragged sequences and the like
            raise param_error(name, "a real numeric array", x, exc=TypeError) from err
        if probe.dtype.kind == "c":
            raise param_error(name, "real-valued (not complex)", probe, exc=TypeError)
        if probe.dtype.kind in "USV" or (probe.dtype.kind == "O" and any(
                isinstance(v, (str, bytes, complex)) for v in probe.flat)):
            # "1.5" is text, not a number: parsing is the caller's business
            raise param_error(name, "a real numeric array (not text)", probe, exc=TypeError)
        if probe.dtype.kind not in "biuf":
            try:
                probe = probe.astype(np.float64)
            except (TypeError, ValueError) as err:
                raise param_error(name, "a real numeric array", probe, exc=TypeError) from err
        arr = probe.astype(np.float64, copy=False)
    if ndim is not None:
        allowed = (ndim,) if isinstance(ndim, int) else tuple(ndim)
        if arr.ndim not in allowed:
            exp = " or ".join(str(a) for a in allowed)
            raise param_error(name, f"{exp}-dimensional", arr)
    if shape is not None:
        ok = arr.ndim == len(shape) and all(
            s is None or s == a for s, a in zip(shape, arr.shape))
        if not ok:
            want = "(" + ", ".join("*" if s is None else str(s) for s in shape) + \
                ("," if len(shape) == 1 else "") + ")"
            raise param_error(name, f"of shape {want}", f"<shape {arr.shape}>")
    if finite and arr.size:
        if allow_nan:
            if np.isinf(arr).any():
                raise param_error(name, "free of infinite values", "<infinite entries>")
        elif not np.isfinite(arr).all():
            bad = np.argwhere(~np.isfinite(arr))[0]
            where = tuple(int(i) for i in bad) if arr.ndim > 1 else int(bad[0])
            raise param_error(name, "finite (no NaN or inf)",
                              f"<a non-finite value at index {where}>")
    if copy or not arr.flags.c_contiguous:
        arr = np.array(arr, dtype=np.float64, order="C", copy=True)
    return arr


def check_scalar(x, name: str, *, low=None, high=None, low_open=False,
                 high_open=False, finite=True) -> float:
    """Check a real scalar against an interval and return it as ``float``.

    ``finite=False`` also accepts ±inf (within the interval); NaN never.
    """
    if isinstance(x, (bool, np.bool_)) or not isinstance(x, (numbers.Real, np.floating, np.integer)):
        if isinstance(x, np.ndarray) and x.ndim == 0 and x.dtype.kind in "iuf":
            x = x.item()
        else:
            raise param_error(name, "a real number", x, exc=TypeError)
    try:
        val = float(x)
    except OverflowError:  # a Python int beyond the float range
        val = math.inf if x > 0 else -math.inf
        if finite:
            raise param_error(name, "a finite real number (within the float range)",
                              "<an integer too large for a float>") from None
    lo_b = "(" if low_open else "["
    hi_b = ")" if high_open else "]"
    interval = f"in {lo_b}{'-inf' if low is None else low}, {'inf' if high is None else high}{hi_b}"
    if np.isnan(val) or (finite and not np.isfinite(val)):
        raise param_error(name, f"{'finite and ' if finite else ''}{interval}", x)
    if low is not None and (val < low or (low_open and val == low)):
        raise param_error(name, interval, x)
    if high is not None and (val > high or (high_open and val == high)):
        raise param_error(name, interval, x)
    return val


def check_int(x, name: str, *, low=None, high=None) -> int:
    """Check an integer (not bool) within ``[low, high]``."""
    if isinstance(x, (bool, np.bool_)):
        raise param_error(name, "an integer", x, exc=TypeError)
    try:
        val = operator.index(x)
    except TypeError:
        raise param_error(name, "an integer", x, exc=TypeError) from None
    if low is not None and val < low:
        raise param_error(name, f"an integer >= {low}", x)
    if high is not None and val > high:
        raise param_error(name, f"an integer <= {high}", x)
    return int(val)


def check_choice(x, name: str, choices) -> str:
    """Check that ``x`` is one of ``choices``."""
    if not isinstance(x, str) or x not in choices:
        opts = ", ".join(repr(c) for c in choices)
        raise param_error(name, f"one of {opts}", x)
    return x


def symmetrised(M: np.ndarray, name: str, *, rtol=None) -> np.ndarray:
    """Check that a finite square matrix is symmetric to ``rtol`` (relative to its
    largest entry; default ``100 n eps``) and return ``(M + Mᵀ)/2`` without overflow."""
    n = M.shape[0]
    if rtol is None:
        rtol = 100 * n * np.finfo(float).eps
    scale = np.max(np.abs(M)) if M.size else 0.0
    if scale > 0 and np.max(np.abs(M / scale - M.T / scale)) > rtol:
        raise param_error(name, "a symmetric matrix", "<a non-symmetric matrix>")
    return 0.5 * M + 0.5 * M.T


def check_spd(P, name: str, n: int, *, rtol=None) -> np.ndarray:
    """Return ``P`` as an (n, n) symmetric positive definite float64 matrix.

    A scalar ``c`` means ``c * I``. Symmetry is checked to a relative
    tolerance (default ``100 * n * eps``) and positive definiteness by a
    Cholesky factorisation.
    """
    if np.ndim(P) == 0:
        c = check_scalar(P, name, low=0.0, low_open=True)
        return np.eye(n) * c
    M = symmetrised(as_float_array(P, name, shape=(n, n)), name, rtol=rtol)
    try:
        np.linalg.cholesky(M)
    except np.linalg.LinAlgError:
        raise param_error(name, "positive definite", "<a matrix that is not positive definite>") from None
    return M
