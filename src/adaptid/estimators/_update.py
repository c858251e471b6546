r"""``update``: one sample through the compiled code, in as few Python steps as possible.

An update is bit for bit a step of ``run`` and takes one of two paths:

* **the packed step** — when the algorithm has a narrow step entry
  (:mod:`adaptid._kernels.recursions._step`; RLS's fast forms) and it costs no compilation
  (compiled at install, in numba's cache, or by :func:`compile_update`): φ, y,
  λ, w, the threshold, ε and the skipped flag sit in one packed row
  (:attr:`StepArrays.R`), and the call unboxes two arrays instead of eleven;
* **the run of length 1** — otherwise: the algorithm's compiled ``run`` called on
  one-sample arrays of exactly the types ``run`` passes (:class:`StepArrays`), with
  the arguments (:class:`RunArgs`) kept between calls (:class:`RunCall`) and
  rebuilt only when the state array or the options change.

The functions taking ``self`` are methods of
:class:`~adaptid.estimators._engine.RecursiveEstimator` (bound there by name).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from .._kernels.recursions import _step
from ._inputs import F64, read_only

__all__ = ["StepArrays", "RunArgs", "RunCall", "update", "compile_update", "find_step",
           "step_kernel", "skipped_step"]


class RunArgs(NamedTuple):
    """The arguments of an algorithm's compiled ``run`` for a run of length 1, in the
    order of :class:`adaptid._kernels.Entries`'s common signature."""

    S: Any
    Phi: Any
    Y: Any
    lam: Any
    w: Any
    Th: Any
    E: Any
    skipped: Any
    Lk: Any
    St: Any
    opt: Any
    mat: Any
    ntag: Any
    ptag: Any


@dataclass(slots=True)
class RunCall:
    """The run of length 1 that ``update`` makes, kept between calls: its arguments
    (:class:`RunArgs` as a plain tuple, which ``*args`` passes on without a copy)
    and the objects they were built for, the state array ``S`` and the options
    ``opt`` and ``mat`` (rebuilt when one of them is another object). Slots: the
    three checks of each update cost what reading a tuple does."""

    S: Any = None
    opt: Any = None
    mat: Any = None
    args: tuple = ()


class StepArrays:
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
        self.Phi, self.Y = (read_only(a) for a in (self.phi, self.y))
        strided = np.lib.stride_tricks.as_strided
        self.lam = strided(self.lw[:1], (2,), (0,), writeable=False)
        self.w = strided(self.lw[1:], (2,), (0,), writeable=False)
        self.Th = np.empty((0, n, p))
        self.E = np.empty((1, p))
        self.skipped = np.zeros(1, dtype=np.bool_)
        self.Lk = np.empty(1 if reports else 0)
        self.reports = reports
        self.call = RunCall()  # the kernel's arguments, rebuilt when S or the options change
        self.D = None  # the window's pivots (a view of S), checked after each step
        # the packed sample of a narrow step entry (adaptid._kernels.recursions._step): φ, y, λ, w, ε,
        # the threshold, the skipped flag in one row R of W
        at = _step.layout(n, p)
        self.W = np.zeros((1, 1, at.width))
        self.R = R = self.W[0, 0]
        self.iy, self.ilam, self.iw, self.ie, self.ithr, self.isk = at[:6]
        R[at.lam] = R[at.w] = self.Rlam = self.Rw = 1.0  # λ and w, and their values
        self.Rphi, self.Ry, self.RE = R[:n], R[at.y:at.lam], R[at.e:at.threshold]
        self.step_ep = None  # the step entry's compiled function, when found for step_S
        self.step_S = None   # the state array step_ep was looked up for


def update(self, phi, y, *, weight=1.0, forgetting=None):
    r"""Process one sample; returns the a-priori error ε = y − φᵀθ.

    Parameters
    ----------
    phi : array_like, shape (n,)
    y : float or array_like, shape (p,)
    weight : float
        wₖ ≥ 0 (0: the sample only advances the forgetting; a weight below the
        smallest normal float, ~2.2e-308, counts as 0).
    forgetting : float, optional
        λₖ for this step (default: the estimator's ``forgetting``; RLS
        and the sliding window only).

    Returns
    -------
    float or ndarray, shape (p,)
        NaN for a sample skipped under ``nan_policy="skip"``.

    Raises
    ------
    RuntimeError
        If another ``update`` / ``run`` / ``run_batched`` on this estimator is
        running (another thread): an estimator is not thread-safe; give each
        thread its own (``est.copy()``).
    """
    if self._busy:
        raise self._in_use("update")
    self._busy = True
    try:
        if self._batch is not None:
            self._check_single("update")
        w = 1.0 if type(weight) is float and weight == 1.0 else self._weight(weight)
        lam = self._lam_fixed if forgetting is None else self._lam_step(forgetting)
        a = self._step
        S = self._S
        if S is not a.step_S:
            self._find_step(S)
        if a.step_ep is not None:
            # the narrow step entry (_kernels.recursions._step): two arrays to unbox, not eleven
            R = a.R
            if type(phi) is np.ndarray and phi.dtype is F64 and phi.shape == a.nshape:
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
        if type(phi) is np.ndarray and phi.dtype is F64 and phi.shape == a.nshape:
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
        call = a.call
        if call.S is not S or call.opt is not self._opt or call.mat is not self._mat:
            args = RunArgs(S, a.Phi, a.Y, a.lam, a.w, a.Th, a.E, a.skipped, a.Lk, None,
                           self._opt, self._mat, self._ntag, self._ptag)
            call = a.call = RunCall(S, self._opt, self._mat, tuple(args))
            a.D = self._ud_views(S)[1] if self._rebuilds else None
        if self._update_ep is not None:
            code = self._update_ep(*call.args)
        else:
            code = self._kern.run(*call.args)
            self._update_ep = _step.entry_point(self._kern.run, call.args)
        e = a.E.item(0)  # a Python float
        if e != e and a.skipped[0]:  # a skipped sample (its error is NaN)
            a.skipped[0] = False
            return self._skipped_step(a.phi[0], a.y[0], a.E[0], code)
        self.n_updates += 1
        if code != -1 or self._rebuilds:
            self._code_warnings(code, a.D)
        return e if self._single else a.E[0].copy()
    finally:
        self._busy = False


def compile_update(self) -> bool:
    """Compile the narrow step entry that makes :meth:`update` cheaper, if there is one.

    :meth:`update` is bit for bit a step of :meth:`run` either way. For
    :class:`RLS`'s fast forms (no forgetting strategy, finite prior) it has a
    compiled entry that takes one packed sample, cheaper per call than a
    run of length 1 through ``run``'s entry (``benchmarks/bench_update.py``). ``update`` uses
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


def find_step(self, S):
    """Look up the narrow step entry for the state array ``S`` (once per S and options).

    Used only if it costs no compilation (:func:`adaptid._kernels.recursions._step.entry_point`);
    else ``update`` goes through ``run``'s compiled code."""
    a = self._step
    a.step_S, a.step_ep = S, None
    step = self._step_kernel()
    if step is not None:
        a.step_ep = _step.entry_point(step, (S, a.W, self._ntag, self._ptag))


def step_kernel(self):
    """The algorithm's narrow step entry, or None (none, or one that ``update``'s
    packed sample cannot serve: the window's re-solves, reported forgetting)."""
    step = self._kern.step
    return None if self._rebuilds or self._reports else step


def skipped_step(self, phi, y, E, code):
    """The end of an ``update`` whose sample the kernel skipped (NaN or inf in it)."""
    self._nonfinite_step(phi, y)
    if code >= 0 and not self._rebuilds:
        self._warn_nonpositive(self.n_updates)
    return float("nan") if self._single else E.copy()
