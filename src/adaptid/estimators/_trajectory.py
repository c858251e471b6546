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
    names : tuple of str, or None
        Parameter names, set by the producer that knows them (the model
        objects' ``fit_recursive``); :meth:`to_pandas` and :meth:`plot` use them.
    time : ndarray, shape (N,), or None
        Time stamp of every row (numbers or ``datetime64``), set when the
        data came as an :class:`adaptid.IDData`; the index of :meth:`to_pandas`.
    stderr : ndarray, shape (N, n), or None
        Standard error of every estimate when the producer kept the P
        history; :meth:`plot` then draws ±2σ bands.
    identified : ndarray of bool, shape (N,) or (B, N), or None
        Estimators with an exact diffuse start (``P0="diffuse"``): whether θ
        was determined by the data after sample k, i.e. the (weighted,
        forgotten or windowed) information matrix :math:`\Phi^TW\Phi` had
        full numerical rank (``theta[k]`` is then the exact least-squares
        solution); where False, ``theta[k]`` is the minimum-norm
        least-squares solution (the diffuse Kalman filter's estimate for
        :class:`~adaptid.KalmanRLS`). A skipped sample keeps the previous
        value. None for estimators with a finite prior ``P0``.
    stats : WindowStats or None
        The per-sample statistics of the window (``run(..., stats=True)``);
        None when not asked for.
    """

    theta: np.ndarray
    error: np.ndarray
    skipped: np.ndarray
    n_rebuilds: int = 0
    forgetting: np.ndarray | None = None
    meta: dict = field(default_factory=dict, repr=False)
    names: tuple | None = None
    time: np.ndarray | None = field(default=None, repr=False)
    stderr: np.ndarray | None = field(default=None, repr=False)
    identified: np.ndarray | None = field(default=None, repr=False)
    stats: object | None = field(default=None, repr=False)

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

        Columns: one per parameter (``names``, else the trajectory's own
        ``names``, else ``theta0..``), ``error`` and ``skipped``. Index:
        ``index``, else the trajectory's ``time`` (named "time"), else the
        sample positions ``meta["index"]`` (named "k") when known. Requires
        pandas (``pip install adaptid[pandas]``).
        """
        try:
            import pandas as pd
        except ImportError as err:  # pragma: no cover - depends on the extra
            raise ImportError("to_pandas needs pandas: pip install 'adaptid[pandas]'") from err
        if self.theta.ndim != 2:
            raise ValueError("to_pandas is for a single-stream, single-output trajectory")
        n = self.theta.shape[1]
        names = self._param_names(names)
        if index is None and self.time is not None:
            index = pd.Index(self.time, name="time")
        elif index is None and self.meta.get("index") is not None:
            index = pd.Index(self.meta["index"], name="k")
        df = pd.DataFrame(self.theta, columns=names, index=index)
        df["error"] = self.error
        df["skipped"] = self.skipped
        return df

    def _param_names(self, names=None):
        n = self.theta.shape[-1] if self.theta.ndim == 2 else self.theta.shape[1]
        if names is None:
            names = self.names if self.names is not None else [f"theta{i}" for i in range(n)]
        names = [str(x) for x in names]
        if len(names) != n:
            raise ValueError(f"names must have {n} entries, got {len(names)}")
        return names

    def plot(self, names=None, *, ax=None, true_theta=None):
        """Draw the parameter tracks (:func:`adaptid.plot.tracks`); returns the figure.

        One panel per parameter against ``time`` (or the sample position),
        with ±2σ bands when ``stderr`` is known. Requires matplotlib
        (``pip install 'adaptid[plot]'``).
        """
        if self.theta.ndim != 2:
            raise ValueError("plot is for a single-stream, single-output trajectory")
        from ._hooks import upward
        tracks = upward("adaptid.plot").tracks  # the figure lives in layer 7

        x = self.time if self.time is not None else self.meta.get("index")
        x = np.arange(self.theta.shape[0]) if x is None else np.asarray(x)
        truth = None
        if true_theta is not None:
            truth = (x[[0, -1]], np.tile(np.ravel(true_theta), (2, 1)))
        xlabel = "time" if self.time is not None else "sample"
        return tracks(x, self.theta, self._param_names(names), band=self.stderr, truth=truth,
                      xlabel=xlabel, ax=ax)
