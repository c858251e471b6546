"""The numerical warnings of the engine's runs, from the kernels' return codes.

Each function is a method of :class:`~adaptid.estimators._engine.RecursiveEstimator`
(bound there by name, so that the ``stacklevel`` of each warning counts the same
frames as a method's, and an algorithm can override it: the gradient estimators
warn of divergence, RLS's covariance form of repairs).
"""

from __future__ import annotations

import warnings

import numpy as np

from .._exceptions import CovarianceWindupWarning, DefinitenessLossWarning

__all__ = ["warn_nonpositive", "warn_rebuild", "check_pivots", "report_codes",
           "code_warnings", "warn_segments"]


def warn_nonpositive(self, where):
    """:class:`CovarianceWindupWarning` at sample ``where`` (once until ``reset``)."""
    if getattr(self, "_windup_warned", False):
        return  # once per episode: reset() re-arms the warning
    self._windup_warned = True
    warnings.warn(
        f"{type(self).__name__}: covariance windup at sample {where}: a pivot of "
        f"P = U D Uᵀ passed windup_threshold={self.windup_threshold:.3g}, overflowed or "
        "lost positivity (forgetting with a direction not excited? see adaptid.forgetting)",
        CovarianceWindupWarning, stacklevel=3)


def warn_rebuild(self, count):
    """:class:`DefinitenessLossWarning`: ``count`` removals re-solved the window."""
    warnings.warn(
        f"{type(self).__name__}: {count} removal(s) from the window would have lost "
        "positive definiteness; the window was re-solved exactly from its buffer "
        "(poorly excited window?)", DefinitenessLossWarning, stacklevel=4)


def check_pivots(self, D, where):
    """The window's kernel does not watch the pivots: after a run or a step the
    engine checks them all in (0, windup_threshold) (a NaN is not). D: 1-D."""
    thr = self._windup_threshold
    if not all(0.0 < d < thr for d in D.tolist()):
        self._warn_nonpositive(where)


def report_codes(self, codes, where):
    """Warnings for the kernel's return codes (one per stream or segment)."""
    codes = np.atleast_1d(codes)
    if self._rebuilds:
        if codes.sum():
            self._warn_rebuild(int(codes.sum()))
        self._check_pivots(self._ud_views(self._S)[1].ravel(), f"≤ {self.n_updates}")
    elif (codes >= 0).any():
        first = int(np.argmax(codes >= 0))
        self._warn_nonpositive(int(codes[first]) if where is None
                               else f"{int(codes[first])} of {where} {first}")


def code_warnings(self, code, D):
    """The warnings of an update whose kernel returned ``code`` (not −1, or the window's)."""
    if self._rebuilds:  # the window: code counts re-solves; D is checked here
        if code:
            self._warn_rebuild(1)
        self._check_pivots(D, self.n_updates)
    elif code >= 0:
        self._warn_nonpositive(self.n_updates)
    elif code <= -2:  # a repaired covariance (RLS form="covariance")
        self._warn_rebuild(1)


def warn_segments(self, status):
    """The warnings of ``run_segments`` from its status per segment."""
    if self._rebuilds:
        if status.sum():
            self._warn_rebuild(int(status.sum()))
        return
    bad = np.flatnonzero(status >= 0)
    if bad.size:
        warnings.warn(
            f"{type(self).__name__}: in {bad.size} segment(s) (first: segment {int(bad[0])}, "
            f"sample {int(status[bad[0]])}) the covariance factor lost positivity or "
            "overflowed (covariance windup)", CovarianceWindupWarning, stacklevel=3)
