"""Many streams of different lengths stored back to back: the segmented run."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._kernels.recursions._segments import segment_stats
from .._validation import param_error

__all__ = ["SegmentResult"]


@dataclass(frozen=True, eq=False)
class SegmentResult:
    r"""Result of :meth:`RLS.run_segments` (and of the other estimators').

    G streams ("segments") stored back to back, segment g being rows
    ``offsets[g]:offsets[g+1]``; each was run from the estimator's prior.

    Attributes
    ----------
    theta : ndarray, shape (G, n) or (G, n, p)
        Final estimate of each segment (the prior θ₀ for an empty one).
    P : ndarray, shape (G, n, n)
        Final covariance of each segment.
    n_samples : ndarray of int64, shape (G,)
        Samples used (skipped ones not counted).
    n_skipped : ndarray of int64, shape (G,)
        Samples skipped under ``nan_policy="skip"``.
    sse : ndarray, shape (G,) or (G, p)
        :math:`\sum_k \varepsilon_k^2` over the used samples of each segment
        (a-priori errors).
    error : ndarray, shape (N_total,) or (N_total, p)
        Per-sample a-priori errors, NaN where skipped.
    skipped : ndarray of bool, shape (N_total,)
    theta_track : ndarray, shape (N_total, n[, p]), or None
        Per-sample estimates when the run was asked to ``store`` them.
    offsets : ndarray of int64, shape (G + 1,)
    status : ndarray of int64, shape (G,)
        RLS / Kalman: the first sample (within the segment) where the
        covariance factor lost positivity or passed the windup threshold,
        else −1. Sliding window: the number of removals replaced by a re-solve.
    """

    theta: np.ndarray
    P: np.ndarray
    n_samples: np.ndarray
    n_skipped: np.ndarray
    sse: np.ndarray
    error: np.ndarray
    skipped: np.ndarray
    theta_track: np.ndarray | None
    offsets: np.ndarray
    status: np.ndarray

    def __len__(self) -> int:
        return self.n_samples.shape[0]


def check_offsets(offsets, N: int) -> np.ndarray:
    """Validate segment boundaries: int, nondecreasing, from 0 to N."""
    arr = np.asarray(offsets)
    if arr.ndim != 1 or arr.shape[0] < 1:
        raise param_error("offsets", "a 1-D array of G+1 segment boundaries", f"<shape {arr.shape}>")
    if arr.dtype.kind not in "iu":
        if arr.dtype.kind == "f" and np.all(np.isfinite(arr)) and np.all(arr == np.round(arr)):
            arr = arr.astype(np.int64)
        else:
            raise param_error("offsets", "integers", f"<dtype {arr.dtype}>", exc=TypeError)
    arr = np.ascontiguousarray(arr, dtype=np.int64)
    if arr[0] != 0 or arr[-1] != N:
        raise param_error("offsets", f"starting at 0 and ending at N={N}",
                          f"<first {int(arr[0])}, last {int(arr[-1])}>")
    if np.any(np.diff(arr) < 0):
        raise param_error("offsets", "nondecreasing", "<a decreasing pair>")
    return arr
