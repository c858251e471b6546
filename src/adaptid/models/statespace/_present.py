r"""How a state-space model presents itself: summary (text, HTML), table, figure."""

from __future__ import annotations

import html
from dataclasses import dataclass, field

import numpy as np

from ..._summary import _fmt
from ..._lazy import pyplot

__all__ = ["StateSpaceSummary", "StateSpacePresentation"]


@dataclass(frozen=True, eq=False)
class StateSpaceSummary:
    r"""Summary of a :class:`~adaptid.models.StateSpaceModel`.

    Attributes
    ----------
    title : str
    stats : dict
        Label → value (order, signals, method, horizon, N, fit %, …).
    matrices : tuple of (name, ndarray, row labels, column labels)
        A, B, C, D, K, the innovation covariance and the poles.
    notes : tuple of str
    """

    title: str
    stats: dict
    matrices: tuple
    notes: tuple = field(default=())

    def __getitem__(self, label):
        """A statistic by its label, e.g. ``summary["order"]``."""
        return self.stats[label]

    def as_text(self) -> str:
        """The summary as fixed-width text."""
        kw = max((len(str(k)) for k in self.stats), default=0)
        out = [self.title, "=" * max(len(self.title), 40)]
        out += [f"{str(k).ljust(kw)}  {_fmt(v)}" for k, v in self.stats.items()]
        for name, M, rows, cols in self.matrices:
            cells = [[""] + list(cols)] + [[r] + [_fmt(v) for v in row] for r, row in zip(rows, M)]
            widths = [max(len(c[j]) for c in cells) for j in range(len(cells[0]))]
            out += ["", f"{name}:"]
            out += ["  " + "  ".join(c.rjust(w) for c, w in zip(line, widths)) for line in cells]
        out += ["=" * max(len(self.title), 40), *self.notes]
        return "\n".join(out)

    __str__ = as_text
    __repr__ = as_text

    def _repr_html_(self) -> str:
        esc = html.escape
        st = "".join(f"<tr><th style='text-align:left'>{esc(str(k))}</th><td>{esc(_fmt(v))}</td></tr>"
                     for k, v in self.stats.items())
        blocks = []
        for name, M, rows, cols in self.matrices:
            head = "<th></th>" + "".join(f"<th>{esc(str(c))}</th>" for c in cols)
            body = "".join(f"<tr><th>{esc(str(r))}</th>" + "".join(f"<td>{esc(_fmt(v))}</td>"
                                                                 for v in row) + "</tr>"
                           for r, row in zip(rows, M))
            blocks.append(f"<p><strong>{esc(name)}</strong></p><table><thead><tr>{head}</tr>"
                          f"</thead><tbody>{body}</tbody></table>")
        notes = "".join(f"<p>{esc(n)}</p>" for n in self.notes)
        return (f"<div><strong>{esc(self.title)}</strong><table>{st}</table>{''.join(blocks)}"
                f"{notes}</div>")


class StateSpacePresentation:
    """summary / to_frame / plot of :class:`StateSpaceModel` (a mixin)."""

    def _labels(self):
        xs = tuple(f"x{i + 1}" for i in range(self.order))
        return xs, tuple(self.y_names), tuple(self.u_names)

    def _fit_stats(self):
        """Fit % (simulation from the estimated x0, one-step prediction) on the estimation data."""
        from ..._teststats import fit_percent

        ex = self._fit_data if self._fit_data is not None else getattr(self, "_fit_dask", None)
        if ex is None or len(ex.Y) != 1:
            return {}
        Y, U = ex.Y[0], ex.U[0]
        if self._fit_data is None:                   # Dask: one pass over the chunks
            from ._passes import fit_percent_chunked

            fit_s, fit_p, varies = fit_percent_chunked(self, Y, U)
        else:
            ysim = self.simulate((Y, U), x0="estimate")
            y1 = self.predict(Y, U, k=1)
            varies = np.ptp(Y, axis=0) > 0
            fit_s = [fit_percent(Y[:, i], ysim[:, i]) if varies[i] else None
                     for i in range(Y.shape[1])]
            fit_p = [fit_percent(Y[:, i], y1[:, i]) if varies[i] else None
                     for i in range(Y.shape[1])]
        out = {}
        for i, name in enumerate(self.y_names):
            if varies[i]:
                out[f"fit % {name} (simulation, x0 estimated)"] = float(fit_s[i])
                out[f"fit % {name} (1-step prediction)"] = float(fit_p[i])
        return out

    def summary(self):
        r"""The model's summary: sizes, how it was estimated, fit %, matrices and poles.

        The fit percentages (MATLAB's NRMSE, :func:`adaptid.diagnostics.fit_percent`)
        are on the estimation record (one experiment): of the simulation from
        the least-squares initial state (:meth:`estimate_x0`) and of the
        one-step prediction from a zero initial state.

        Returns
        -------
        StateSpaceSummary
            Text when printed, HTML in a notebook.
        """
        xs, ys, us = self._labels()
        info = self.info
        stats = {"order": self.order, "outputs": ", ".join(ys), "inputs": ", ".join(us),
                 "dt": self.dt}
        for key in ("method", "horizon", "samples", "experiments", "order rule", "criterion"):
            if key in info:
                stats[key] = info[key]
        stats.update(self._fit_stats())
        poles = np.linalg.eigvals(self.A)   # (with standard deviations: self.poles())
        mats = [("A", self.A, xs, xs), ("B", self.B, xs, us), ("C", self.C, ys, xs),
                ("D", self.D, ys, us), ("K", self.K, xs, ys), ("noise_cov", self.noise_cov, ys, ys),
                ("poles", np.column_stack([poles.real, poles.imag, np.abs(poles)]),
                 tuple(f"p{i + 1}" for i in range(poles.size)), ("real", "imag", "|p|"))]
        notes = []
        if self.singular_values is not None:
            sv = self.singular_values[: 2 * self.order + 4]
            notes.append("singular values: " + ", ".join(_fmt(float(v)) for v in sv)
                         + (" …" if self.singular_values.size > sv.size else ""))
        return StateSpaceSummary(title=f"State-space model, order {self.order}", stats=stats,
                                 matrices=tuple(mats), notes=tuple(notes))

    def _repr_html_(self):
        return self.summary()._repr_html_()

    def to_frame(self):
        """Every entry of A, B, C, D, K and ``noise_cov`` as a long pandas table.

        Columns ``matrix``, ``row``, ``column`` (state, output and input names)
        and ``value`` (``pip install 'adaptid[pandas]'``).
        """
        try:
            import pandas as pd
        except ImportError as err:  # pragma: no cover - depends on the extra
            raise ImportError("to_frame needs pandas: pip install 'adaptid[pandas]'") from err
        xs, ys, us = self._labels()
        rows = []
        for name, M, rl, cl in (("A", self.A, xs, xs), ("B", self.B, xs, us),
                                ("C", self.C, ys, xs), ("D", self.D, ys, us),
                                ("K", self.K, xs, ys), ("noise_cov", self.noise_cov, ys, ys)):
            rows += [(name, r, c, float(M[i, j])) for i, r in enumerate(rl)
                     for j, c in enumerate(cl)]
        return pd.DataFrame(rows, columns=["matrix", "row", "column", "value"])

    def plot(self, fig=None, *, n=None):
        """Singular values (the order marked) when the model has them, else the step response
        (:meth:`StepResponse.plot`, with bands when the model has a covariance).

        Parameters
        ----------
        fig : matplotlib Figure, optional
        n : int, optional
            Samples of the step response (default 50).

        Returns
        -------
        matplotlib.figure.Figure
        """
        plt = pyplot()
        if fig is None:
            fig = plt.figure(figsize=(6.5, 4))
        if self.singular_values is not None:
            ax = fig.subplots()
            sv = self.singular_values
            k = np.arange(1, sv.size + 1)
            ax.semilogy(k, np.maximum(sv, np.finfo(float).tiny), "o-", ms=4, lw=0.8)
            ax.axvline(self.order + 0.5, color="0.5", ls="--", lw=0.8)
            ax.set_xlabel("index")
            ax.set_ylabel("singular value")
            ax.set_title(f"{self.info.get('method', 'singular values')}: order {self.order}")
            return fig
        sr = self.step_response(50 if n is None else n)
        return sr.plot(fig=fig)
