r"""The engine's checks of its inputs: samples, weights, forgetting, pandas labels.

Each function taking ``self`` is a method of
:class:`~adaptid.estimators._engine.RecursiveEstimator` (bound there by name);
the others are plain helpers. Every check raises ``ValueError`` naming the
argument (:func:`adaptid._validation.param_error`).
"""

from __future__ import annotations

import numpy as np

from .._validation import as_float_array, check_scalar, param_error

__all__ = ["NAN_POLICIES", "F64", "labels", "strided", "read_only", "check_phi", "check_y",
           "check_weight", "nonfinite_step", "run_arrays", "per_sample", "in_use", "exclusive"]

NAN_POLICIES = ("raise", "skip")
#: numpy's float64 dtype: ``update`` takes a float64 φ as it is when its dtype is this
#: object (native byte order), and converts anything else.
F64 = np.dtype(np.float64)


def labels(Phi, y):
    """Parameter names and time stamps of pandas input (DataFrame columns, index)."""
    out = {}
    columns = getattr(Phi, "columns", None)
    if columns is not None and getattr(Phi, "ndim", 0) == 2:
        out["names"] = tuple(str(c) for c in columns)
    index = getattr(Phi, "index", None)
    if index is None:
        index = getattr(y, "index", None)
    if index is not None and not _is_default_index(index):
        out["time"] = np.asarray(index)
    return out


def _is_default_index(index):
    """A RangeIndex 0..N-1 carries no time."""
    start, step = getattr(index, "start", None), getattr(index, "step", None)
    return start == 0 and step == 1


def strided(arr):
    """``arr`` (read-only, float64, shape (..., N)) with a non-contiguous layout
    (numba's 'A', the type of a broadcast scalar), so that λ and w compile one
    signature whether they are scalars or per-sample arrays, and whatever N.

    A contiguous array is copied into every other element of a new buffer. numpy
    flags every array of at most one element contiguous (a broadcast scalar
    too), so for N < 2 the copy has two samples along its last axis, the second
    a repeat of the first (or 1.0 for N = 0): the kernels read the first N."""
    if not (arr.flags.c_contiguous or arr.flags.f_contiguous):
        return arr
    N = arr.shape[-1]
    out = np.empty(arr.shape[:-1] + (max(N, 2), 2))[..., 0]
    if N >= 2:
        out[...] = arr
    else:
        out[...] = arr if N == 1 else 1.0
    out.flags.writeable = False
    return out


def read_only(a):
    """A read-only view of ``a``."""
    v = a.view()
    v.flags.writeable = False
    return v


def check_phi(self, phi):
    """φ of ``update`` as a float64 array of shape (n,) (itself when it is one)."""
    n = self.n_params
    if type(phi) is np.ndarray and phi.dtype == np.float64 and phi.shape == (n,) \
            and phi.flags.c_contiguous:
        return phi
    return as_float_array(phi, "phi", shape=(n,), finite=False)


def check_y(self, y):
    """y of ``update`` as a float64 array of shape (p,) (one output: a reused buffer)."""
    p = self.n_outputs
    if self._single:
        if type(y) is float or type(y) is np.float64:
            self._ybuf[0] = y
            return self._ybuf
        arr = as_float_array(y, "y", ndim=(0, 1), finite=False)
        if arr.size != 1:
            raise param_error("y", "a scalar for a single-output estimator", f"<shape {arr.shape}>")
        self._ybuf[0] = arr.reshape(())
        return self._ybuf
    return as_float_array(y, "y", shape=(p,), finite=False)


#: the smallest normal float64: a weight below it (subnormal) is taken as 0; the
#: kernels' r = λ/w would overflow (U-D, Kalman, window: NaN and a windup warning)
TINY = float(np.finfo(np.float64).tiny)


def check_weight(weight):
    """The weight w ≥ 0 of ``update`` as a float (below the smallest normal float: 0)."""
    if weight == 1.0 and type(weight) in (float, int):
        return 1.0
    w = check_scalar(weight, "weight", low=0.0)
    return 0.0 if w < TINY else w


class exclusive:
    """``with exclusive(est, "run"):`` — the in-use flag of :func:`in_use` around a call.

    ``update`` sets the flag inline instead: a context manager costs about a
    quarter of an ``update`` at small n.
    """

    __slots__ = ("est", "what")

    def __init__(self, est, what):
        self.est, self.what = est, what

    def __enter__(self):
        if self.est._busy:
            raise in_use(self.est, self.what)
        self.est._busy = True

    def __exit__(self, *exc):
        self.est._busy = False


def in_use(self, what):
    """The error of a call made while another call on the same estimator runs.

    An estimator is not thread-safe: ``update``, ``run`` and ``run_batched``
    change its state in place (the kernels run without the GIL). Each sets an
    in-use flag for its duration and a call that finds it set raises this
    instead of racing (a flag rather than a lock: a non-blocking
    ``Lock.acquire`` cost 5-10 % of an ``update`` at n = 2, the flag about 1 %).
    The check and the set are two steps, so two calls starting within the same
    few bytecodes can both pass: the flag detects concurrent use, it does not
    make an estimator safe to share. One estimator per thread (``est.copy()``).
    """
    return RuntimeError(
        f"{type(self).__name__}.{what}() was called while another call on the same "
        f"{type(self).__name__} was running (from another thread?): an estimator is not "
        "thread-safe; give each thread its own (est.copy())")


def nonfinite_step(self, phi, y):
    """An ``update`` whose sample has NaN or inf: raise, or count it as skipped."""
    if self.nan_policy == "raise":
        arg = "phi" if not np.isfinite(phi).all() else "y"
        raise param_error(arg, "finite (no NaN or inf) with nan_policy='raise'",
                          "<a non-finite value>")
    self.n_skipped += 1


def run_arrays(self, Phi, y, weights, batched, precheck=True):
    """Validate Phi, y, weights of run / run_batched; returns (Phi, Y, w)."""
    n, p = self.n_params, self.n_outputs
    lead = 2 if batched else 1
    Phi = as_float_array(Phi, "Phi", ndim=lead + 1, finite=False)
    if Phi.shape[-1] != n:
        raise param_error("Phi", f"of shape ({'B, ' if batched else ''}N, {n}) for n_params={n}",
                          f"<shape {Phi.shape}>")
    shape_N = Phi.shape[:-1]
    Y = as_float_array(y, "y", ndim=(lead, lead + 1), finite=False)
    if Y.ndim == lead:
        if not self._single and p != 1:
            raise param_error("y", f"of shape {shape_N + (p,)} for n_outputs={p}",
                              f"<shape {Y.shape}>")
        Y = Y.reshape(Y.shape + (1,))
    elif self._single and Y.shape[-1] != 1:  # (N, 1) is one output, as lstsq and the models take it
        raise param_error("y", f"of shape {shape_N} or {shape_N + (1,)} (single output; "
                          "construct with n_outputs=p for several outputs)", f"<shape {Y.shape}>")
    if Y.shape != shape_N + (p,):
        want = shape_N if self._single else shape_N + (p,)
        raise param_error("y", f"of shape {want} to match Phi", f"<shape {Y.shape[:lead] if self._single else Y.shape}>")
    if precheck and self.nan_policy == "raise":
        for name, arr in (("Phi", Phi), ("y", Y)):
            if not np.isfinite(arr).all():
                idx = np.argwhere(~np.isfinite(arr))[0]
                raise param_error(name, "finite (no NaN or inf) with nan_policy='raise'",
                                  f"<a non-finite value at sample {tuple(int(i) for i in idx[:lead])}>")
    w = self._per_sample(weights, "weights", shape_N, low=0.0, tiny_zero=True)
    # read-only views: the kernels see one array type whatever the caller
    # passes (a writeable and a read-only array would compile twice)
    Phi, Y = Phi.view(), Y.view()
    Phi.flags.writeable = False
    Y.flags.writeable = False
    return Phi, Y, w


def per_sample(value, name, shape_N, *, low=None, high=None, low_open=False, default=1.0,
               tiny_zero=False):
    """A scalar or per-sample array as a read-only array of shape shape_N.

    With ``tiny_zero`` (the weights), values below the smallest normal float
    (subnormal) become 0: they behave as zero weights.

    A scalar is broadcast (no copy). A per-sample array is given the same
    numba type as a broadcast scalar (strided layout 'A', read-only), copied
    if it is contiguous, so that a kernel compiles one signature whether λ or
    the weights are given per sample or not (each signature is seconds of
    compile time)."""
    if value is None:
        value = default
    if np.ndim(value) == 0:
        v = check_scalar(value, name, low=low, high=high, low_open=low_open)
        if tiny_zero and v < TINY:
            v = 0.0
        return strided(np.broadcast_to(np.float64(v), shape_N))
    arr = as_float_array(value, name)
    try:
        arr = np.broadcast_to(arr, shape_N)
    except ValueError:
        raise param_error(name, f"a scalar or an array broadcastable to {shape_N}",
                          f"<shape {arr.shape}>") from None
    if (low is not None and (arr < low).any()) or (low_open and (arr == low).any()) or \
            (high is not None and (arr > high).any()):
        lo = "(" if low_open else "["
        raise param_error(name, f"in {lo}{low}, {high if high is not None else 'inf'}]",
                          "<values outside that range>")
    if tiny_zero and (arr < TINY).any():
        arr = np.where(arr < TINY, 0.0, arr)
    return strided(arr)
