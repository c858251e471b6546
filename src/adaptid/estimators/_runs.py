r"""The runs: ``run``, ``run_batched`` and ``run_segments``, and what they share.

Each validates its input (:mod:`._inputs`), allocates the kernel's outputs, calls
one compiled entry of the algorithm (:class:`adaptid._kernels.Entries`, or a
structure-of-arrays kernel of :mod:`adaptid._kernels.lanes._soa` for many streams),
restores the state and raises if ``nan_policy="raise"`` met a non-finite sample,
counts, warns (:mod:`._warn`) and returns its result.

The functions taking ``self`` are methods of
:class:`~adaptid.estimators._engine.RecursiveEstimator` (bound there by name).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .. import _kernels
from .._kernels.recursions._parallel import parallel_guard
from .._validation import param_error
from . import _inputs
from ._inputs import exclusive
from ._trajectory import Trajectory
from ._windowstats import check_stats, finish_stats, stats_rows

__all__ = ["run", "run_batched", "run_segments", "soa_entry", "raise_if_skipped", "backup",
           "prepare_batch", "finish", "alloc", "count"]


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

    Raises
    ------
    RuntimeError
        If another ``update`` / ``run`` / ``run_batched`` on this estimator is
        running (another thread): an estimator is not thread-safe; give each
        thread its own (``est.copy()``).
    """
    with exclusive(self, "run"):
        self._check_single("run")
        labels = _inputs.labels(Phi, y)
        want = check_stats(self, stats, has_constant)
        Phi, Y, w = self._run_arrays(Phi, y, weights, batched=False, precheck=False)
        lam = self._lam_run(forgetting, Phi.shape[:1])
        if want:
            self._before_stats()
        Th, E, skipped = self._alloc(Phi.shape[:1], store or want)
        Lk = np.empty(Phi.shape[0] if self._reports or self._diffuse else 0)
        St = stats_rows(self, Phi.shape[:1], want)
        backup = self._S.copy()  # restored if the kernel raises: a failed run changes nothing
        try:
            code = self._kern.run(self._S, Phi, Y, lam, w, Th, E, skipped, Lk, St, self._opt,
                                  self._mat, self._ntag, self._ptag)
        except BaseException:
            self._S = backup
            raise
        self._raise_if_skipped(skipped, Phi, Y, backup)
        self._count(skipped)
        self._report_codes(code, None)
        if want:
            labels["stats"] = finish_stats(self, St, Th, Phi, has_constant,
                                           Lk if self._diffuse else None).with_labels(
                                               labels.get("names"), labels.get("time"))
        traj = self._finish(Th, E, skipped, store, code if self._rebuilds else 0,
                            Lk if self._reports else None, Lk)
        return replace(traj, **labels) if labels else traj


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

    Raises
    ------
    RuntimeError
        If another ``update`` / ``run`` / ``run_batched`` on this estimator is
        running (another thread): an estimator is not thread-safe; give each
        thread its own (``est.copy()``).
    """
    with exclusive(self, "run_batched"):
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
        with parallel_guard():  # the workqueue layer: one parallel call at a time
            if soa is not None:  # same results; its signature has no statistics output
                soa(S, Phi, Y, lam, w, Th, E, skipped, Lk, self._opt, self._mat, codes,
                    self._ntag, self._ptag)
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
                            codes.sum() if self._rebuilds else 0,
                            Lk if self._reports else None, Lk)
        return replace(traj, stats=ws) if want else traj


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
    with parallel_guard():  # the workqueue layer: one parallel call at a time
        if soa is not None:
            soa(S0, Sout, Phi, Y, off, lam, w, Th, E, skipped, Lk, self._opt, self._mat, status,
                self._ntag, self._ptag)
        else:
            self._kern.run_segments(S0, Sout, Phi, Y, off, lam, w, Th, E, skipped, Lk, None,
                                    self._opt, self._mat, status, self._ntag, self._ptag)
    self._raise_if_skipped(skipped, Phi, Y, None)
    n_skip = np.empty(G, dtype=np.int64)
    sse = np.empty((G, E.shape[1]))
    with parallel_guard():
        segment_stats(E, skipped, off, n_skip, sse)
    n_used = np.diff(off) - n_skip
    P = self._covariance_of(Sout) if self.spec.covariance else None
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


def soa_entry(self, what, count, store=False):
    """The structure-of-arrays kernel (:mod:`adaptid._kernels.lanes._soa`, bit for bit the
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


def raise_if_skipped(self, skipped, Phi, Y, backup):
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


def backup(self):
    """A copy of the state to restore if the run raises (nan_policy="raise"), else None."""
    return self._S.copy() if self._nan_policy == "raise" else None


def prepare_batch(self, B):
    """The state rows (B, L) a batched run starts from (a copy)."""
    if self._batch is None:
        S = np.repeat(self._S[None, :], B, axis=0)
    elif self._batch == B:
        S = self._S.copy()
    else:
        raise param_error("Phi", f"of {self._batch} streams to continue this batched estimator",
                          f"<{B} streams>")
    return S


def finish(self, Th, E, skipped, store, n_rebuilds=0, lk=None, ident=None):
    """The :class:`Trajectory` of a run from the kernel's outputs."""
    if self._single:
        Th = Th[..., 0]
        E = E[..., 0]
    if not store:
        Th = Th[..., :0, :] if self._single else Th[..., :0, :, :]
    ident = ident != 0.0 if self._diffuse else None
    return Trajectory(theta=Th, error=E, skipped=skipped, n_rebuilds=int(n_rebuilds),
                      forgetting=lk, identified=ident)


def alloc(self, shape_N, store):
    """The kernel's outputs Th, E, skipped for samples of shape ``shape_N``."""
    n, p = self.n_params, self.n_outputs
    N = shape_N[-1]
    lead = shape_N[:-1]
    Th = np.empty(lead + ((N if store else 0), n, p))
    E = np.empty(shape_N + (p,))
    skipped = np.zeros(shape_N, dtype=np.bool_)
    return Th, E, skipped


def count(self, skipped):
    """Single stream: samples used and skipped. Batched: time steps, and all skips."""
    k = int(np.count_nonzero(skipped))
    self.n_skipped += k
    self.n_updates += skipped.shape[-1] if skipped.ndim == 2 else skipped.size - k
