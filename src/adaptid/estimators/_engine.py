r"""The engine every recursive estimator runs on.

One base class implements, once, what all recursive estimators share:
``update``, ``run``, ``run_batched``, ``run_segments``, ``predict``, the state
round trip (``get_state`` / ``from_state`` / state files), the NaN policy,
restoring the state when a call fails, and the numerical warnings. An
algorithm (:class:`~adaptid.RLS`, :class:`~adaptid.SlidingWindowRLS`,
:class:`~adaptid.KalmanRLS`) declares only

* its compiled entry points (:class:`adaptid._kernels.Entries`, one common
  signature) through :meth:`RecursiveEstimator._entries`,
* its options: the ``opt`` vector and ``mat`` matrix the kernels read
  (:meth:`_kernel_options`), the per-sample forgetting (:meth:`_lam_step`,
  :meth:`_lam_run`) and the dict of :meth:`_options`,
* its state layout (:meth:`_state_length`, :meth:`_fill_initial`,
  :meth:`_check_state`) and what the kernel's return code means
  (``_code_is_rebuilds``),
* whether it computes windowed statistics (``_supports_stats``; the window
  sums its own buffer, ``_stats_from_buffer``; see :mod:`._windowstats`),
* whether its state holds a covariance (``_has_covariance``): the gradient
  estimators (:class:`~adaptid.LMS`, :class:`~adaptid.NLMS`) keep only θ, have
  no prior covariance ``P0``, no ``P``, no ``excitation`` and no windup watch.
"""

from __future__ import annotations

import copy as _copy
from dataclasses import replace as _dataclass_replace
import warnings

import numpy as np

from .. import _kernels
from .._kernels.recursions import _step
from .._exceptions import CovarianceWindupWarning, DefinitenessLossWarning
from .._validation import (
    as_float_array,
    check_choice,
    check_int,
    check_scalar,
    check_spd,
    param_error,
)
from ._factor import P_from_ud, ud_from_P
from ._hooks import upward as _upward
from ._statefile import FORMAT
from ._trajectory import Trajectory
from ._windowstats import check_stats, finish_stats, stats_rows

__all__ = ["RecursiveEstimator"]


def _labels(Phi, y):
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

_NAN_POLICIES = ("raise", "skip")
#: numpy's float64 dtype: ``update`` takes a float64 φ as it is when its dtype is this
#: object (native byte order), and converts anything else.
_F64 = np.dtype(np.float64)


class _StepArrays:
    """One-sample arrays of exactly the numba types :meth:`RecursiveEstimator.run`
    passes its kernel (read-only C arrays for Φ and y, read-only strided views for
    λ and w, as ``np.broadcast_to`` gives), so that ``update`` reuses that compiled
    ``run``. The writeable bases ``phi``, ``y``, ``lw`` are filled per step."""

    def __init__(self, n, p, reports):
        self.phi = np.zeros((1, n))
        self.phi1 = self.phi[0]  # filled with ``phi1[...] = φ`` (half the time of ``phi[0] = φ``)
        self.y = np.zeros((1, p))
        self.lw = np.ones(2)
        self.lam_now = self.w_now = 1.0  # the values in lw
        self.nshape = (n,)
        self.Phi, self.Y = (_read_only(a) for a in (self.phi, self.y))
        strided = np.lib.stride_tricks.as_strided
        self.lam = strided(self.lw[:1], (2,), (0,), writeable=False)
        self.w = strided(self.lw[1:], (2,), (0,), writeable=False)
        self.Th = np.empty((0, n, p))
        self.E = np.empty((1, p))
        self.skipped = np.zeros(1, dtype=np.bool_)
        self.Lk = np.empty(1 if reports else 0)
        self.reports = reports
        self.args = (None,) * 14  # the kernel's arguments, rebuilt when S or the options change
        self.D = None  # the window's pivots (a view of S), checked after each step
        # the packed sample of a narrow step entry (adaptid._kernels._step): φ, y, λ, w, ε,
        # the threshold, the skipped flag in one row R of W
        at = _step.layout(n, p)
        self.W = np.zeros((1, 1, at.width))
        self.R = R = self.W[0, 0]
        self.iy, self.ilam, self.iw, self.ie, self.ithr, self.isk = at[:6]
        R[at.lam] = R[at.w] = self.Rlam = self.Rw = 1.0  # λ and w, and their values
        self.Rphi, self.Ry, self.RE = R[:n], R[at.y:at.lam], R[at.e:at.threshold]
        self.step_ep = None  # the step entry's compiled function, when found for step_S
        self.step_S = None   # the state array step_ep was looked up for


def _strided(arr):
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


def _read_only(a):
    v = a.view()
    v.flags.writeable = False
    return v


class RecursiveEstimator:
    """Common engine; see :class:`~adaptid.RLS` and the other algorithms."""

    _kind = "base"
    #: the kernel's return code counts window re-solves (else: first bad sample or −1)
    _code_is_rebuilds = False
    #: the kernel reports the forgetting factor applied per sample (strategies)
    _reports_forgetting = False
    #: the state holds the U-D factors of a covariance P after θ (False: θ only)
    _has_covariance = True
    #: run(..., stats=True) is supported (see estimators/_windowstats.py)
    _supports_stats = False
    #: the kernel sums its own buffer for the statistics (else they continue row 0)
    _stats_from_buffer = False

    def _before_stats(self):
        """Called by a run with ``stats=True`` before its kernel (RLS: leave the
        square-root form for the U-D form, whose stream computes the statistics)."""

    def __init__(self, n_params, *, theta0=None, P0=1e4, nan_policy="raise",
                 n_outputs=None, windup_threshold=None):
        n = check_int(n_params, "n_params", low=1)
        self._nan_policy = check_choice(nan_policy, "nan_policy", _NAN_POLICIES)
        if n_outputs is not None:
            n_outputs = check_int(n_outputs, "n_outputs", low=1)
        if theta0 is None:
            p = n_outputs or 1
            th0 = np.zeros((n, p))
            single = n_outputs is None
        else:
            th0 = as_float_array(theta0, "theta0", ndim=(1, 2), copy=True)
            if th0.shape[0] != n:
                raise param_error("theta0", f"of length n_params={n}", f"<shape {th0.shape}>")
            single = th0.ndim == 1
            th0 = th0.reshape(n, -1)
            if n_outputs is not None and th0.shape[1] != n_outputs:
                raise param_error("theta0", f"of shape ({n}, {n_outputs}) for n_outputs={n_outputs}",
                                  f"<shape {th0.shape}>")
        self.n_params = n
        self.n_outputs = th0.shape[1]
        self._single = single
        self.theta0 = th0
        self._diffuse = False
        if not self._has_covariance:
            self.P0 = None
            windup_threshold = np.inf  # nothing to wind up
        elif isinstance(P0, str):
            self._check_diffuse(P0, th0)
            self._diffuse = True
            self.P0 = "diffuse"
            self._U0, self._D0 = np.eye(n), np.ones(n)  # placeholders until identified
        else:
            self.P0 = check_spd(P0, "P0", n)
            self._U0, self._D0 = ud_from_P(self.P0)
        if windup_threshold is None:
            scale = 0.0 if self._diffuse else float(np.max(np.diag(self.P0)))
            Q = getattr(self, "process_cov", None)
            if Q is not None:
                scale = max(scale, float(np.max(np.diag(Q))))
            windup_threshold = 1e6 * scale if scale > 0 else np.inf
        self._windup_threshold = check_scalar(windup_threshold, "windup_threshold", low=0.0,
                                              low_open=True, finite=False)
        self._ybuf = np.empty(1)
        self._step = _StepArrays(n, self.n_outputs, self._reports_forgetting or self._diffuse)
        self._ntag, self._ptag = _kernels.tags(n, self.n_outputs)
        self._sync_options()
        self.reset()

    def _check_diffuse(self, P0, th0):
        if P0 != "diffuse":
            raise param_error("P0", "a positive scalar, a symmetric positive definite (n, n) "
                              "matrix or 'diffuse'", P0)
        if np.any(th0 != 0.0):
            raise param_error("theta0", "None (zeros) with P0='diffuse' (a diffuse prior has "
                              "no mean)", "<nonzero values>")

    @property
    def diffuse(self) -> bool:
        """True for an exact diffuse start (``P0="diffuse"``)."""
        return self._diffuse

    def _diffuse_tail(self) -> int:
        """Length of the diffuse part at the end of the state vector (0 unless diffuse)."""
        return 0

    def _fill_diffuse(self, T):
        """Initial diffuse tail (zeros: not identified, no information)."""

    def _identified_of(self, S):
        if not self._diffuse:
            return np.ones(S.shape[:-1], dtype=bool)
        return S[..., S.shape[-1] - self._diffuse_tail()] != 0.0

    @property
    def identified(self):
        r"""Whether the data determine θ (bool; (B,) after ``run_batched``).

        Always True with a finite prior ``P0``. With ``P0="diffuse"`` False
        until the (weighted, forgotten or windowed) information matrix
        :math:`\Phi^TW\Phi` has full numerical rank — θ is then the
        minimum-norm least-squares solution (RLS, window) or the diffuse
        Kalman filter's estimate, ``P`` is inf and :meth:`predict` NaN.
        """
        ident = self._identified_of(self._S)
        return bool(ident) if self._batch is None else ident

    # ------------------------------------------------ what an algorithm declares
    def _entries(self):
        """The compiled entry points (:class:`adaptid._kernels.Entries`)."""
        raise NotImplementedError

    def _kernel_options(self):
        """(opt, mat): the float64 options vector (opt[0] the windup threshold) and matrix."""
        return np.array([self._windup_threshold]), np.zeros((1, 1))

    def _lam_step(self, forgetting):
        if forgetting is not None:
            raise param_error("forgetting", f"None for {type(self).__name__} (it has no "
                              "forgetting factor)", forgetting)
        return 1.0

    def _lam_run(self, forgetting, shape_N):
        self._lam_step(forgetting)
        return _strided(np.broadcast_to(np.float64(1.0), shape_N))

    def _sync_options(self):
        self._update_ep = None
        self._lam_fixed = self._lam_step(None)
        self._opt, self._mat = self._kernel_options()
        self._kern = self._entries()
        self._reports = self._reports_forgetting
        a = self._step
        a.step_ep = a.step_S = None  # looked up again by the next update
        a.R[a.ithr] = self._opt[0]

    @property
    def nan_policy(self) -> str:
        """What a sample with NaN or inf does: "raise" or "skip"."""
        return self._nan_policy

    @nan_policy.setter
    def nan_policy(self, value):
        self._nan_policy = check_choice(value, "nan_policy", _NAN_POLICIES)
        self._sync_options()

    @property
    def windup_threshold(self) -> float:
        """A pivot of P = U D Uᵀ above it raises :class:`CovarianceWindupWarning`."""
        return self._windup_threshold

    @windup_threshold.setter
    def windup_threshold(self, value):
        self._windup_threshold = check_scalar(value, "windup_threshold", low=0.0,
                                              low_open=True, finite=False)
        self._sync_options()

    # ---------------------------------------------------------------- state
    def _state_length(self) -> int:
        n, p = self.n_params, self.n_outputs
        return n * p + n * n + n + self._diffuse_tail()

    def _fill_initial(self, S):
        n, p = self.n_params, self.n_outputs
        S[: n * p] = self.theta0.ravel()
        S[n * p: n * p + n * n] = self._U0.T.ravel()  # U by columns (see adaptid._kernels)
        S[n * p + n * n: n * p + n * n + n] = self._D0
        if self._diffuse:
            self._fill_diffuse(S[S.shape[0] - self._diffuse_tail():])

    def reset(self):
        """Return to the prior (θ₀, P₀) and forget all data and any batch axis."""
        self._S = np.zeros(self._state_length())
        self._fill_initial(self._S)
        self._batch = None
        self.n_updates = 0
        self.n_skipped = 0
        self._windup_warned = False
        self._stats_acc = None
        return self

    def _theta_view(self, S):
        n, p = self.n_params, self.n_outputs
        th = S[..., : n * p].reshape(S.shape[:-1] + (n, p))
        return th[..., 0] if self._single else th

    def _no_covariance(self, what):
        return AttributeError(
            f"{type(self).__name__} has no {what}: a gradient estimator keeps only θ, "
            "no covariance P (use RLS or KalmanRLS for one)")

    def _ud_views(self, S):
        if not self._has_covariance:
            raise self._no_covariance("covariance factor")
        n, p = self.n_params, self.n_outputs
        U = np.swapaxes(S[..., n * p: n * p + n * n].reshape(S.shape[:-1] + (n, n)), -1, -2)
        D = S[..., n * p + n * n: n * p + n * n + n]
        return U, D

    @property
    def theta(self) -> np.ndarray:
        """Current estimate, shape (n,) or (n, p); (B, n[, p]) after ``run_batched``."""
        return self._theta_view(self._S).copy()

    @property
    def P(self) -> np.ndarray:
        """Current covariance (n, n), or (B, n, n), formed from its U-D factors.

        AttributeError for the gradient estimators (LMS, NLMS), which have none.
        """
        if not self._has_covariance:
            raise self._no_covariance("covariance P")
        P = self._covariance_of(self._S)
        if self._diffuse:
            P[~self._identified_of(self._S)] = np.inf
        return P

    def _covariance_of(self, S):
        """P from state rows S (…, L): from the U-D factors (RLS overrides it per form)."""
        return P_from_ud(*self._ud_views(S))

    @property
    def batch_size(self):
        """B after ``run_batched``, else None."""
        return self._batch

    # ------------------------------------------------------------ validation
    def _check_single(self, what):
        if self._batch is not None:
            raise ValueError(
                f"{what} is for a single stream, but this estimator holds {self._batch} "
                "streams after run_batched; use run_batched, or reset() first")

    def _phi(self, phi):
        n = self.n_params
        if type(phi) is np.ndarray and phi.dtype == np.float64 and phi.shape == (n,) \
                and phi.flags.c_contiguous:
            return phi
        return as_float_array(phi, "phi", shape=(n,), finite=False)

    def _y(self, y):
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

    @staticmethod
    def _weight(weight):
        if weight == 1.0 and type(weight) in (float, int):
            return 1.0
        return check_scalar(weight, "weight", low=0.0)

    def _nonfinite_step(self, phi, y):
        if self.nan_policy == "raise":
            arg = "phi" if not np.isfinite(phi).all() else "y"
            raise param_error(arg, "finite (no NaN or inf) with nan_policy='raise'",
                              "<a non-finite value>")
        self.n_skipped += 1

    def _run_arrays(self, Phi, y, weights, batched, precheck=True):
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
        elif self._single:
            raise param_error("y", f"of shape {shape_N} (single output; construct with "
                              "n_outputs=p for several outputs)", f"<shape {Y.shape}>")
        if Y.shape != shape_N + (p,):
            want = shape_N if self._single else shape_N + (p,)
            raise param_error("y", f"of shape {want} to match Phi", f"<shape {Y.shape[:lead] if self._single else Y.shape}>")
        if precheck and self.nan_policy == "raise":
            for name, arr in (("Phi", Phi), ("y", Y)):
                if not np.isfinite(arr).all():
                    idx = np.argwhere(~np.isfinite(arr))[0]
                    raise param_error(name, "finite (no NaN or inf) with nan_policy='raise'",
                                      f"<a non-finite value at sample {tuple(int(i) for i in idx[:lead])}>")
        w = self._per_sample(weights, "weights", shape_N, low=0.0)
        # read-only views: the kernels see one array type whatever the caller
        # passes (a writeable and a read-only array would compile twice)
        Phi, Y = Phi.view(), Y.view()
        Phi.flags.writeable = False
        Y.flags.writeable = False
        return Phi, Y, w

    @staticmethod
    def _per_sample(value, name, shape_N, *, low=None, high=None, low_open=False, default=1.0):
        """A scalar or per-sample array as a read-only array of shape shape_N.

        A scalar is broadcast (no copy). A per-sample array is given the same
        numba type as a broadcast scalar (strided layout 'A', read-only), copied
        if it is contiguous, so that a kernel compiles one signature whether λ or
        the weights are given per sample or not (each signature is seconds of
        compile time)."""
        if value is None:
            value = default
        if np.ndim(value) == 0:
            v = check_scalar(value, name, low=low, high=high, low_open=low_open)
            return _strided(np.broadcast_to(np.float64(v), shape_N))
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
        return _strided(arr)

    def _raise_if_skipped(self, skipped, Phi, Y, backup):
        """nan_policy='raise' without a pre-pass over the data: the kernel skipped
        (and flagged) the non-finite samples; restore the state and raise."""
        if self.nan_policy != "raise" or not skipped.any():
            return
        if backup is not None:
            self._S = backup
        row = tuple(int(i) for i in np.argwhere(skipped)[0])
        name = "Phi" if not np.isfinite(Phi[row]).all() else "y"
        raise param_error(name, "finite (no NaN or inf) with nan_policy='raise'",
                          f"<a non-finite value at sample {row if len(row) > 1 else row[0]}>")

    def _backup(self):
        return self._S.copy() if self._nan_policy == "raise" else None

    def _prepare_batch(self, B):
        if self._batch is None:
            S = np.repeat(self._S[None, :], B, axis=0)
        elif self._batch == B:
            S = self._S.copy()
        else:
            raise param_error("Phi", f"of {self._batch} streams to continue this batched estimator",
                              f"<{B} streams>")
        return S

    def _finish(self, Th, E, skipped, store, n_rebuilds=0, lk=None, ident=None):
        if self._single:
            Th = Th[..., 0]
            E = E[..., 0]
        if not store:
            Th = Th[..., :0, :] if self._single else Th[..., :0, :, :]
        ident = ident != 0.0 if self._diffuse else None
        return Trajectory(theta=Th, error=E, skipped=skipped, n_rebuilds=int(n_rebuilds),
                          forgetting=lk, identified=ident)

    def _alloc(self, shape_N, store):
        n, p = self.n_params, self.n_outputs
        N = shape_N[-1]
        lead = shape_N[:-1]
        Th = np.empty(lead + ((N if store else 0), n, p))
        E = np.empty(shape_N + (p,))
        skipped = np.zeros(shape_N, dtype=np.bool_)
        return Th, E, skipped

    def _count(self, skipped):
        """Single stream: samples used and skipped. Batched: time steps, and all skips."""
        k = int(np.count_nonzero(skipped))
        self.n_skipped += k
        self.n_updates += skipped.shape[-1] if skipped.ndim == 2 else skipped.size - k

    def _warn_nonpositive(self, where):
        if getattr(self, "_windup_warned", False):
            return  # once per episode: reset() re-arms the warning
        self._windup_warned = True
        warnings.warn(
            f"{type(self).__name__}: covariance windup at sample {where}: a pivot of "
            f"P = U D Uᵀ passed windup_threshold={self.windup_threshold:.3g}, overflowed or "
            "lost positivity (forgetting with a direction not excited? see adaptid.forgetting)",
            CovarianceWindupWarning, stacklevel=3)

    def _warn_rebuild(self, count):
        warnings.warn(
            f"{type(self).__name__}: {count} removal(s) from the window would have lost "
            "positive definiteness; the window was re-solved exactly from its buffer "
            "(poorly excited window?)", DefinitenessLossWarning, stacklevel=4)

    def _check_pivots(self, D, where):
        """The window's kernel does not watch the pivots: after a run or a step the
        engine checks them all in (0, windup_threshold) (a NaN is not). D: 1-D."""
        thr = self._windup_threshold
        if not all(0.0 < d < thr for d in D.tolist()):
            self._warn_nonpositive(where)

    def _report_codes(self, codes, where):
        """Warnings for the kernel's return codes (one per stream or segment)."""
        codes = np.atleast_1d(codes)
        if self._code_is_rebuilds:
            if codes.sum():
                self._warn_rebuild(int(codes.sum()))
            self._check_pivots(self._ud_views(self._S)[1].ravel(), f"≤ {self.n_updates}")
        elif (codes >= 0).any():
            first = int(np.argmax(codes >= 0))
            self._warn_nonpositive(int(codes[first]) if where is None
                                   else f"{int(codes[first])} of {where} {first}")

    @property
    def excitation(self):
        r"""Smallest eigenvalue of the information matrix :math:`R = P^{-1}`.

        For RLS with forgetting R is the exponentially weighted information
        :math:`\sum_j \lambda^{k-j}w_j\varphi_j\varphi_j^T` plus the decayed
        prior; for the sliding window the information of the samples in the
        window plus the decayed prior. A value near zero (relative to the
        regressors' scale) means some direction is not excited: its
        parameter combination is not identifiable from the recent data.
        Float, or (B,) after ``run_batched``; 0 while a diffuse start
        (``P0="diffuse"``) is not identified. AttributeError for the
        gradient estimators (no P).
        """
        if not self._has_covariance:
            raise self._no_covariance("excitation (it needs the covariance P)")
        P = self.P
        ident = self._identified_of(self._S)
        ev = np.linalg.eigvalsh(np.where(ident[..., None, None], P, np.eye(self.n_params)))
        ex = np.where(ident, 1.0 / ev[..., -1], 0.0)  # not identified: a direction unexcited
        return ex if self._batch is not None else float(ex)

    # ------------------------------------------------------------ the runs
    def update(self, phi, y, *, weight=1.0, forgetting=None):
        r"""Process one sample; returns the a-priori error ε = y − φᵀθ.

        Parameters
        ----------
        phi : array_like, shape (n,)
        y : float or array_like, shape (p,)
        weight : float
            wₖ ≥ 0 (0: the sample only advances the forgetting).
        forgetting : float, optional
            λₖ for this step (default: the estimator's ``forgetting``; RLS
            and the sliding window only).

        Returns
        -------
        float or ndarray, shape (p,)
            NaN for a sample skipped under ``nan_policy="skip"``.
        """
        if self._batch is not None:
            self._check_single("update")
        w = 1.0 if type(weight) is float and weight == 1.0 else self._weight(weight)
        lam = self._lam_fixed if forgetting is None else self._lam_step(forgetting)
        a = self._step
        S = self._S
        if S is not a.step_S:
            self._find_step(S)
        if a.step_ep is not None:
            # the narrow step entry (adaptid._kernels._step): two arrays to unbox, not eleven
            R = a.R
            if type(phi) is np.ndarray and phi.dtype is _F64 and phi.shape == a.nshape:
                a.Rphi[...] = phi
            else:
                a.Rphi[...] = self._phi(phi)
            if self._single and (type(y) is float or type(y) is np.float64):
                R[a.iy] = y
            else:
                a.Ry[...] = self._y(y)
            if lam != a.Rlam:
                R[a.ilam] = a.Rlam = lam
            if w != a.Rw:
                R[a.iw] = a.Rw = w
            code = a.step_ep(S, a.W, self._ntag, self._ptag)
            e = R.item(a.ie)  # a Python float
            if e != e and R[a.isk]:  # a skipped sample (its error is NaN)
                R[a.isk] = 0.0
                return self._skipped_step(a.Rphi, a.Ry, a.RE, code)
            self.n_updates += 1
            if code != -1:  # the step kernels are RLS's: no window re-solves
                self._code_warnings(code, None)
            return e if self._single else a.RE.copy()
        # One step is a run of length 1 through the compiled ``run`` numba already has
        # for these argument types (those run() passes): nothing more to compile, and
        # bit for bit the arithmetic of run().
        if type(phi) is np.ndarray and phi.dtype is _F64 and phi.shape == a.nshape:
            a.phi1[...] = phi
        else:
            a.phi1[...] = self._phi(phi)
        if self._single and (type(y) is float or type(y) is np.float64):
            a.y[0, 0] = y
        else:
            a.y[0] = self._y(y)
        if lam != a.lam_now:
            a.lw[0] = a.lam_now = lam
        if w != a.w_now:
            a.lw[1] = a.w_now = w
        args = a.args
        if args[0] is not S or args[10] is not self._opt or args[11] is not self._mat:
            args = a.args = (S, a.Phi, a.Y, a.lam, a.w, a.Th, a.E, a.skipped, a.Lk, None,
                             self._opt, self._mat, self._ntag, self._ptag)
            a.D = self._ud_views(S)[1] if self._code_is_rebuilds else None
        if self._update_ep is not None:
            code = self._update_ep(*args)
        else:
            code = self._kern.run(*args)
            self._update_ep = _step.entry_point(self._kern.run, args)
        e = a.E.item(0)  # a Python float
        if e != e and a.skipped[0]:  # a skipped sample (its error is NaN)
            a.skipped[0] = False
            return self._skipped_step(a.phi[0], a.y[0], a.E[0], code)
        self.n_updates += 1
        if code != -1 or self._code_is_rebuilds:
            self._code_warnings(code, a.D)
        return e if self._single else a.E[0].copy()

    def _code_warnings(self, code, D):
        """The warnings of an update whose kernel returned ``code`` (not −1, or the window's)."""
        if self._code_is_rebuilds:  # the window: code counts re-solves; D is checked here
            if code:
                self._warn_rebuild(1)
            self._check_pivots(D, self.n_updates)
        elif code >= 0:
            self._warn_nonpositive(self.n_updates)
        elif code <= -2:  # a repaired covariance (RLS form="covariance")
            self._warn_rebuild(1)

    def compile_update(self) -> bool:
        """Compile the narrow step entry that makes :meth:`update` cheaper, if there is one.

        :meth:`update` is bit for bit a step of :meth:`run` either way. For
        :class:`RLS`'s fast forms (no forgetting strategy, finite prior) it has a
        compiled entry that takes one packed sample, about 0.5 µs less per call
        at n = 4 than a run of length 1 through ``run``'s entry. ``update`` uses
        it only when that costs no compilation: compiled at install (RLS's
        default form, n ≤ 16, one output), in numba's cache folder, or compiled
        by this method earlier (then it is cached on disk like every kernel).
        A compilation takes a few seconds.

        Returns
        -------
        bool
            True if the estimator has such an entry (it is compiled now), False
            if its updates always go through ``run``'s entry.
        """
        step = self._step_kernel()
        if step is None or self._batch is not None:
            return False
        a = self._step
        S = self._S.copy()  # a throwaway step: neither the state nor the sample changes
        W = a.W.copy()
        W[0, 0, :a.ie] = 0.0
        W[0, 0, a.ilam:a.iw + 1] = 1.0
        step(S, W, self._ntag, self._ptag)
        self._find_step(self._S)
        return a.step_ep is not None

    def _find_step(self, S):
        """Look up the narrow step entry for the state array ``S`` (once per S and options).

        Used only if it costs no compilation (:func:`adaptid._kernels._step.entry_point`);
        else ``update`` goes through ``run``'s compiled code."""
        a = self._step
        a.step_S, a.step_ep = S, None
        step = self._step_kernel()
        if step is not None:
            a.step_ep = _step.entry_point(step, (S, a.W, self._ntag, self._ptag))

    def _step_kernel(self):
        """The algorithm's narrow step entry, or None (none, or one that ``update``'s
        packed sample cannot serve: the window's re-solves, reported forgetting)."""
        step = self._kern.step
        return None if self._code_is_rebuilds or self._reports else step

    def _skipped_step(self, phi, y, E, code):
        """The end of an ``update`` whose sample the kernel skipped (NaN or inf in it)."""
        self._nonfinite_step(phi, y)
        if code >= 0 and not self._code_is_rebuilds:
            self._warn_nonpositive(self.n_updates)
        return float("nan") if self._single else E.copy()

    def run(self, Phi, y, *, weights=None, forgetting=None, store=True, stats=False,
            has_constant=None):
        r"""Process N samples in one compiled loop.

        Parameters
        ----------
        Phi : array_like, shape (N, n)
        y : array_like, shape (N,) or (N, p)
        weights : float or array_like, shape (N,), optional
            wₖ ≥ 0 (default 1).
        forgetting : float or array_like, shape (N,), optional
            λₖ ∈ (0, 1] (default: the estimator's ``forgetting``; RLS and the
            sliding window only).
        store : bool
            Keep the per-sample θ (``Trajectory.theta``); False saves memory.
        stats : bool
            Also compute, in the same compiled loop, the statistics of the
            data in the cost after every sample (the window, or all samples
            so far under forgetting): ``Trajectory.stats``, a
            :class:`~adaptid.WindowStats` (statsmodels ``RollingOLS`` /
            ``RollingWLS``). :class:`SlidingWindowRLS`, and :class:`RLS` with
            exponential forgetting; an RLS must have run all its samples
            since the prior with ``stats=True``.
        has_constant : bool, optional
            With ``stats``: whether the regressors hold a constant (centred
            R²); default: detected from Φ as statsmodels does.

        Returns
        -------
        Trajectory
            Bit-for-bit the result of N calls of :meth:`update`.
        """
        self._check_single("run")
        labels = _labels(Phi, y)
        want = check_stats(self, stats, has_constant)
        Phi, Y, w = self._run_arrays(Phi, y, weights, batched=False, precheck=False)
        lam = self._lam_run(forgetting, Phi.shape[:1])
        if want:
            self._before_stats()
        Th, E, skipped = self._alloc(Phi.shape[:1], store or want)
        Lk = np.empty(Phi.shape[0] if self._reports or self._diffuse else 0)
        St = stats_rows(self, Phi.shape[:1], want)
        backup = self._backup()
        code = self._kern.run(self._S, Phi, Y, lam, w, Th, E, skipped, Lk, St, self._opt,
                              self._mat, self._ntag, self._ptag)
        self._raise_if_skipped(skipped, Phi, Y, backup)
        self._count(skipped)
        self._report_codes(code, None)
        if want:
            labels["stats"] = finish_stats(self, St, Th, Phi, has_constant,
                                           Lk if self._diffuse else None)
        traj = self._finish(Th, E, skipped, store, code if self._code_is_rebuilds else 0,
                            Lk if self._reports else None, Lk)
        return _dataclass_replace(traj, **labels) if labels else traj

    def run_batched(self, Phi, y, *, weights=None, forgetting=None, store=True, stats=False,
                    has_constant=None):
        r"""Run B independent streams in one compiled, parallel call.

        Parameters
        ----------
        Phi : array_like, shape (B, N, n)
        y : array_like, shape (B, N) or (B, N, p)
        weights, forgetting : float or array broadcastable to (B, N), optional
        stats, has_constant
            As for :meth:`run` (the statistics with a leading axis B; the
            constant is detected over all streams).

        Returns
        -------
        Trajectory
            ``.theta`` (B, N, n), ``.error`` (B, N). Afterwards ``theta`` and
            ``P`` carry the leading axis B; each stream started from this
            estimator's state (or continues it, if already batched).
        """
        want = check_stats(self, stats, has_constant)
        Phi, Y, w = self._run_arrays(Phi, y, weights, batched=True, precheck=False)
        shape_N = Phi.shape[:2]
        lam = self._lam_run(forgetting, shape_N)
        if want:
            self._before_stats()
        St = stats_rows(self, shape_N, want)
        S = self._prepare_batch(shape_N[0])
        Th, E, skipped = self._alloc(shape_N, store or want)
        Lk = np.empty(shape_N if self._reports or self._diffuse else (shape_N[0], 0))
        codes = np.empty(shape_N[0], dtype=np.int64)
        soa = self._soa_entry("batched", shape_N[0], store or St is not None)
        if soa is not None:  # same results; its signature has no statistics output
            soa(S, Phi, Y, lam, w, Th, E, skipped, Lk, self._opt, self._mat, codes, self._ntag,
                self._ptag)
        else:
            self._kern.run_batched(S, Phi, Y, lam, w, Th, E, skipped, Lk, St, self._opt,
                                   self._mat, codes, self._ntag, self._ptag)
        self._raise_if_skipped(skipped, Phi, Y, None)  # S is a copy: nothing to restore
        self._S, self._batch = S, shape_N[0]
        self._count(skipped)
        self._report_codes(codes, "stream")
        ws = finish_stats(self, St, Th, Phi, has_constant, Lk if self._diffuse else None) \
            if want else None
        traj = self._finish(Th, E, skipped, store,
                            codes.sum() if self._code_is_rebuilds else 0,
                            Lk if self._reports else None, Lk)
        return _dataclass_replace(traj, stats=ws) if want else traj

    def run_segments(self, Phi, y, offsets, *, weights=None, store=False, stats=False):
        r"""Run G independent streams stored back to back, in one compiled, parallel call.

        Segment g is rows ``offsets[g]:offsets[g+1]`` of ``Phi`` and ``y``
        (streams of different lengths, e.g. the telemetry of G devices). Each
        segment starts from this estimator's prior (θ₀, P₀) with its options;
        the estimator itself is not changed. Segment g's result is bit for
        bit that of ``est.copy().reset().run(Phi[a:b], y[a:b])``.

        Parameters
        ----------
        Phi : array_like, shape (N_total, n)
        y : array_like, shape (N_total,) or (N_total, p)
        offsets : array_like of int, shape (G + 1,)
            Nondecreasing segment boundaries, ``offsets[0] = 0`` and
            ``offsets[-1] = N_total``; empty segments are allowed.
        weights : float or array_like, shape (N_total,), optional
        store : bool
            Also return the per-sample estimates (``theta_track``).
        stats : bool
            Not supported here (ValueError if True): use :meth:`run` per
            segment or :meth:`run_batched` for windowed statistics.

        Returns
        -------
        SegmentResult
            Final θ and P, sample counts, sums of squared a-priori errors per
            segment, and the per-sample errors.
        """
        from ._segments import SegmentResult, check_offsets, segment_stats
        if stats is not False:
            raise param_error("stats", "False for run_segments (windowed statistics: run or "
                              "run_batched)", stats)
        # nan_policy="raise": the kernels flag non-finite samples and the check
        # follows them (no pre-pass over the data); the estimator is not changed
        Phi, Y, w = self._run_arrays(Phi, y, weights, batched=False, precheck=False)
        N = Phi.shape[0]
        off = check_offsets(offsets, N)
        G = off.shape[0] - 1
        S0 = np.zeros(self._state_length())
        self._fill_initial(S0)
        Sout = np.empty((G, S0.shape[0]))
        Th, E, skipped = self._alloc((N,), store)
        lam = self._lam_run(None, Phi.shape[:1])
        Lk = np.empty(N if self._reports or self._diffuse else 0)
        status = np.empty(G, dtype=np.int64)
        soa = self._soa_entry("segments", G, store)
        if soa is not None:
            soa(S0, Sout, Phi, Y, off, lam, w, Th, E, skipped, Lk, self._opt, self._mat, status,
                self._ntag, self._ptag)
        else:
            self._kern.run_segments(S0, Sout, Phi, Y, off, lam, w, Th, E, skipped, Lk, None,
                                    self._opt, self._mat, status, self._ntag, self._ptag)
        self._raise_if_skipped(skipped, Phi, Y, None)
        n_skip = np.empty(G, dtype=np.int64)
        sse = np.empty((G, E.shape[1]))
        segment_stats(E, skipped, off, n_skip, sse)
        n_used = np.diff(off) - n_skip
        P = self._covariance_of(Sout) if self._has_covariance else None
        if self._diffuse:
            P[~self._identified_of(Sout)] = np.inf
        theta = self._theta_view(Sout).copy()
        if self._single:
            E, sse = E[:, 0], sse[:, 0]
            Th = Th[..., 0] if store else None
        elif not store:
            Th = None
        self._warn_segments(status)
        return SegmentResult(theta=theta, P=P, n_samples=n_used,
                             n_skipped=n_skip, sse=sse, error=E, skipped=skipped,
                             theta_track=Th, offsets=off, status=status)

    def _soa_entry(self, what, count, store=False):
        """The structure-of-arrays kernel (:mod:`adaptid._kernels._soa`, bit for bit the
        same results, several streams per vector instruction) when it pays: RLS in U-D
        form (its kernels, no strategy; n <= ``MAX_N``) or in covariance form (n <=
        ``COV_MAX_N``), one output, n specialised, at least ``MIN_STREAMS`` streams or
        segments, θ not stored per sample (its scatter made the lane kernels slower than
        the scalar ones). Else None (the algorithm's own)."""
        if store or self._ptag != (0,) or not isinstance(self._ntag, tuple):
            return None
        from .._kernels.lanes import _soa
        if count < _soa.MIN_STREAMS:
            return None
        if self._kern is _kernels.RLS and self.n_params <= _soa.MAX_N:
            return _soa.rls_soa_batched if what == "batched" else _soa.rls_soa_segments
        if self._kern is _kernels.COVARIANCE and self.n_params <= _soa.COV_MAX_N:
            return _soa.cov_soa_batched if what == "batched" else _soa.cov_soa_segments
        return None

    def _warn_segments(self, status):
        if self._code_is_rebuilds:
            if status.sum():
                self._warn_rebuild(int(status.sum()))
            return
        bad = np.flatnonzero(status >= 0)
        if bad.size:
            warnings.warn(
                f"{type(self).__name__}: in {bad.size} segment(s) (first: segment {int(bad[0])}, "
                f"sample {int(status[bad[0]])}) the covariance factor lost positivity or "
                "overflowed (covariance windup)", CovarianceWindupWarning, stacklevel=3)

    # ------------------------------------------------------------ prediction
    def predict(self, phi):
        r"""Predicted output :math:`\hat y = \varphi^T\hat\theta`.

        Parameters
        ----------
        phi : array_like, shape (n,) or (N, n); (B, n) or (B, N, n) when batched

        Returns
        -------
        float or ndarray
            Shape (), (N,) [or with a trailing p axis for several outputs].
        """
        n = self.n_params
        theta = self._theta_view(self._S)
        if self._diffuse and not self._identified_of(self._S).all():
            theta = np.where(self._identified_of(self._S).reshape(
                self._S.shape[:-1] + (1,) * (theta.ndim - self._S.ndim + 1)), theta, np.nan)
        if self._batch is None:
            phi = as_float_array(phi, "phi", ndim=(1, 2))
            if phi.shape[-1] != n:
                raise param_error("phi", f"of shape (n,) or (N, n) with n={n}", f"<shape {phi.shape}>")
            with np.errstate(over="ignore", invalid="ignore"):  # huge φ: inf, as NumPy gives
                out = phi @ theta
            return float(out) if out.ndim == 0 else out
        phi = as_float_array(phi, "phi", ndim=(2, 3))
        if phi.shape[0] != self._batch or phi.shape[-1] != n:
            raise param_error("phi", f"of shape (B, n) or (B, N, n) with B={self._batch}, n={n}",
                              f"<shape {phi.shape}>")
        with np.errstate(over="ignore", invalid="ignore"):
            if self._single:
                return np.einsum("b...i,bi->b...", phi, theta)
            return np.einsum("b...i,bij->b...j", phi, theta)

    # ------------------------------------------------------- state round trip
    def _options(self) -> dict:
        return {"nan_policy": self.nan_policy, "windup_threshold": self.windup_threshold}

    def get_state(self) -> dict:
        """Everything needed to resume exactly: options, prior and the state vector.

        The dict holds only plain Python values and float64 arrays, so it can
        be stored as JSON + arrays (see :meth:`save_state`).
        """
        return {
            "estimator": type(self).__name__,
            "format": FORMAT,
            "n_params": self.n_params,
            "n_outputs": self.n_outputs,
            "single_output": self._single,
            "options": dict(self._options(), **({"P0": "diffuse"} if self._diffuse else {})),
            "theta0": self.theta0.copy(),
            "P0": None if self.P0 is None or self._diffuse else self.P0.copy(),
            "state": self._S.copy(),
            "batch": self._batch,
            "n_updates": self.n_updates,
            "n_skipped": self.n_skipped,
        }

    def kernel_settings(self):
        """The algorithm and current state in the form a compiled recursion takes.

        A public hook for recursions built on the estimators (the models'
        pseudo-linear regressions): they read the estimator's algorithm and
        state here instead of its private fields.

        Returns
        -------
        KernelSettings
            Copies of θ (n, p) and the U-D factors of P, and the options:
            ``method`` ("rls", "window", "kalman"), ``forgetting`` (constant λ,
            1.0 under a strategy), ``strategy_mode`` (−1: none or exponential
            without ``P_max``), ``strategy_params``, ``P_max`` (inf: none),
            ``window`` (0: none), ``process_cov``, ``noise_var``;
            ``diffuse_state``: None with a finite prior, else a copy of the
            diffuse tail of the state (``adaptid._kernels._diffuse``).
        """
        from ._settings import KernelSettings
        self._check_single("kernel_settings")
        n, p = self.n_params, self.n_outputs
        U, D = self._ud_views(self._S)
        theta = self._S[: n * p].reshape(n, p).copy()
        tail = self._S[self._S.shape[0] - self._diffuse_tail():].copy() if self._diffuse \
            else None
        return KernelSettings.of(self, theta, np.array(U), np.array(D), tail)

    @classmethod
    def from_state(cls, state: dict):
        """Rebuild an estimator from :meth:`get_state`'s dict (exact round trip)."""
        if not isinstance(state, dict):
            raise param_error("state", "a dict from get_state()", state, exc=TypeError)
        from ._statefile import estimator_from_state
        est = estimator_from_state(state)
        if not isinstance(est, cls):
            raise param_error("state", f"the state of a {cls.__name__}",
                              f"<the state of a {type(est).__name__}>")
        return est

    def _set_state(self, S, batch, n_updates, n_skipped):
        expect = (self._state_length(),) if batch is None else (batch, self._state_length())
        S = as_float_array(S, "state['state']", shape=expect, copy=True, finite=False)
        self._check_state(S.reshape(-1, S.shape[-1]))
        self._S = S
        self._batch = batch
        self._stats_acc = None
        self.n_updates = int(n_updates)
        self.n_skipped = int(n_skipped)

    def _check_state(self, S):
        """Refuse a state vector the kernels cannot run on safely (rows of S).

        RLS and Kalman states hold no indices: any float values are safe to
        run on (a wound-up state stays wound up). The window's are checked.
        """

    def save_state(self, path):
        """Write the state to ``path`` (versioned, checksummed ``.npz``; never pickle).

        The file is written to a temporary name and renamed, so a crash
        never leaves a half-written state file. See :func:`adaptid.load_state`.
        """
        from ._statefile import save_state
        save_state(self, path)

    @classmethod
    def load_state(cls, path):
        """Read a file written by :meth:`save_state`; raises StateFileError if it is damaged."""
        from ._statefile import load_state
        est = load_state(path)
        if not isinstance(est, cls):
            from .._exceptions import StateFileError
            raise StateFileError(f"{path}: holds the state of a {type(est).__name__}, "
                                 f"not a {cls.__name__}")
        return est

    def to_c(self, directory, *, name="rls", dtype="float64"):
        r"""Write ``NAME.h`` and ``NAME.c``: this estimator's recursion in C99, from its state.

        The generated update continues exactly where this estimator stands
        (bit for bit with ``-DNAME_USE_FMA`` on a CPU with FMA). See
        :func:`adaptid.codegen.to_c` for the generated interface, the
        supported options and the verification, and ``docs/embedded.md``.

        Parameters
        ----------
        directory : str or os.PathLike
        name : str
            C identifier: file names and the prefix of every symbol.
        dtype : {"float64", "float32"}

        Returns
        -------
        tuple of pathlib.Path
            The header and the source file.
        """
        return _upward("adaptid.codegen").to_c(self, directory, name=name, dtype=dtype)

    def copy(self):
        """An independent deep copy."""
        return _copy.deepcopy(self)

    def __getstate__(self):
        return self.get_state()

    def __setstate__(self, state):
        from ._statefile import estimator_from_state
        other = estimator_from_state(state)
        self.__dict__.update(other.__dict__)

    def __repr__(self):
        opts = ", ".join(f"{k}={v!r}" for k, v in self._options().items() if k != "nan_policy")
        batch = f", batch={self._batch}" if self._batch is not None else ""
        return (f"{type(self).__name__}(n_params={self.n_params}"
                f"{', n_outputs=' + str(self.n_outputs) if not self._single else ''}"
                f"{', ' + opts if opts else ''}, n_updates={self.n_updates}{batch})")



class _ForgettingMixin:
    """Validation of forgetting (λ ∈ (0, 1], scalar or per sample)."""

    @staticmethod
    def _check_lambda(value, name="forgetting"):
        return check_scalar(value, name, low=0.0, high=1.0, low_open=True)

    def _lam_step(self, forgetting):
        if forgetting is None:
            return self._lam if self._lam is not None else 1.0
        self._no_strategy("forgetting")
        return self._check_lambda(forgetting)

    def _lam_run(self, forgetting, shape_N):
        if forgetting is None:
            forgetting = self._lam if self._lam is not None else 1.0
        else:
            self._no_strategy("forgetting")
        return self._per_sample(forgetting, "forgetting", shape_N, low=0.0, high=1.0, low_open=True)

    def _no_strategy(self, name):
        if getattr(self, "_strategy", None) is not None:
            raise param_error(name, f"None (per-sample λ needs exponential forgetting; this "
                              f"estimator uses {type(self._strategy).__name__})", "<a value>")

    def _forgetting_option(self):
        f = self.forgetting
        return f if isinstance(f, float) else f.to_dict()
