r"""The fit of one output of a NARX model: the results object (summary, frame, figure)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..._summary import Summary, parameter_rows
from ..._lazy import pyplot

__all__ = ["NARXResult", "term_name"]


class _ERRSummary(Summary):
    """A :class:`~adaptid._summary.Summary` with the ERR of each term as a seventh column."""

    def _param_header(self):
        return super()._param_header() + ("ERR",)

    def to_frame(self):
        """The parameter table (with ERR) as a pandas DataFrame."""
        try:
            import pandas as pd
        except ImportError as err:  # pragma: no cover - depends on the extra
            raise ImportError("to_frame needs pandas: pip install 'adaptid[pandas]'") from err
        cols = ["estimate", "stderr", "t", "P>|t|", "lower", "upper", "ERR"]
        return pd.DataFrame(self.params, index=list(self.names), columns=cols)


def term_name(combo, base_names):
    """``"u1(k-2)*y1(k-1)"``: factors by descending base index, powers as ``^p``."""
    idx = [int(i) for i in combo if i > 0]
    if not idx:
        return "1"
    parts = []
    for i in sorted(set(idx), reverse=True):
        p = idx.count(i)
        parts.append(base_names[i - 1] + (f"^{p}" if p > 1 else ""))
    return "*".join(parts)


@dataclass(frozen=True, eq=False)
class NARXResult:
    r"""The fit of one output of a :class:`NARX` model.

    Attributes
    ----------
    output : str
        The output's name.
    terms : tuple of str
        The selected terms in the order FROLS chose them.
    combos : ndarray of intp, shape (d_p, D)
        The process terms' index tuples into :math:`[1, x_1, …, x_n]` (the
        base variables).
    theta, stderr, tvalues, pvalues : ndarray, shape (d,)
        Least squares on the selected terms (:func:`adaptid.lstsq`), the
        process terms then, with ``noise_lags`` q, the noise terms
        e(k−1) … e(k−q) (d = d_p + q).
    cov : ndarray, shape (d, d)
        :math:`\hat\sigma^2 (\Phi^T\Phi)^{-1}`, :math:`\hat\sigma^2 = \mathrm{SSR}/(N - d)`.
    err : ndarray, shape (d_p,)
        Error reduction ratio of each process term (its share of :math:`y^Ty`).
    residuals : ndarray, shape (N,)
        One-step prediction errors of the fit's rows.
    path : dict or None
        With a criterion: ``ssr`` and each criterion over the FROLS path
        (d = 1 … len), ``chosen`` (d).
    n_candidates : int
    lsq : LSResult
    """

    output: str
    terms: tuple
    combos: np.ndarray
    theta: np.ndarray
    cov: np.ndarray
    err: np.ndarray
    residuals: np.ndarray
    path: dict | None
    n_candidates: int
    lsq: object = field(repr=False)
    criterion: str | None = None
    _model: object = field(default=None, repr=False)
    noise_lags: int = 0
    iterations: int = 0

    @property
    def n_process(self):
        """Number of process terms d_p (the rest of θ are noise terms)."""
        return self.combos.shape[0]

    @property
    def stderr(self):
        """Standard errors √diag(cov)."""
        return np.sqrt(np.clip(np.diag(self.cov), 0.0, None))

    @property
    def tvalues(self):
        """θ / stderr."""
        return np.asarray(self.lsq.tvalues)

    @property
    def pvalues(self):
        """Two-sided p-values of Student's t with N − d degrees of freedom."""
        return np.asarray(self.lsq.pvalues)

    def information(self):
        """AIC, BIC, FPE, LILC (Ljung's V = SSR/N form) of this fit, as a dict."""
        r = self.residuals
        n, s = r.size, self.theta.size
        V = max(float(r @ r), 1e-300) / n
        base = n * np.log(V)
        return {"aic": base + 2 * s, "bic": base + s * np.log(n),
                "fpe": base + n * np.log((n + s) / (n - s)) if s < n else float("inf"),
                "lilc": base + 2 * s * np.log(np.log(n))}

    def summary(self, *, alpha=0.05, max_lag=25):
        r"""Table of the terms (θ, stderr, t, p, limits, ERR) and the criteria.

        Parameters
        ----------
        alpha : float
            Level of the confidence limits and of the Ljung–Box test.
        max_lag : int
            Lags of the Ljung–Box test (capped at N − 1).

        Returns
        -------
        Summary
            ``print`` it for text; notebooks show its HTML.
        """
        from ..._teststats import ljung_box
        from ..._validation import param_error

        r = self.residuals
        if r.size == 0:
            raise param_error("model", "a batch fit (NARX.fit) for summary(): a model of "
                              "RecursiveNARX.to_model has no residuals or covariance",
                              f"<output {self.output} without residuals>")
        n, d = r.size, self.theta.size
        ssr = float(r @ r)
        rows = parameter_rows(self.theta, self.stderr, n - d, alpha)
        rows = np.column_stack([rows, np.concatenate([self.err,
                                                      np.full(self.noise_lags, np.nan)])])
        ic = self.information()
        st = {"N": n, "candidates": self.n_candidates, "terms": d,
              "selection": (f"FROLS, {self.criterion} minimum over the path"
                            if self.criterion else "FROLS, n_terms given"),
              "noise terms": self.noise_lags,
              "sum of ERR": float(np.sum(self.err)),
              "sigma^2": ssr / (n - d) if n > d else float("nan"), "loss V": ssr / n,
              "AIC": ic["aic"], "BIC": ic["bic"], "FPE": ic["fpe"], "LILC": ic["lilc"]}
        m = self._model
        if m is not None and getattr(m, "_fit_record", None) is not None:
            from ..._teststats import fit_percent

            Y, U = m._fit_record
            o = m.y_names.index(self.output)
            if np.ptp(Y[:, o]) > 0:
                st["fit % (1-step, estimation)"] = fit_percent(
                    Y[:, o], np.reshape(m.predict(Y, U, k=1), (Y.shape[0], -1))[:, o])
                sim = np.reshape(m.simulate(U, y0=Y), (Y.shape[0], -1))[:, o]
                if np.all(np.isfinite(sim)):
                    st["fit % (simulation, estimation)"] = fit_percent(Y[:, o], sim)
        if np.ptp(r) > 0 and n > 2:
            M = min(max_lag, n - 1)
            st[f"Ljung-Box p (lags 1..{M})"] = ljung_box(r, M, alpha)["p_value"]
        notes = ("ERR: error reduction ratio, the term's share of y'y (Billings 2013, sec. 3.2)",
                 "criteria with V = SSR/N: AIC = N log V + 2d, BIC = N log V + d log N, "
                 "FPE = N log V + N log((N+d)/(N-d)), LILC = N log V + 2d log log N")
        return _ERRSummary(title=f"NARX output {self.output}", names=self.terms, params=rows,
                           stats=st, alpha=alpha, notes=notes)

    def to_frame(self):
        """Terms × (estimate, stderr, t, P>|t|, ERR) as a pandas DataFrame."""
        try:
            import pandas as pd
        except ImportError as err:  # pragma: no cover - depends on the extra
            raise ImportError("to_frame needs pandas: pip install 'adaptid[pandas]'") from err
        err = np.concatenate([self.err, np.full(self.noise_lags, np.nan)])
        return pd.DataFrame({"estimate": self.theta, "stderr": self.stderr, "t": self.tvalues,
                             "P>|t|": self.pvalues, "ERR": err},
                            index=pd.Index(list(self.terms), name="term"))

    def plot(self, *, fig=None):
        """ERR of each selected term and, with a criterion, the criterion over the FROLS path.

        Returns
        -------
        matplotlib.figure.Figure
        """
        plt = pyplot()
        fig = plt.figure(figsize=(9, 3.5)) if fig is None else fig
        ax1, ax2 = fig.subplots(1, 2)
        pos = np.arange(len(self.terms))
        ax1.barh(pos[: self.err.size], self.err)
        ax1.set_yticks(pos, labels=list(self.terms))
        ax1.invert_yaxis()
        ax1.set_xlabel("ERR")
        ax1.set_title(f"{self.output}: terms in the order chosen")
        if self.path is not None:
            c = self.path[self.criterion]
            d = np.arange(1, c.size + 1)
            ax2.plot(d, c, marker=".")
            ax2.axvline(self.path["chosen"], color="k", lw=0.8, ls="--")
            ax2.set_ylabel(self.criterion.upper())
        else:
            ax2.plot(np.arange(1, self.err.size + 1), np.cumsum(self.err), marker=".")
            ax2.set_ylabel("cumulative ERR")
        ax2.set_xlabel("number of terms d")
        fig.tight_layout()
        return fig
