"""The result of a recursive run."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["Trajectory"]


@dataclass(frozen=True, eq=False)
class Trajectory:
    r"""Per-sample estimates and a-priori errors of a recursive run.

    Attributes
    ----------
    theta : ndarray, shape (N, n) or (N, n, p); (B, N, n[, p]) when batched
        ``theta[k]`` is the estimate after sample ``k`` (0-based), i.e.
        :math:`\hat\theta_{k+1}` in the 1-based notation of the references.
        Empty (first axis 0) when the run was asked not to store it.
    error : ndarray, shape (N,) or (N, p); (B, N[, p]) when batched
        A-priori errors :math:`\varepsilon_k = y_k - \varphi_k^T\hat\theta_{k-1}`;
        NaN for skipped samples.
    skipped : ndarray of bool, shape (N,) or (B, N)
        Samples skipped under ``nan_policy="skip"`` (all False otherwise).
    n_rebuilds : int
        Sliding window only: removals that would have lost positive
        definiteness and were replaced by an exact re-solve of the window.
    forgetting : ndarray, shape (N,) or (B, N), or None
        RLS with a forgetting strategy (:mod:`adaptid.forgetting`) or
        ``P_max``: the factor λₖ actually applied at each sample (NaN where
        skipped). None for constant or given per-sample λ.
    """

    theta: np.ndarray
    error: np.ndarray
    skipped: np.ndarray
    n_rebuilds: int = 0
    forgetting: np.ndarray | None = None
    meta: dict = field(default_factory=dict, repr=False)

    def __len__(self) -> int:
        return self.error.shape[-1] if self.error.ndim == 1 else self.skipped.shape[-1]

    @property
    def n_skipped(self) -> int:
        """Number of skipped samples."""
        return int(np.count_nonzero(self.skipped))

    def __repr__(self) -> str:
        return (f"Trajectory(theta: shape {self.theta.shape}, error: shape {self.error.shape}, "
                f"n_skipped={self.n_skipped}, n_rebuilds={self.n_rebuilds})")

    def to_pandas(self, names=None, index=None):
        """Return the single-stream, single-output trajectory as a DataFrame.

        Columns: one per parameter (``names`` or ``theta0..``), ``error`` and
        ``skipped``. Requires pandas (``pip install adaptid[pandas]``).
        """
        try:
            import pandas as pd
        except ImportError as err:  # pragma: no cover - depends on the extra
            raise ImportError("to_pandas needs pandas: pip install 'adaptid[pandas]'") from err
        if self.theta.ndim != 2:
            raise ValueError("to_pandas is for a single-stream, single-output trajectory")
        n = self.theta.shape[1]
        names = list(names) if names is not None else [f"theta{i}" for i in range(n)]
        if len(names) != n:
            raise ValueError(f"names must have {n} entries, got {len(names)}")
        df = pd.DataFrame(self.theta, columns=names, index=index)
        df["error"] = self.error
        df["skipped"] = self.skipped
        return df
