"""The report folder: PNG figures, ``index.html`` and ``estimates.csv``.

Figures are drawn on ``matplotlib.figure.Figure`` with the Agg canvas (no
pyplot, no GUI backend, no global state). The HTML page is self-contained:
inline CSS, figures linked by relative paths, no scripts and no external
resources (a data: URI stands in for the favicon, so a browser requests
nothing but the page and its figures).
"""

from __future__ import annotations

import csv
import html
import math
import os
import shutil
import tempfile
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from ._errors import CLIError

__all__ = ["Report", "tracks_figure", "errors_figure", "cusum_figure", "constancy_figure",
           "constancy_verdict"]


_CSS = """
body{font-family:-apple-system,"Segoe UI",Roboto,Helvetica,Arial,sans-serif;margin:0;
color:#1d2330;background:#f6f7f9}
header{background:#1d2b45;color:#fff;padding:18px 32px}
header h1{margin:0;font-size:22px}header p{margin:4px 0 0;color:#c8d1e0;font-size:13px}
main{max-width:1180px;margin:0 auto;padding:8px 32px 40px}
section{background:#fff;border:1px solid #dde2ea;border-radius:6px;margin:18px 0;padding:14px 20px}
h2{font-size:17px;margin:4px 0 10px;color:#1d2b45}
table{border-collapse:collapse;font-size:13px;margin:6px 0}
th,td{padding:4px 10px;border-bottom:1px solid #e6e9ef;text-align:right;white-space:nowrap}
th{background:#eef1f6;color:#1d2b45}td.l,th.l{text-align:left}
figure{margin:10px 0}figure img{max-width:100%;height:auto;border:1px solid #e6e9ef}
figcaption{font-size:13px;color:#4a5468;margin-top:4px}
p.note{font-size:13px;color:#4a5468}code{background:#eef1f6;padding:1px 4px;border-radius:3px}
ul.warn{color:#8a4b00;font-size:13px}
"""


def _require_matplotlib():
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError:  # pragma: no cover - the cli extra installs it
        raise CLIError("the report needs matplotlib: pip install 'adaptid[cli]'") from None
    return Figure, FigureCanvasAgg


def _fmt(v, digits=5) -> str:
    if v is None:
        return ""
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    try:
        f = float(v)
    except (TypeError, ValueError):
        return str(v)
    if math.isnan(f):
        return "—"
    return f"{f:.{digits}g}"


class Report:
    """Collects figures, tables and notes; :meth:`write` makes the folder."""

    def __init__(self, out_dir, title: str, subtitle: str = ""):
        self.out = Path(os.fspath(out_dir))
        self._created = not self.out.exists()
        try:
            self.out.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            raise CLIError(f"--out {self.out}: cannot create the report folder "
                           f"({err.strerror or err})") from None
        if not os.access(self.out, os.W_OK):
            raise CLIError(f"--out {self.out}: the folder is not writable")
        # files are written into a hidden staging folder inside ``out`` and moved
        # into place by write(): an interrupted or failed run leaves no partial report
        try:
            self._stage = Path(tempfile.mkdtemp(prefix=f".adaptid-report.{os.getpid()}.",
                                                dir=self.out))
        except OSError as err:
            raise CLIError(f"--out {self.out}: cannot write in the report folder "
                           f"({err.strerror or err})") from None
        _OPEN.add(self)
        self.title = title
        self.subtitle = subtitle
        self._parts = []
        self.files = []

    # ----------------------------------------------------------- contents
    def section(self, heading: str):
        self._parts.append(f"<section><h2>{html.escape(heading)}</h2>")
        return self

    def end(self):
        self._parts.append("</section>")
        return self

    def note(self, text: str, *, raw=False):
        self._parts.append(f'<p class="note">{text if raw else html.escape(text)}</p>')
        return self

    def warnings(self, items):
        if items:
            lis = "".join(f"<li>{html.escape(w)}</li>" for w in items)
            self._parts.append(f'<ul class="warn">{lis}</ul>')
        return self

    def table(self, columns, rows, *, left=1):
        head = "".join(f'<th class="{"l" if i < left else ""}">{html.escape(str(c))}</th>'
                       for i, c in enumerate(columns))
        body = []
        for row in rows:
            cells = "".join(
                f'<td class="{"l" if i < left else ""}">'
                f'{html.escape(v if isinstance(v, str) else _fmt(v))}</td>'
                for i, v in enumerate(row))
            body.append(f"<tr>{cells}</tr>")
        self._parts.append(f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>")
        return self

    def figure(self, filename: str, fig, caption: str):
        """Save ``fig`` (a matplotlib Figure) as ``filename`` and link it."""
        _, Canvas = _require_matplotlib()
        Canvas(fig)
        path = self._stage / filename
        try:
            fig.savefig(path, dpi=100, format="png")
        except OSError as err:
            raise CLIError(f"--out {self.out}: cannot write {filename} ({err.strerror or err})") from None
        w, h = (fig.get_size_inches() * 100).round().astype(int)
        self.files.append(filename)
        self._parts.append(
            f'<figure><img src="{html.escape(filename)}" width="{w}" height="{h}" '
            f'alt="{html.escape(caption)}"><figcaption>{html.escape(caption)}</figcaption></figure>')
        return self

    # -------------------------------------------------------------- output
    def write(self, estimates: list, *, commit=True) -> Path:
        """Write ``estimates.csv`` (rows: name, method, estimate, stderr, truth) and ``index.html``.

        With ``commit=False`` the files stay staged until :meth:`commit` (so a
        command can put its report in place only after its other outputs).
        """
        from adaptid import __version__

        csv_path = self._stage / "estimates.csv"
        try:
            with open(csv_path, "w", newline="", encoding="utf-8") as fh:
                w = csv.writer(fh)
                w.writerow(["name", "method", "estimate", "stderr", "truth"])
                for r in estimates:
                    w.writerow([r["name"], r["method"], _num(r.get("estimate")),
                                _num(r.get("stderr")), _num(r.get("truth"))])
        except OSError as err:
            raise CLIError(f"--out {self.out}: cannot write estimates.csv ({err.strerror or err})") from None
        self.files.append("estimates.csv")
        stamp = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
        doc = (
            "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">"
            "<link rel=\"icon\" href=\"data:,\">"
            f"<title>{html.escape(self.title)}</title><style>{_CSS}</style></head><body>"
            f"<header><h1>{html.escape(self.title)}</h1><p>{html.escape(self.subtitle)}</p></header><main>"
            + "".join(self._parts)
            + "<section><h2>Files</h2><p class=\"note\">Estimates as CSV: "
              "<a href=\"estimates.csv\">estimates.csv</a> (name, method, estimate, stderr, truth).</p>"
            + f"<p class=\"note\">Written by adaptid {html.escape(__version__)} on {stamp}.</p></section>"
            + "</main></body></html>\n")
        try:
            (self._stage / "index.html").write_text(doc, encoding="utf-8")
        except OSError as err:
            raise CLIError(f"--out {self.out}: cannot write index.html ({err.strerror or err})") from None
        self.files.append("index.html")
        if commit:
            self.commit()
        return self.out / "index.html"

    def commit(self):
        """Move the staged files into the report folder (each atomically, index.html last)."""
        try:
            for name in dict.fromkeys(self.files):
                os.replace(self._stage / name, self.out / name)
        except OSError as err:
            raise CLIError(f"--out {self.out}: cannot write {name} ({err.strerror or err})") from None
        self.discard()

    def discard(self):
        """Remove the staging folder (and ``out`` if this run created it and it is empty)."""
        _OPEN.discard(self)
        shutil.rmtree(self._stage, ignore_errors=True)
        if self._created:
            try:
                self.out.rmdir()  # only when empty: a finished report stays
            except OSError:
                pass


#: Reports being written by this process: removed by :func:`discard_open_reports`.
_OPEN: set = set()


def discard_open_reports() -> None:
    """Remove the staging folders of unfinished reports (after an error or a signal)."""
    for rep in list(_OPEN):
        rep.discard()


def _num(v):
    if v is None:
        return ""
    f = float(v)
    return "" if math.isnan(f) else repr(f)


# ------------------------------------------------------------------ figures
# The drawing is adaptid.plot's (public); these compose the report's panels.


def tracks_figure(panels, *, xlabel="sample", events=()):
    """Parameter tracks: one panel per parameter, several estimators per panel.

    ``panels``: list of dicts with ``name``, ``series`` (list of dicts with
    ``label``, ``x`` (N,), ``y`` (N,), optional ``xb``, ``lo``, ``hi`` (K,)
    for the band) and optional ``truth`` = (x, y).
    """
    from adaptid import plot

    _require_matplotlib()
    fig, axes = plot.panel_axes(len(panels))
    for ax, p in zip(axes, panels):
        for j, s in enumerate(p["series"]):
            c = plot.COLORS[j % len(plot.COLORS)]
            if s.get("xb") is not None:
                ax.fill_between(s["xb"], s["lo"], s["hi"], color=c, alpha=0.18, lw=0)
            last = j == len(p["series"]) - 1
            plot.tracks(s["x"], s["y"], [p["name"]], label=s["label"], color=c, xlabel=xlabel,
                        truth=p.get("truth") if last else None, events=events if last else (),
                        ax=[ax])
    handles, labels = axes[0].get_legend_handles_labels()
    if handles:
        fig.legend(handles, labels, loc="outside upper center", ncol=len(labels), fontsize=9,
                   frameon=False)
    return fig


def errors_figure(rows, *, xlabel="sample"):
    """Prediction errors: ``rows`` = list of (title, [(label, x, e), ...])."""
    from adaptid import plot

    _require_matplotlib()
    fig = plot.new_figure((11, 2.4 * len(rows) + 0.4))
    axes = fig.subplots(len(rows), 1, squeeze=False)[:, 0]
    for ax, (title, series) in zip(axes, rows):
        for j, (label, x, e) in enumerate(series):
            plot.prediction_errors(x, e, label=label, color=plot.COLORS[j % len(plot.COLORS)],
                                   ax=ax)
        plot.symmetric_limits(ax, [e for _, _, e in series])
        plot.finish_errors_axes(ax, title, xlabel, len(series))
    return fig


def cusum_figure(items, *, xlabel="sample"):
    """CUSUM panels: ``items`` = list of (title, x (m,), CusumResult)."""
    from adaptid import plot

    _require_matplotlib()
    fig = plot.new_figure((11, 2.6 * len(items) + 0.4))
    axes = fig.subplots(len(items), 1, squeeze=False)[:, 0]
    for ax, (title, x, res) in zip(axes, items):
        plot.cusum(x, res, title=title, xlabel=xlabel, ax=ax)
    return fig


def constancy_verdict(checks) -> str:
    """One sentence: "no evidence of change" only when every test shown agrees."""
    tests = checks.get("tests")
    if tests is None:
        crossed = checks["result"].crossed or checks["squares"].crossed
        return ("the CUSUM tests reject constant parameters" if crossed else
                "no evidence of change in the CUSUM tests (too few samples for the F tests)")
    if tests.no_change:
        return "no evidence of change (CUSUM, CUSUM of squares, supF, RE and Nyblom–Hansen agree)"
    which = ", ".join(tests.rejected)
    dates = checks.get("breaks") or ()
    when = f"; break(s) dated after sample(s) {', '.join(str(int(b)) for b in dates)}" \
        if dates else ""
    return f"parameters not constant: rejected by {which} at 5 %{when}"


def constancy_figure(fits, xaxis, *, xlabel="sample"):
    """Per fit: CUSUM, CUSUM of squares and the F statistics with the dated breaks."""
    from adaptid import plot

    _require_matplotlib()
    fig = plot.new_figure((11, 2.6 * 3 * len(fits) + 0.4))
    axes = fig.subplots(3 * len(fits), 1, squeeze=False)[:, 0]
    for i, f in enumerate(fits):
        c = f.cusum
        x = xaxis(f.index[c["rows"]])
        a1, a2, a3 = axes[3 * i: 3 * i + 3]
        plot.cusum(x, c["result"], title=f.title, xlabel=xlabel, ax=a1)
        plot.cusum(x, c["squares"], title=f.title, xlabel=xlabel, ax=a2,
                   label="CUSUM of squares")
        if c["fstats"] is not None:
            xs = xaxis(f.index)
            pos = {int(r): j for j, r in enumerate(c["all_rows"])}
            xf = np.asarray(xs)[c["all_rows"]]
            plot.fstats(xf, c["fstats"], breaks=[pos[int(b)] for b in c["breaks"]],
                        title=f.title, xlabel=xlabel, ax=a3)
        else:
            a3.set_visible(False)
    return fig
