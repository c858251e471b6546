r"""``KalmanRLS.smooth`` and ``KalmanRLS.loglike``: the fixed-interval smoother and
the likelihood of the random-walk model, from the estimator's prior.

Both methods validate here and make one call of a compiled kernel
(:mod:`adaptid._kernels.recursions._smoother`). They start from the prior
(θ₀, P₀, or the exact diffuse start), as statsmodels' state-space models and
MATLAB's smoothers do, and leave the estimator's state untouched. The
functions taking ``self`` are methods of :class:`~adaptid.KalmanRLS` (bound
there by name).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from .. import _config
from .._exceptions import DefinitenessLossWarning
from .._validation import param_error
from . import _inputs

__all__ = ["KalmanSmoothResult", "smooth", "loglike", "prepared", "prior", "loglike_terms"]


def _kernels():
    from .._kernels.recursions import _smoother  # loaded on first use (numba)
    return _smoother


def prepared(self, Phi, y, weights, what):
    """Validated (labels, Phi (N, n), y (N,), w (N,)), contiguous float64 copies."""
    if self.n_outputs != 1:
        raise param_error("y", f"a single output for {what} (this KalmanRLS has n_outputs="
                          f"{self.n_outputs})", "<several outputs>")
    labels = _inputs.labels(Phi, y)
    Phi, Y, w = self._run_arrays(Phi, y, weights, batched=False)
    return (labels, np.array(Phi, dtype=np.float64, order="C"),
            np.array(Y[:, 0], dtype=np.float64), np.array(w, dtype=np.float64))


def prior(self):
    """(a, P, P∞, diffuse): the state before the first sample, as new arrays."""
    n = self.n_params
    if self._diffuse:
        return np.zeros(n), np.zeros((n, n)), np.eye(n), True
    return self.theta0[:, 0].copy(), np.array(self.P0, dtype=np.float64), np.zeros((n, n)), False


def loglike_terms(Phi, y, w, start, Q, r2):
    """One forward pass: [Σ v²/F, Σ log F, count, Σ log F∞, rank steps]."""
    a, P, Pi, diffuse = (x.copy() if isinstance(x, np.ndarray) else x for x in start)
    acc = np.zeros(5)
    _kernels().kalman_loglike(Phi, y, w, a, P, Pi, np.ascontiguousarray(Q, dtype=np.float64),
                              float(r2), diffuse, _config.DIFFUSE_KALMAN_TOL, acc)
    return acc


def llf_of(acc):
    """The log-likelihood from :func:`loglike_terms`."""
    return -0.5 * ((acc[2] + acc[4]) * math.log(2.0 * math.pi) + acc[0] + acc[1] + acc[3])


def loglike(self, Phi, y, *, weights=None):
    r"""Gaussian log-likelihood of (Φ, y) by the prediction-error decomposition.

    With the innovations :math:`v_k = y_k - \varphi_k^T\hat\theta_{k|k-1}` and
    their variances :math:`F_k = \varphi_k^TP_{k|k-1}\varphi_k + R_2/w_k` of
    the filter run from the prior (Harvey 1989, §3.4; Durbin & Koopman 2012,
    eq. 7.2):

    .. math::

        \log L = -\tfrac12\sum_k\bigl[\log(2\pi F_k) + v_k^2/F_k\bigr].

    With ``P0="diffuse"`` it is the diffuse log-likelihood of the exact
    initial filter (Durbin & Koopman 2012, §7.2.2, :math:`P_\infty = I`): a
    sample that lowers the rank of :math:`P_\infty`
    (:math:`F_{\infty,k} > 0`) contributes
    :math:`-\tfrac12\log(2\pi F_{\infty,k})`, every other one the term
    above — statsmodels' ``llf`` with ``initialization="diffuse"`` and
    ``loglikelihood_burn=0``. Samples with weight 0 or (under
    ``nan_policy="skip"``) a non-finite value are missing: they contribute
    nothing.

    Parameters
    ----------
    Phi : array_like, shape (N, n)
    y : array_like, shape (N,)
    weights : float or array_like, shape (N,), optional
        wₖ ≥ 0: the noise variance of sample k is R₂/wₖ (default 1).

    Returns
    -------
    float
        The log-likelihood; the estimator's state is not changed (the
        filter runs from the prior θ₀, P₀, not from the current state).
    """
    _, Phi, y, w = prepared(self, Phi, y, weights, "loglike")
    return llf_of(loglike_terms(Phi, y, w, prior(self), self.process_cov, self.noise_var))


def smooth(self, Phi, y, *, weights=None):
    r"""Smoothed parameter track: θ(k|N) and P(k|N) given all N samples.

    The Rauch–Tung–Striebel fixed-interval smoother (Rauch, Tung & Striebel
    1965; Särkkä 2013, *Bayesian Filtering and Smoothing*, §8.2) of the
    random walk :math:`\theta_{k+1} = \theta_k + \nu_k`,
    :math:`y_k = \varphi_k^T\theta_k + e_k`:

    .. math::

        J_k = P_{k|k}P_{k+1|k}^{-1},\quad
        \hat\theta_{k|N} = \hat\theta_{k|k} + J_k(\hat\theta_{k+1|N} - \hat\theta_{k|k}),\quad
        P_{k|N} = P_{k|k} + J_k(P_{k+1|N} - P_{k+1|k})J_k^T,

    computed without any inverse in the equivalent backward form of Durbin &
    Koopman (2012, §4.4.3): :math:`r_{k-1} = \varphi_kv_k/F_k + L_k^Tr_k`,
    :math:`N_{k-1} = \varphi_k\varphi_k^T/F_k + L_k^TN_kL_k`,
    :math:`L_k = I - P_{k|k-1}\varphi_k\varphi_k^T/F_k`,
    :math:`\hat\theta_{k|N} = \hat\theta_{k|k-1} + P_{k|k-1}r_{k-1}`,
    :math:`P_{k|N} = P_{k|k-1} - P_{k|k-1}N_{k-1}P_{k|k-1}`. With
    ``P0="diffuse"`` the exact diffuse smoother (Durbin & Koopman 2012,
    §5.3) runs over the samples of the diffuse phase. Forward and backward
    pass are one compiled call.

    The recursions are in covariance form: a finite ``P0`` far larger than
    what the data determine (a vague prior, P₀ = 10⁸·I) cancels digits in
    :math:`P_{k|N}` at the first samples (statsmodels' smoother does the
    same); a :class:`~adaptid.DefinitenessLossWarning` says when it went
    indefinite. ``P0="diffuse"`` is the exact limit and has no such loss.

    The filter starts from the prior (θ₀, P₀ or the diffuse start), as
    statsmodels' and MATLAB's smoothers do, and the estimator's state is
    left unchanged (unlike :meth:`run`, which continues from the current
    state).

    Parameters
    ----------
    Phi : array_like, shape (N, n)
        Regressors; a DataFrame gives the parameter names and time axis.
    y : array_like, shape (N,)
    weights : float or array_like, shape (N,), optional
        wₖ ≥ 0: the noise variance of sample k is R₂/wₖ (default 1; 0 marks
        the sample missing).

    Returns
    -------
    KalmanSmoothResult
        ``theta`` (N, n) and ``P`` (N, n, n) smoothed; ``theta_filtered``,
        ``P_filtered`` (the estimate after sample k, equal to :meth:`run`'s
        ``Trajectory.theta``); ``error`` (innovations vₖ), ``F``,
        ``loglike``; ``summary()``, ``to_frame()``, ``plot()``.

    Examples
    --------
    The smoother and the filter agree at the last sample, and nowhere is the
    smoothed variance above the filtered one:

    >>> import numpy as np
    >>> from adaptid import KalmanRLS
    >>> rng = np.random.default_rng(0)
    >>> Phi = rng.standard_normal((200, 2))
    >>> y = Phi @ [1.0, -1.0] + 0.1 * rng.standard_normal(200)
    >>> res = KalmanRLS(2, process_cov=1e-4, noise_var=0.01, P0="diffuse").smooth(Phi, y)
    >>> bool(np.allclose(res.theta[-1], res.theta_filtered[-1]))
    True
    >>> bool(np.all(res.stderr[5:] <= res.stderr_filtered[5:] + 1e-12))
    True
    """
    labels, Phi, y, w = prepared(self, Phi, y, weights, "smooth")
    N, n = Phi.shape
    a, P, Pi, diffuse = prior(self)
    A, PP, Af, PF, As, Ps = (np.empty((N, n)), np.empty((N, n, n)), np.empty((N, n)),
                             np.empty((N, n, n)), np.empty((N, n)), np.empty((N, n, n)))
    PI = np.zeros((N if diffuse else 0, n, n))
    V, F, FI = np.empty(N), np.empty(N), np.empty(N)
    kind = np.empty(N, dtype=np.int8)
    acc = np.zeros(5)
    still = _kernels().kalman_smooth(Phi, y, w, a, P, Pi, np.ascontiguousarray(self.process_cov),
                                     float(self.noise_var), diffuse, _config.DIFFUSE_KALMAN_TOL,
                                     A, PP, PI, Af, PF, V, F, FI, kind, acc, As, Ps)
    identified = None
    if diffuse:
        identified = np.cumsum(kind == 2) >= n
        if still:
            Ps[:] = np.inf  # κ-terms remain: not determined by the data
    if N and np.min(np.diagonal(Ps, axis1=1, axis2=2)) < 0.0:
        warnings.warn("the smoothed covariance P(k|N) lost positive definiteness: the prior P0 "
                      "is far larger than what the data determine (a vague prior); use "
                      "P0='diffuse' for the exact diffuse start", DefinitenessLossWarning,
                      stacklevel=2)
    return KalmanSmoothResult(theta=As, P=Ps, theta_filtered=Af, P_filtered=PF, error=V, F=F,
                              loglike=llf_of(acc), identified=identified,
                              kind=kind, **labels)


@dataclass(frozen=True, eq=False)
class KalmanSmoothResult:
    r"""The smoothed and filtered parameter tracks of :meth:`KalmanRLS.smooth`.

    Attributes
    ----------
    theta : ndarray, shape (N, n)
        Smoothed estimates :math:`\hat\theta_{k|N}` (row k: the parameter
        that generated sample k).
    P : ndarray, shape (N, n, n)
        Their covariances :math:`P_{k|N}` (inf when a diffuse start was never
        identified by the data).
    theta_filtered : ndarray, shape (N, n)
        :math:`\hat\theta_{k|k}`, the estimate after sample k (``run``'s).
    P_filtered : ndarray, shape (N, n, n)
        :math:`P_{k|k}`; during a diffuse start its finite part
        :math:`P_*` (statsmodels' ``filtered_state_cov``).
    error : ndarray, shape (N,)
        Innovations :math:`v_k` (NaN for missing samples).
    F : ndarray, shape (N,)
        Their variances :math:`F_k` (:math:`F_{*,k}` during a diffuse start).
    loglike : float
        As :meth:`KalmanRLS.loglike`.
    kind : ndarray of int8, shape (N,)
        Per sample: 0 missing (weight 0 or skipped), 1 ordinary, 2 a step of
        the diffuse phase that lowered the rank of :math:`P_\infty`, 3 another
        step of the diffuse phase.
    identified : ndarray of bool, shape (N,), or None
        With ``P0="diffuse"``: whether the filter has left the diffuse phase
        after sample k. None with a finite prior.
    names, time
        Parameter names and time axis, from pandas input (as ``run`` gives).
    """

    theta: np.ndarray
    P: np.ndarray
    theta_filtered: np.ndarray
    P_filtered: np.ndarray
    error: np.ndarray
    F: np.ndarray
    loglike: float
    identified: np.ndarray | None = field(default=None, repr=False)
    kind: np.ndarray | None = field(default=None, repr=False)
    names: tuple | None = None
    time: np.ndarray | None = field(default=None, repr=False)

    def __len__(self):
        return self.theta.shape[0]

    @property
    def stderr(self) -> np.ndarray:
        """(N, n) standard errors of the smoothed estimates, √diag P(k|N)."""
        return np.sqrt(np.clip(np.diagonal(self.P, axis1=1, axis2=2), 0.0, None))

    @property
    def stderr_filtered(self) -> np.ndarray:
        """(N, n) standard errors of the filtered estimates (inf until identified)."""
        se = np.sqrt(np.clip(np.diagonal(self.P_filtered, axis1=1, axis2=2), 0.0, None))
        if self.identified is not None:
            se = np.where(self.identified[:, None], se, np.inf)
        return se

    def _names(self, names=None):
        n = self.theta.shape[1]
        names = names if names is not None else self.names
        names = [f"theta{i}" for i in range(n)] if names is None else [str(x) for x in names]
        if len(names) != n:
            raise param_error("names", f"{n} names", f"<{len(names)} names>")
        return names

    def to_frame(self, names=None):
        """One row per sample: per parameter ``name``, ``name_stderr`` (smoothed),
        ``name_filtered``, ``name_filtered_stderr``; then ``error`` and ``F``.
        Index: the time axis (named "time") when known, as ``Trajectory.to_pandas``.
        Requires pandas."""
        try:
            import pandas as pd
        except ImportError as err:  # pragma: no cover - depends on the extra
            raise ImportError("to_frame needs pandas: pip install 'adaptid[pandas]'") from err
        cols = {}
        se, sef = self.stderr, self.stderr_filtered
        for j, nm in enumerate(self._names(names)):
            cols[nm] = self.theta[:, j]
            cols[f"{nm}_stderr"] = se[:, j]
            cols[f"{nm}_filtered"] = self.theta_filtered[:, j]
            cols[f"{nm}_filtered_stderr"] = sef[:, j]
        cols["error"] = self.error
        cols["F"] = self.F
        index = pd.Index(self.time, name="time") if self.time is not None else None
        return pd.DataFrame(cols, index=index)

    def plot(self, names=None, *, ax=None, true_theta=None):
        """Filtered and smoothed tracks with ±2σ bands, one panel per parameter;
        returns the matplotlib Figure (``pip install 'adaptid[plot]'``).
        ``true_theta``: (n,) or (N, n) drawn dashed."""
        from ._hooks import upward
        plot = upward("adaptid.plot")  # the figures live in layer 7
        x = self.time if self.time is not None else np.arange(len(self))
        names = self._names(names)
        truth = None
        if true_theta is not None:
            tt = np.asarray(true_theta, dtype=float)
            truth = (x[[0, -1]], np.tile(tt.ravel(), (2, 1))) if tt.ndim == 1 else (x, tt)
        sef = self.stderr_filtered
        xlabel = "time" if self.time is not None else "sample"
        axes = plot.panel_axes(len(names))[1] if ax is None else ax
        plot.tracks(x, self.theta_filtered, names, band=np.where(np.isfinite(sef), sef, np.nan),
                    label="filtered", xlabel=xlabel, ax=axes, color="tab:gray")
        fig = plot.tracks(x, self.theta, names, band=self.stderr, truth=truth, label="smoothed",
                          xlabel=xlabel, ax=axes, color="tab:blue")
        if ax is None:
            fig.legend(*fig.axes[0].get_legend_handles_labels(), loc="outside upper center",
                       ncol=3, fontsize=9, frameon=False)
        return fig

    def summary(self, names=None, *, alpha=0.05):
        """:class:`~adaptid.Summary`: the estimate at the last sample (smoothed equals
        filtered there) with its standard error and limits, N, the log-likelihood."""
        from .._summary import Summary, parameter_rows
        if not len(self):
            raise ValueError("summary needs at least one sample (this result has none)")
        rows = parameter_rows(self.theta[-1], self.stderr[-1], np.inf, alpha)
        missing = int(np.count_nonzero(self.kind == 0)) if self.kind is not None else 0
        stats = {"N": len(self), "missing": missing, "log-likelihood": float(self.loglike)}
        if self.identified is not None:
            stats["diffuse samples"] = int(np.count_nonzero(~self.identified))
        return Summary(title="Kalman smoother (Rauch-Tung-Striebel)",
                       names=tuple(self._names(names)), params=rows, stats=stats, alpha=alpha,
                       notes=("Estimates: θ(N|N); the track is in theta (smoothed) and "
                              "theta_filtered.",))
