r"""Statistics and presentation of the MIMO ARX model: summary, table, figure.

With n the number of rows (prediction errors per output), d the total
number of parameters and :math:`V = \det(E^TE/n)` (MATLAB's loss function
of a multi-output model):

.. math::

    \mathrm{AIC} = n\log V + 2d + n\,n_y(\log 2\pi + 1),\qquad
    \mathrm{FPE} = V\,\frac{1 + d/n}{1 - d/n}

(Ljung 1999, sec. 16.4 and eq. 16.31; MATLAB's ``aic`` and ``fpe``).
"""

from __future__ import annotations

import numpy as np

from ..._validation import check_scalar

__all__ = ["Presentation"]


class Presentation:
    """Statistics, summary(), to_frame(), plot() of :class:`MIMOARX` (a mixin)."""

    @property
    def stderr(self):
        """Standard errors √diag(cov), shape (d,)."""
        self._check_fitted()
        return np.sqrt(np.clip(np.diag(self.cov), 0.0, None))

    @property
    def thetas(self):
        """θ of each equation: a tuple of ny arrays (d_i,)."""
        self._check_fitted()
        return tuple(self.theta[s] for s in self._slices)

    @property
    def cov_blocks(self):
        """Covariance of each equation's θ_i alone: a tuple of ny arrays (d_i, d_i)."""
        self._check_fitted()
        return tuple(self.cov[s, s] for s in self._slices)

    @property
    def noise_variance(self):
        """Innovation variances, the diagonal of ``noise_cov``, shape (ny,)."""
        self._check_fitted()
        return np.diag(self.noise_cov).copy()

    @property
    def loss(self):
        r"""MATLAB's loss function :math:`\det(E^TE/n)` of the fit's prediction errors."""
        self._check_fitted()
        E = self.residuals
        return float(np.linalg.det(E.T @ E / E.shape[0]))

    @property
    def aic(self):
        """Akaike's criterion of the Gaussian likelihood (module docstring)."""
        n, ny = self.residuals.shape
        return float(n * np.log(self.loss) + 2 * self.n_params
                     + n * ny * (np.log(2 * np.pi) + 1.0))

    @property
    def fpe(self):
        """Akaike's final prediction error (module docstring)."""
        n, d = self.residuals.shape[0], self.n_params
        return float("inf") if n <= d else float(self.loss * (1 + d / n) / (1 - d / n))

    def _fit_percents(self):
        """Fit % per output of the 1-step prediction and of the simulation, every experiment."""
        from ..._teststats import fit_percent

        ex = self._fit_records
        Ys = np.vstack(ex.Y)
        one = np.vstack([self.predict((Y, U)) for Y, U in zip(ex.Y, ex.U)])
        sim = np.vstack([self.simulate(U) for U in ex.U])
        out = {}
        for i, name in enumerate(self.y_names):
            if np.ptp(Ys[:, i]) > 0:
                out[f"fit % {name} (1-step, estimation)"] = fit_percent(Ys[:, i], one[:, i])
                out[f"fit % {name} (simulation, estimation)"] = fit_percent(Ys[:, i], sim[:, i])
        return out

    def summary(self, *, alpha=0.05):
        r"""The fit's summary: every parameter with its t test, per-output σ̂ and fit %.

        Parameter rows as :func:`adaptid.models.model_summary` (t with the
        equation's n − d_i degrees of freedom); statistics: rows, experiments,
        loss, AIC, FPE, the innovation covariance and the fit % (MATLAB's
        NRMSE) of the one-step prediction and of the simulation (zero
        initial conditions) of each output on the estimation data.

        Parameters
        ----------
        alpha : float
            Level of the confidence limits (default 0.05).

        Returns
        -------
        adaptid._summary.Summary
        """
        from ..._summary import Summary, parameter_rows

        self._check_fitted()
        alpha = check_scalar(alpha, "alpha", low=0.0, high=1.0, low_open=True, high_open=True)
        n = self.residuals.shape[0]
        se = self.stderr
        rows = [parameter_rows(self.theta[s], se[s], n - (s.stop - s.start), alpha)
                for s in self._slices]
        st = {"N (rows per output)": n, "experiments": len(self._fit_records.Y),
              "parameters": self.n_params, "regressors": "shared (one QR)"
              if self._orders.shared else "per equation", "loss det(E'E/n)": self.loss,
              "AIC": self.aic, "FPE": self.fpe}
        for i, yi in enumerate(self.y_names):
            for j, yj in enumerate(self.y_names[: i + 1]):
                st[f"noise_cov[{yi}, {yj}]"] = float(self.noise_cov[i, j])
        st.update(self._fit_percents())
        notes = (f"outputs: {', '.join(self.y_names)}; inputs: {', '.join(self.u_names)}",
                 "a{l}_yi_yj: coefficient of yj(k-l) in the equation of yi; "
                 "b{l}_yi_uj: of uj(k-nk[i,j]-l)",
                 "noise_cov[i, j] = e_i'e_j / sqrt((n - d_i)(n - d_j)); cov couples the equations")
        return Summary(title=repr(self).split(" [")[0], names=self.names,
                       params=np.vstack(rows), stats=st, alpha=alpha, notes=notes)

    def to_frame(self):
        """The parameters as a pandas table.

        Columns ``name``, ``output`` (the equation), ``regressor`` (the
        output or input it multiplies), ``lag`` (samples), ``estimate``,
        ``stderr``.
        """
        import pandas as pd

        self._check_fitted()
        rows = []
        for i, cols in enumerate(self._layout):
            for kind, j, l, name in cols:
                lag = l if kind == "a" else int(self._orders.nk[i, j]) + l
                src = self.y_names[j] if kind == "a" else self.u_names[j]
                rows.append((name, self.y_names[i], src, lag))
        df = pd.DataFrame(rows, columns=["name", "output", "regressor", "lag"])
        df["estimate"], df["stderr"] = self.theta, self.stderr
        return df

    def plot(self, fig=None):
        """Measured and simulated outputs on the first estimation experiment, fit % in the legend.

        Returns
        -------
        matplotlib.figure.Figure
        """
        from ..._lazy import pyplot
        from ..._teststats import fit_percent

        self._check_fitted()
        plt = pyplot()
        Y, U = self._fit_records.Y[0], self._fit_records.U[0]
        sim = self.simulate(U)
        if fig is None:
            fig = plt.figure(figsize=(6.5, 2.2 * Y.shape[1]), layout="constrained")
        axes = fig.subplots(Y.shape[1], 1, squeeze=False, sharex=True)[:, 0]
        t = np.arange(Y.shape[0]) * self.dt
        for i, (ax, name) in enumerate(zip(axes, self.y_names)):
            ax.plot(t, Y[:, i], color="k", lw=1.0, label=f"{name} (measured)")
            f = fit_percent(Y[:, i], sim[:, i]) if np.ptp(Y[:, i]) > 0 else float("nan")
            ax.plot(t, sim[:, i], lw=1.0, label=f"simulation: {f:.2f} %")
            ax.set_ylabel(name)
            ax.legend(loc="best", fontsize="small")
        axes[-1].set_xlabel("time")
        fig.suptitle("MIMO ARX: simulation on the estimation data", fontsize=10)
        return fig
