r"""``adaptid demo``: identify the simulated DC motor with three recursive estimators.

Data: :func:`adaptid.datasets.dc_motor` (60 s at 1 kHz; the winding heats up
so R drifts by ~20 %, a load coupled at 30 s triples J and B). Regressors:
:func:`adaptid.models.dc_motor_regressors` (electrical θ = [R, L, Kₑ],
mechanical θ = [J, B, τc, τ0]/Kₜ). Each equation is identified by

* ``rls`` — :class:`adaptid.RLS` with exponential forgetting λ = 0.999
  (memory 1/(1−λ) = 1000 samples = 1 s);
* ``window`` — :class:`adaptid.SlidingWindowRLS`, the last M = 1000 samples
  (the same memory);
* ``kalman`` — :class:`adaptid.KalmanRLS`, random walk with
  R₁ = diag((ρ θ̂ᵢ)²), ρ = 10⁻⁴ per sample, and R₂ = σ̂², both taken from a
  batch fit of the first 5 s (the commissioning an engineer would do);

all with P₀ = 10⁶·I. Tracking delay: the time after the load step until the
estimate of J enters, and stays in, ±5 % of its new true value. RMS
prediction error: of the a-priori errors after the first 0.5 s.
"""

from __future__ import annotations

import time as _time

import numpy as np

from . import _prewarm
from ._engine import MethodSpec, fit_equation
from ._errors import CLIError
from ._output import Output
from ._physical import physical_tracks

__all__ = ["run_demo", "DEMO_METHODS", "tracking_delay"]

FORGETTING = 0.999
WINDOW = 1000
KALMAN_RATE = 1e-4
P0 = 1e6
COMMISSION_S = 5.0
N_CHUNKS = 200
SETTLE_TOL = 0.05
PARAMS = ("R", "L", "Ke", "J", "B", "tau_c", "tau_0")
UNITS = {"R": "Ω", "L": "H", "Ke": "V·s/rad", "Kt": "N·m/A", "J": "kg·m²", "B": "N·m·s/rad",
         "tau_c": "N·m", "tau_0": "N·m"}
# display: (label, scale) so that the tables show numbers of order 1
DISPLAY = {"R": ("R [Ω]", 1.0), "L": ("L [mH]", 1e3), "Ke": ("Ke [mV·s/rad]", 1e3),
           "J": ("J [10⁻⁴ kg·m²]", 1e4), "B": ("B [10⁻⁴ N·m·s/rad]", 1e4),
           "tau_c": ("τc [mN·m]", 1e3), "tau_0": ("τ0 [mN·m]", 1e3)}
DEMO_METHODS = ("rls", "window", "kalman")
#: Compiled by a helper process while the others run (:mod:`._prewarm`).
PREWARMED = ("window",)


def tracking_delay(t, estimate, truth, t_step, tol=SETTLE_TOL) -> float:
    """Time after ``t_step`` until ``estimate`` enters and stays within ``tol`` of ``truth``.

    NaN if it is outside at the last sample.
    """
    after = t >= t_step
    if not after.any():
        return float("nan")
    rel = np.abs(estimate[after] / truth[after] - 1.0)
    outside = ~(rel <= tol)
    if outside[-1]:
        return float("nan")
    idx = np.flatnonzero(outside)
    ta = t[after]
    return 0.0 if idx.size == 0 else float(ta[idx[-1] + 1] - t_step)


def demo_spec(method, *, theta=None, sigma2=None):
    """The demo's estimator for ``method``; Kalman's R₁, R₂ from a commissioning fit
    (θ̂, σ̂²)."""
    if method == "rls":
        return MethodSpec("rls", forgetting=FORGETTING, P0=P0)
    if method == "window":
        return MethodSpec("window", window=WINDOW, P0=P0)
    return _KalmanSpec(theta, sigma2)


def compile_kernels(methods):
    """In :mod:`._prewarm`'s helper: run each method's estimator as the demo makes it
    (generic kernels, the same array types) on a few rows of zeros."""
    from adaptid.estimators import size_generic_kernels

    from ._engine import run_chunked

    Phi = np.zeros((4, 3))
    y = np.zeros(4)
    with size_generic_kernels():
        for m in methods:
            est = demo_spec(m, theta=np.ones(3), sigma2=1.0).make(3, "raise")
            run_chunked(est, Phi, y, n_chunks=2)


def _specs(regs, dt):
    import adaptid

    k = int(round(COMMISSION_S / dt))
    k0 = int(round(0.2 / dt))
    specs = {}
    specs["rls"] = lambda title: demo_spec("rls")
    specs["window"] = lambda title: demo_spec("window")
    comm = {}
    for title, reg in (("electrical", regs.electrical), ("mechanical", regs.mechanical)):
        res = adaptid.lstsq(reg.Phi[k0:k], reg.y[k0:k])
        comm[title] = res
    specs["kalman"] = lambda title: demo_spec("kalman", theta=comm[title].theta,
                                              sigma2=comm[title].sigma2)
    return specs


class _KalmanSpec(MethodSpec):
    """Kalman random walk with R₁ = diag((ρ θ̂)²), R₂ = σ̂² from a commissioning fit."""

    def __init__(self, theta, sigma2):
        super().__init__("kalman", process_cov=1.0, noise_var=float(sigma2), P0=P0)
        self._Q = np.diag((KALMAN_RATE * np.abs(theta)) ** 2 + 1e-300)

    def make(self, n, nan_policy):
        from adaptid.estimators import estimator

        return estimator("kalman", n, process_cov=self._Q, noise_var=self.noise_var, P0=self.P0,
                         nan_policy=nan_policy)

    def label(self, est=None):
        return f"Kalman ρ={KALMAN_RATE:g}"


def run_demo(*, out_dir, seed: int, output: Output) -> dict:
    t0 = _time.perf_counter()
    # a helper process compiles the window's kernels meanwhile
    helper = _prewarm.start(__name__, "compile_kernels", PREWARMED,
                            unless_cached=("_window._window_core", "_window.window_run"))
    try:
        from adaptid.datasets import dc_motor
        from adaptid.models import dc_motor_regressors
    except ImportError as err:
        raise CLIError(f"the demo needs pandas: pip install 'adaptid[cli]' ({err})") from None
    data, truth = dc_motor(seed=seed)
    dt = float(data.attrs.get("dt", data.time.iloc[1] - data.time.iloc[0]))
    t_load = float(data.attrs["load_time"])
    t = data.time.to_numpy()
    # the simulated speed sensor differences encoder counts: a mean over the
    # last interval, which the regressors model exactly with "interval_mean"
    regs = dc_motor_regressors(t, data.voltage.to_numpy(), data.current.to_numpy(),
                               data.speed.to_numpy(), speed_kind="interval_mean")
    output.detail(f"dc_motor(seed={seed}): {len(data)} samples, dt={dt:g} s, load at {t_load:g} s "
                  f"({_time.perf_counter() - t0:.2f} s)")
    specs = _specs(regs, dt)
    eqs = (("electrical", regs.electrical), ("mechanical", regs.mechanical))
    total = len(DEMO_METHODS) * sum(len(r.y) for _, r in eqs)
    fits = {}
    with output.progress(total, "identifying") as advance:
        # the prewarmed methods last: by then the helper has compiled them
        for m in sorted(DEMO_METHODS, key=lambda m: m in PREWARMED):
            if m in PREWARMED:
                _prewarm.wait(helper)
            fits[m] = {title: fit_equation(title, list(reg.names), reg.Phi, np.asarray(reg.y, float),
                                           np.asarray(reg.index), specs[m](title), n_chunks=N_CHUNKS,
                                           advance=advance, want_cusum=False)
                       for title, reg in eqs}
    fits = {m: fits[m] for m in DEMO_METHODS}
    for m in DEMO_METHODS:
        for f in fits[m].values():
            for w in f.warnings:
                output.warn(f"{m} {f.title}: {w}")

    idx = np.asarray(regs.electrical.index)
    tt = t[idx]
    warm = int(round(0.5 / dt))
    last = truth.iloc[idx[-1]]
    summary = {}
    tracks = {}
    for m in DEMO_METHODS:
        fe, fm = fits[m]["electrical"], fits[m]["mechanical"]
        full = regs.physical(fe.track, fm.track)
        ends = fe.ends
        band = physical_tracks(regs, fe.track[ends], fe.cov_ends, fm.track[ends], fm.cov_ends)
        tracks[m] = (full, ends, band)
        params = {}
        for p in PARAMS:
            est = float(full[p][-1])
            tru = float(last[p])
            params[p] = {"estimate": est, "stderr": float(band[p][1][-1]), "truth": tru,
                         "rel_error": est / tru - 1.0}
        delay = tracking_delay(tt, full["J"], truth.J.to_numpy()[idx], t_load)
        rms = {title: float(np.sqrt(np.nanmean(fits[m][title].error[warm:] ** 2)))
               for title in ("electrical", "mechanical")}
        summary[m] = {"label": fe.label, "parameters": params, "delay_J_s": delay,
                      "rms_error": rms, "n_skipped": fe.n_skipped + fm.n_skipped}
    result = {"seed": seed, "n_samples": int(len(data)), "dt": dt, "load_time": t_load,
              "settle_tolerance": SETTLE_TOL, "methods": summary}
    if out_dir is not None:
        result["report"] = str(_report(out_dir, regs, fits, tracks, summary, truth, t, idx, t_load,
                                       seed, len(data), dt))
    result["elapsed_s"] = _time.perf_counter() - t0
    _print(output, result)
    return result


def _print(output: Output, result):
    if not output.chatty:
        return
    from ._output import rich_table

    c = output.console
    summ = result["methods"]
    c.print(f"adaptid demo: simulated DC motor (seed {result['seed']}), "
            f"{result['n_samples']} samples at {1 / result['dt']:g} Hz, load coupled at "
            f"{result['load_time']:g} s", markup=False, soft_wrap=True)
    rows = []
    for p in PARAMS:
        label, scale = DISPLAY[p]
        row = [label, f"{scale * summ[DEMO_METHODS[0]]['parameters'][p]['truth']:.4g}"]
        for m in DEMO_METHODS:
            q = summ[m]["parameters"][p]
            row.append(f"{scale * q['estimate']:.4g} ({100 * q['rel_error']:+.2f} %)")
        rows.append(row)
    c.print(rich_table("final estimates (relative error to the truth at the last sample)",
                       ["parameter", "truth"] + [summ[m]["label"] for m in DEMO_METHODS], rows))
    rows = []
    for m in DEMO_METHODS:
        s = summ[m]
        d = s["delay_J_s"]
        rows.append([s["label"], "not settled" if np.isnan(d) else f"{d:.2f}",
                     f"{s['rms_error']['electrical']:.4g}", f"{s['rms_error']['mechanical']:.4g}"])
    c.print(rich_table("tracking and prediction", ["method", "J delay after load [s]",
                                                   "RMS ε electrical [V]", "RMS ε mechanical [A]"],
                       rows))
    c.print(f"J delay: time after the load step until the J estimate stays within "
            f"±{100 * result['settle_tolerance']:g} % of its new true value.",
            markup=False, soft_wrap=True)
    if "report" in result:
        c.print(f"report: {result['report']}", markup=False, soft_wrap=True)
    c.print(f"done in {result['elapsed_s']:.1f} s", markup=False, soft_wrap=True)


def _summary_section(rep, fits, summary):
    """The report's first section: final estimates against the truth, delays, RMS errors."""
    rep.section("Summary")
    rep.note("Final estimates at the last sample, with the relative error to the simulator's "
             "truth at that sample (R drifts as the winding heats; J and B step at the load).")
    rows = []
    for p in PARAMS:
        label, scale = DISPLAY[p]
        row = [label, scale * summary[DEMO_METHODS[0]]["parameters"][p]["truth"]]
        for m in DEMO_METHODS:
            q = summary[m]["parameters"][p]
            row.append(f"{scale * q['estimate']:.4g} ({100 * q['rel_error']:+.2f} %)")
        rows.append(row)
    rep.table(["parameter", "truth"] + [summary[m]["label"] for m in DEMO_METHODS], rows)
    rows = []
    for m in DEMO_METHODS:
        s = summary[m]
        d = s["delay_J_s"]
        rows.append([s["label"], "not settled" if np.isnan(d) else f"{d:.2f}",
                     s["rms_error"]["electrical"], s["rms_error"]["mechanical"]])
    rep.table(["method", "J delay after load [s]", "RMS ε electrical [V]", "RMS ε mechanical [A]"],
              rows)
    rep.note(f"J delay: time after the load step until the J estimate enters and stays within "
             f"±{100 * SETTLE_TOL:g} % of its new true value. RMS ε: a-priori prediction errors "
             "after the first 0.5 s. RLS: forgetting λ = "
             f"{FORGETTING:g}; sliding window: M = {WINDOW} samples; Kalman: random walk "
             f"R₁ = diag((ρθ̂)²), ρ = {KALMAN_RATE:g}, R₂ = σ̂² from a batch fit of the first "
             f"{COMMISSION_S:g} s; P₀ = {P0:g}·I.")
    rep.warnings([f"{m} {f.title}: {w}" for m in DEMO_METHODS for f in fits[m].values()
                  for w in f.warnings])


def _report(out_dir, regs, fits, tracks, summary, truth, t, idx, t_load, seed, N, dt):
    from adaptid.diagnostics import cusum, recursive_residuals

    from ._report import Report, cusum_figure, errors_figure, tracks_figure

    rep = Report(out_dir, "adaptid demo: DC motor identification",
                 f"simulated permanent-magnet DC motor (adaptid.datasets.dc_motor, seed {seed}) · "
                 f"{N} samples at {1 / dt:g} Hz · load coupled at {t_load:g} s")
    _summary_section(rep, fits, summary)
    rep.end()

    tt = t[idx]
    panels = []
    for p in PARAMS:
        label, c = DISPLAY[p]
        series = []
        for m in DEMO_METHODS:
            full, ends, band = tracks[m]
            v, s = band[p]
            series.append({"label": summary[m]["label"], "x": tt, "y": c * full[p], "xb": tt[ends],
                           "lo": c * (v - 2 * s), "hi": c * (v + 2 * s)})
        panels.append({"name": label, "series": series,
                       "truth": (tt, c * truth[p].to_numpy()[idx])})
    rep.section("Parameter tracks")
    rep.figure("tracks.png", tracks_figure(panels, xlabel="time [s]", events=(t_load,)),
               "Physical parameters after each sample, with ±2σ bands (σ̂² × diag(P), σ̂² by "
               "adaptid.recursive_fit_stats, mapped by the delta method), and the truth (dashed). "
               "Dotted line: load coupled.")
    rep.end()
    rows = []
    for title, unit in (("electrical", "V"), ("mechanical", "A")):
        rows.append((f"{title} equation: a-priori prediction error [{unit}]",
                     [(summary[m]["label"], tt, fits[m][title].error) for m in DEMO_METHODS]))
    rep.section("Prediction error")
    rep.figure("errors.png", errors_figure(rows, xlabel="time [s]"),
               "A-priori errors ε = y − φᵀθ̂ of each equation (first transient clipped).")
    rep.end()
    items = []
    for title, reg in (("electrical", regs.electrical), ("mechanical", regs.mechanical)):
        k0 = int(round(0.2 / dt))
        w = recursive_residuals(reg.Phi[k0:], reg.y[k0:])
        ok = np.isfinite(w)
        x = tt[k0 + reg.Phi.shape[1]:][ok]
        items.append((f"{title} equation", x, cusum(w[ok])))
    rep.section("Parameter constancy (CUSUM)")
    rep.figure("cusum.png", cusum_figure(items, xlabel="time [s]"),
               "CUSUM of the recursive residuals of a constant-parameter least-squares fit "
               "(Brown, Durbin & Evans 1975) with its 95 % bounds: crossing them rejects "
               "constant parameters (the heating winding and the load).")
    rep.end()
    estimates = []
    for m in DEMO_METHODS:
        for p in PARAMS + ("Kt",):
            full, ends, band = tracks[m]
            tru = float(truth[p].to_numpy()[idx[-1]])
            estimates.append({"name": p, "method": m, "estimate": float(full[p][-1]),
                              "stderr": float(band[p][1][-1]), "truth": tru})
    return rep.write(estimates)
