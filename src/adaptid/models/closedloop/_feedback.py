r"""A test for feedback from the output to the input: :func:`checkfeedback`."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..._lazy import lazy, pyplot
from ..._validation import check_int, check_scalar, param_error
from .._arx import ARX
from .._iddata import as_record

linalg = lazy("scipy.linalg")
stats = lazy("scipy.stats")

__all__ = ["checkfeedback", "FeedbackResult"]


@dataclass(frozen=True, eq=False)
class FeedbackResult:
    r"""Result of :func:`checkfeedback`.

    Attributes
    ----------
    statistic : float
        :math:`\zeta = N\,r^T T^{-1} r`, χ² with ``dof`` degrees of freedom
        when there is no feedback.
    p_value : float
        :math:`P(\chi^2_M > \zeta)`.
    dof : int
        M, the number of lags tested.
    feedback : bool
        ``p_value < alpha``: the record shows feedback from y to u.
    alpha : float
        Level of the test and of the band.
    lags : ndarray of int, shape (M,)
        τ = 1 … M.
    ccf : ndarray, shape (M,)
        :math:`r(\tau)`, the correlation of :math:`\varepsilon_k` with
        :math:`u_{k+\tau}`.
    band : float
        :math:`z_{1-\alpha/2}/\sqrt N`, the band of one lag.
    order : int
        na = nb of the ARX model whose residuals are tested.
    nk : int
        Its input delay.
    residuals : ndarray
        The ARX model's residuals :math:`\varepsilon_k`.
    n_obs : int
        N, the number of residuals.
    y_name, u_name : str
    """

    statistic: float
    p_value: float
    dof: int
    feedback: bool
    alpha: float
    lags: np.ndarray
    ccf: np.ndarray
    band: float
    order: int
    nk: int
    residuals: np.ndarray = field(repr=False)
    n_obs: int = 0
    y_name: str = "y"
    u_name: str = "u"

    @property
    def outside(self) -> np.ndarray:
        """Lags whose correlation lies outside the band (bool, shape (M,))."""
        return np.abs(self.ccf) > self.band

    def summary(self):
        """A short text: the statistic, the p-value, the verdict and the lags outside the band."""
        lags = ", ".join(str(int(t)) for t in self.lags[self.outside]) or "none"
        verdict = "feedback" if self.feedback else "no evidence of feedback"
        return "\n".join([
            f"Feedback test: {self.u_name} -> {self.y_name} (ARX order {self.order}, "
            f"nk = {self.nk}, {self.n_obs} residuals)",
            f"  statistic = {self.statistic:.4g} (chi2, {self.dof} dof), "
            f"p-value = {self.p_value:.3g}",
            f"  verdict at alpha = {self.alpha:g}: {verdict}",
            f"  lags tau with corr(e[k], u[k+tau]) outside +-{self.band:.3g}: {lags}"])

    def to_frame(self):
        """The correlations as a pandas table: ``lag``, ``ccf``, ``band``, ``outside``."""
        try:
            import pandas as pd
        except ImportError as err:  # pragma: no cover - depends on the extra
            raise ImportError("to_frame needs pandas: pip install 'adaptid[pandas]'") from err
        return pd.DataFrame({"lag": self.lags, "ccf": self.ccf,
                             "band": np.full(self.lags.size, self.band),
                             "outside": self.outside})

    def plot(self, *, fig=None):
        """Stem plot of r(τ), τ = 1 … M, with the ±band.

        Parameters
        ----------
        fig : matplotlib Figure, optional

        Returns
        -------
        matplotlib.figure.Figure
        """
        plt = pyplot()
        if fig is None:
            fig = plt.figure(figsize=(6.5, 3.2), layout="constrained")
        ax = fig.subplots()
        ax.stem(self.lags, self.ccf, basefmt=" ")
        ax.axhline(self.band, color="0.4", ls="--", lw=0.8, label=f"{1 - self.alpha:.0%} band")
        ax.axhline(-self.band, color="0.4", ls="--", lw=0.8)
        ax.axhline(0.0, color="0.6", lw=0.5)
        ax.set_xlabel("lag τ (samples)")
        ax.set_ylabel(f"corr(e[k], {self.u_name}[k+τ])")
        ax.legend(fontsize=8)
        ax.grid(True, lw=0.3)
        fig.suptitle(f"Feedback test: p = {self.p_value:.3g}, "
                     f"{'feedback' if self.feedback else 'no feedback'}", fontsize=10)
        return fig

    def __repr__(self):
        return (f"FeedbackResult(feedback={self.feedback}, p_value={self.p_value:.3g}, "
                f"statistic={self.statistic:.4g}, dof={self.dof}, alpha={self.alpha})")


def _future_correlation(e, u, M):
    """r(τ) = Σ ẽ_k ũ_{k+τ} / √(Σẽ² Σũ²), τ = 1 … M, and ρ_u(0 … M-1) of u."""
    ec = e - e.mean()
    uc = u - u.mean()
    N = ec.size
    den = np.sqrt((ec @ ec) * (uc @ uc))
    r = np.array([ec[: N - t] @ uc[t:] for t in range(1, M + 1)]) / den
    rho = np.array([uc[: N - t] @ uc[t:] for t in range(M)]) / (uc @ uc)
    return r, rho


def checkfeedback(data, *, max_lag=None, alpha=0.05, order=10, nk=1):
    r"""Test a record for feedback from the output to the input (MATLAB's ``feedback``).

    A high-order ARX model :math:`A(q)y_k = B(q)u_k + \varepsilon_k`
    (na = nb = ``order``, delay ``nk``) is fitted by least squares and its
    residuals are correlated with *future* inputs:

    .. math::

        r(\tau) = \frac{\sum_k\tilde\varepsilon_k\,\tilde u_{k+\tau}}
                       {\sqrt{\sum\tilde\varepsilon_k^2\sum\tilde u_k^2}},\qquad
        \zeta = N\,r^T T^{-1} r \sim \chi^2_M,\qquad \tau = 1 \dots M,

    with :math:`T_{ij} = \hat\rho_u(i-j)` the M × M Toeplitz matrix of
    the input's sample autocorrelation (Ljung 1999, sec. 16.6, with white
    ε: the correlations at different lags are correlated through the
    colour of u, which T accounts for). Without feedback u is independent
    of the noise, so the residuals, which the high-order ARX makes white,
    are uncorrelated with every input sample and ζ is χ²(M). With feedback
    the input at k + τ reacts to the output at k, which carries
    :math:`\varepsilon_k`: the correlation appears at τ > 0 (Ljung 1999,
    secs. 13.4 and 16.6; the cross-correlation test of :func:`resid` read
    at negative lags).

    Parameters
    ----------
    data : IDData, (y, u) tuple, or DataFrame (output column first)
        One output and one input.
    max_lag : int, optional
        M, the number of future lags tested, ``1 <= M``; default
        min(25, N // 5) with N the number of residuals.
    alpha : float
        Level of the test (default 0.05), in (0, 1).
    order : int
        na = nb of the ARX model, ``>= 1`` (default 10).
    nk : int
        Its input delay, ``>= 0`` (default 1). Give the plant's delay: a
        direct term b₀u_k left out of the model leaves
        :math:`b_0u_k` in the residual, which correlates with future inputs
        when u is coloured and looks like feedback.

    Returns
    -------
    FeedbackResult
        ``statistic``, ``p_value``, ``feedback`` (the verdict), the
        correlations ``ccf`` at ``lags``, ``summary()``, ``to_frame()``,
        ``plot()``.

    Notes
    -----
    Why a high-order ARX and not an FIR model: the test's χ² law needs
    white residuals. An FIR model's residual is the noise
    :math:`H(q)e_k` itself, coloured in general, and coloured residuals
    widen the spread of r(τ) beyond the band (a false alarm); the ARX
    model's residual approaches the innovation :math:`e_k` as its order
    grows, in open and in closed loop alike (the ARX fit is consistent
    under feedback when its order is high enough; Ljung 1999, sec. 13.4).
    MATLAB's ``feedback`` reports the same kind of test as a probability
    of feedback in percent.

    References
    ----------
    .. [1] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
       Prentice Hall, 1999, secs. 13.4 and 16.6.

    Examples
    --------
    >>> import numpy as np
    >>> from adaptid.models import checkfeedback
    >>> rng = np.random.default_rng(0)
    >>> N = 2000; r = rng.standard_normal(N); e = 0.5 * rng.standard_normal(N)
    >>> y = np.zeros(N); u = np.zeros(N)
    >>> for k in range(N):          # y = 0.5 q^-1/(1 - 0.8 q^-1) u + e,  u = r - 0.5 y
    ...     y[k] = (0.8 * y[k - 1] + 0.5 * u[k - 1] + e[k] - 0.8 * e[k - 1]) if k else e[0]
    ...     u[k] = r[k] - 0.5 * y[k]
    >>> checkfeedback((y, u)).feedback, checkfeedback((y, r)).feedback
    (True, False)
    """
    rec = as_record(data)
    if rec.n_outputs != 1 or rec.n_inputs != 1:
        raise param_error("data", "a record with one output and one input",
                          f"<{rec.n_outputs} output(s), {rec.n_inputs} input(s)>")
    alpha = check_scalar(alpha, "alpha", low=0.0, high=1.0, low_open=True, high_open=True)
    order = check_int(order, "order", low=1)
    nk = check_int(nk, "nk", low=0)
    y, u = rec.y, rec.inputs[:, 0]
    n_rows = y.size - max(order, nk + order - 1)
    if n_rows < 4 * (2 * order) + 10:
        raise param_error("data", f"a record long enough for an ARX model of order {order} "
                          f"(at least {8 * order + 10} rows)", f"<{max(n_rows, 0)} rows>")
    if not np.ptp(u) > 0:
        raise param_error("data", "a record whose input is not constant", "<a constant input>")
    model = ARX(order, order, nk).fit(y, u)
    e = np.asarray(model.residuals)
    ue = u[model.index]
    N = e.size
    M = min(25, N // 5) if max_lag is None else check_int(max_lag, "max_lag", low=1,
                                                          high=N // 2)
    r, rho = _future_correlation(e, ue, M)
    T = linalg.toeplitz(rho)
    stat = float(N * (r @ linalg.cho_solve(linalg.cho_factor(T), r)))
    p = float(stats.chi2.sf(stat, M))
    return FeedbackResult(statistic=stat, p_value=p, dof=M, feedback=bool(p < alpha), alpha=alpha,
                          lags=np.arange(1, M + 1), ccf=r,
                          band=float(stats.norm.ppf(1 - alpha / 2) / np.sqrt(N)), order=order,
                          nk=nk, residuals=e, n_obs=N, y_name=rec.y_names[0],
                          u_name=rec.u_names[0])
