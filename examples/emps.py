r"""EMPS benchmark: IDIM-LS identification of a prismatic axis, then tracking.

The Electro-Mechanical Positioning System (Janot, Gautier & Brunot 2019) is
a prismatic joint driven by a DC motor under PD position control. Its
inverse dynamic model is linear in the parameters,

    tau = gtau * vir = M * qdd + Fv * qd + Fc * sign(qd) + offset,

and the benchmark publishes the result of its IDIM-LS procedure (the
``Script_IDIM_LS.m`` of the benchmark; description document §3.4). This
script repeats that procedure step by step, with MATLAB-compatible
filtering from :mod:`adaptid.datasets`:

1. ``qm`` low-pass filtered, zero phase: ``butter(4, 100/500)`` with MATLAB's
   ``filtfilt`` (:func:`adaptid.datasets.matlab_filtfilt`);
2. ``qd`` and ``qdd`` by the central difference ``diffcent`` applied twice
   (:func:`adaptid.datasets.central_difference`), Ts = 1 ms;
3. the first 49 samples dropped (MATLAB keeps ``50:N``);
4. the observation matrix ``X0 = [qdd, qd, sign(qd), 1]``;
5. every column of ``X0`` and the force ``gtau*vir`` decimated by 10 with
   MATLAB's ``decimate`` (:func:`adaptid.datasets.matlab_decimate`);
6. ``beta = X \ y``; standard deviations ``std(e) * sqrt(diag(inv(X'X)))``
   with MATLAB's ``std`` (N − 1); relative error ``100 |e| / |y|``.

The estimates are then cross-tested on the validation run (force pulses,
``DATA_EMPS_PULSES.mat``), and, unless ``--no-tracking``, the same
regression is tracked sample by sample with :class:`adaptid.RLS` and
:class:`adaptid.SlidingWindowRLS`, with a figure of the tracks converging to
the published values (``--out`` folder), and the recursive-residual
diagnostics (CUSUM, CUSUM of squares) of the fit are printed. Until the
velocity first changes sign (t ≈ 3 s) the columns sign(qd) and 1 are equal,
so Fc and offset are separately unidentifiable and their early tracks swing
widely; RLS with λ = 1 ends exactly at the batch estimate (it *is* least
squares, up to the negligible prior P0 = 1e8 I), the forgetting and window
variants keep following the friction's slow variation between sweeps, which
the CUSUM tests flag as non-constancy.

Usage::

    python examples/emps.py                 # table, cross-test, tracking figure
    python examples/emps.py --no-tracking   # table and cross-test only
    python examples/emps.py --json          # {"M":…, "Fv":…, "Fc":…, "offset":…,
                                            #  "relative_error_percent":…}

With ``--json`` only the JSON object is printed (``relative_error_percent``
is the relative error of the estimation fit, 4.0834 % in the publication)
and no tracking is run.

Reference: A. Janot, M. Gautier, M. Brunot, "Data Set and Reference Models
of EMPS", 2019 Workshop on Nonlinear System Identification Benchmarks,
Eindhoven, NL, April 10-12, 2019.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
from scipy import linalg, signal

from adaptid.datasets import (
    central_difference,
    load_emps,
    matlab_decimate,
    matlab_filtfilt,
)

NAMES = ("M", "Fv", "Fc", "offset")
UNITS = ("kg", "N s/m", "N", "N")

#: Janot, Gautier & Brunot (2019), EMPS_Description.pdf §3.4 (symmetric model).
PUBLISHED = {
    "theta": (95.1089, 203.5034, 20.3935, -3.1648),
    "std": (0.1085, 1.1460, 0.1012, 0.0444),
    "rel_std_percent": (0.1141, 0.5631, 0.4964, 1.4021),
    "abs_diag_R": (64.1376, 13.9005, 69.1706, 157.4483),
    "cond": 25.9883,
    "error_norm": 108.7569,
    "relative_error_percent": 4.0834,
    "error_std": 2.1843,
    "cross_test": {
        "abs_diag_R": (72.1282, 13.9021, 69.1914, 157.4499),
        "cond": 26.0217,
        "error_norm": 169.4876,
        "relative_error_percent": 5.9824,
        "error_std": 3.4039,
    },
}

FS = 1000.0              # sampling frequency, Hz
TS = 1.0 / FS            # 1 ms
F_FILTER = 5 * 20.0      # Butterworth cut-off, Hz
N_BORDER = 50            # MATLAB keeps samples 50:N (1-based)
DECIMATION = round(0.8 * (FS / 2) / (2 * 20.0))   # = 10


def observation_matrix(data):
    """Steps 1–5: the decimated IDIM observation matrix and force vector.

    Parameters
    ----------
    data : adaptid.datasets.EMPSData
        A record from :func:`adaptid.datasets.load_emps`.

    Returns
    -------
    X0 : ndarray, shape (24792, 4)
        Undecimated observation matrix ``[qdd, qd, sign(qd), 1]``.
    X : ndarray, shape (2480, 4)
        Decimated observation matrix.
    y : ndarray, shape (2480,)
        Decimated motor force.
    t : ndarray, shape (2480,)
        Decimated time, s.
    """
    b, a = signal.butter(4, F_FILTER / (FS / 2))
    q_f = matlab_filtfilt(b, a, data.qm)
    dq_f = central_difference(q_f, TS)
    ddq_f = central_difference(dq_f, TS)
    keep = slice(N_BORDER - 1, None)
    qd, qdd = dq_f[keep], ddq_f[keep]
    X0 = np.column_stack([qdd, qd, np.sign(qd), np.ones_like(qd)])
    X = matlab_decimate(X0, DECIMATION)          # column by column, as the script
    y = matlab_decimate(data.force[keep], DECIMATION)
    t = matlab_decimate(data.t[keep], DECIMATION)
    return X0, X, y, t


def _least_squares(X, y):
    """θ and diag((XᵀX)⁻¹) from adaptid.lstsq (QR, no normal equations)."""
    from adaptid import lstsq

    res = lstsq(X, y)
    # res.cov = sigma2 (XᵀX)⁻¹, whatever sigma2's denominator
    return np.asarray(res.theta), np.diag(res.cov) / res.sigma2, "adaptid.lstsq"


def _fit_statistics(X0, X, y, theta):
    e = y - X @ theta
    return {
        "abs_diag_R": np.abs(np.diag(linalg.qr(X0, mode="economic")[1])),
        "cond": float(np.linalg.cond(X)),
        "error_norm": float(np.linalg.norm(e)),
        "relative_error_percent": float(100.0 * np.linalg.norm(e) / np.linalg.norm(y)),
        "error_std": float(np.std(e, ddof=1)),   # MATLAB std: mean removed, N - 1
    }


def identify():
    """Step 6 and the cross-test: the published table, recomputed.

    Returns
    -------
    dict
        ``theta``, ``std``, ``rel_std_percent`` (each shape (4,)),
        ``abs_diag_R``, ``cond``, ``error_norm``, ``relative_error_percent``,
        ``error_std``, ``solver``, the arrays ``X``, ``y``, ``t`` of the
        estimation set and ``cross_test`` (the same statistics on the
        validation run with the estimation set's θ).
    """
    X0, X, y, t = observation_matrix(load_emps("estimation"))
    theta, diag_inv, solver = _least_squares(X, y)
    stats = _fit_statistics(X0, X, y, theta)
    std = stats["error_std"] * np.sqrt(diag_inv)
    X0v, Xv, yv, _ = observation_matrix(load_emps("validation"))
    return {
        "theta": theta, "std": std, "rel_std_percent": 100.0 * std / np.abs(theta),
        **stats, "solver": solver, "X": X, "y": y, "t": t,
        "cross_test": _fit_statistics(X0v, Xv, yv, theta),
    }


def print_table(res, file=sys.stdout):
    pub = PUBLISHED
    p = lambda *a: print(*a, file=file)  # noqa: E731
    p(f"IDIM-LS on DATA_EMPS.mat: N = {res['y'].size} decimated samples (solver: {res['solver']})")
    p(f"{'param':>8} {'value':>12} {'std':>9} {'std %':>8}   published")
    for i, (name, unit) in enumerate(zip(NAMES, UNITS)):
        p(f"{name:>8} {res['theta'][i]:12.4f} {res['std'][i]:9.4f} {res['rel_std_percent'][i]:8.4f}"
          f"   {pub['theta'][i]:.4f} ({pub['std'][i]:.4f}, {pub['rel_std_percent'][i]:.4f} %) [{unit}]")
    fmt = lambda v: ", ".join(f"{x:.4f}" for x in v)  # noqa: E731
    p(f"|diag R| (undecimated X0): {fmt(res['abs_diag_R'])}   published {fmt(pub['abs_diag_R'])}")
    p(f"cond(X): {res['cond']:.4f}   published {pub['cond']:.4f}")
    p(f"error norm {res['error_norm']:.4f}, relative error {res['relative_error_percent']:.4f} %, "
      f"std of error {res['error_std']:.4f}   published {pub['error_norm']:.4f}, "
      f"{pub['relative_error_percent']:.4f} %, {pub['error_std']:.4f}")
    ct, pct = res["cross_test"], pub["cross_test"]
    p("Cross-test on DATA_EMPS_PULSES.mat with these estimates:")
    p(f"  |diag R|: {fmt(ct['abs_diag_R'])}   published {fmt(pct['abs_diag_R'])}")
    p(f"  cond(X): {ct['cond']:.4f}   published {pct['cond']:.4f}")
    p(f"  error norm {ct['error_norm']:.4f}, relative error {ct['relative_error_percent']:.4f} %, "
      f"std of error {ct['error_std']:.4f}   published {pct['error_norm']:.4f}, "
      f"{pct['relative_error_percent']:.4f} %, {pct['error_std']:.4f}")


def track(X, y, t, *, window=600, forgetting=0.998, P0=1e8):
    """Track the IDIM regression online with RLS and the sliding window.

    Returns
    -------
    dict of str to ndarray, shape (N, 4)
        Estimates after each decimated sample, per estimator.
    """
    import adaptid

    n = X.shape[1]
    runs = {
        "RLS (λ = 1)": adaptid.RLS(n, P0=P0),
        f"RLS (λ = {forgetting})": adaptid.RLS(n, forgetting=forgetting, P0=P0),
        f"SlidingWindowRLS (M = {window}, {window / 100:g} s)": adaptid.SlidingWindowRLS(n, window, P0=P0),
    }
    return {label: est.run(X, y).theta for label, est in runs.items()}


def plot_tracks(tracks, t, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(4, 1, sharex=True, figsize=(8, 9))
    for i, ax in enumerate(axes):
        for z, (label, th) in enumerate(tracks.items()):
            ax.plot(t, th[:, i], lw=1, label=label, zorder=3 - z)   # first on top
        ax.axhline(PUBLISHED["theta"][i], color="k", ls="--", lw=1, label="published (IDIM-LS)")
        v, s = PUBLISHED["theta"][i], PUBLISHED["std"][i]
        span = max(25 * s, 0.15 * abs(v))
        ax.set_ylim(v - span, v + span)
        ax.set_ylabel(f"{NAMES[i]} [{UNITS[i]}]")
    axes[0].legend(fontsize=7, loc="upper right")
    axes[-1].set_xlabel("time [s]")
    fig.suptitle("EMPS: online tracking of the IDIM-LS parameters")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def print_diagnostics(X, y, theta, file=sys.stdout):
    from adaptid.diagnostics import (
        autocorrelation_test,
        cusum,
        cusum_squares,
        recursive_residuals,
    )

    w = recursive_residuals(X, y)
    c, cs = cusum(w), cusum_squares(w)
    ac = autocorrelation_test(y - X @ theta)
    n = X.shape[1]

    def where(r):   # w[j] belongs to sample n + 1 + j (1-based)
        return "" if r.first_crossing is None else f", first at sample {n + 1 + r.first_crossing}"

    print("Constancy diagnostics of the fit (recursive residuals, 5 % level):", file=file)
    print(f"  CUSUM: crossed = {c.crossed}{where(c)}", file=file)
    print(f"  CUSUM of squares: crossed = {cs.crossed}{where(cs)}", file=file)
    print(f"  residual whiteness: Ljung-Box Q({ac.dof}) = {ac.q_stat:.1f}, p = {ac.p_value:.3g}", file=file)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--json", action="store_true",
                        help="print only the estimates and relative error as JSON")
    parser.add_argument("--no-tracking", action="store_true",
                        help="skip the online tracking part")
    parser.add_argument("--out", default=".", help="folder for the figure (default: .)")
    args = parser.parse_args(argv)

    res = identify()
    if args.json:
        out = {name: float(v) for name, v in zip(NAMES, res["theta"])}
        out["relative_error_percent"] = res["relative_error_percent"]
        print(json.dumps(out))
        return 0
    print_table(res)
    if args.no_tracking:
        return 0
    print()
    print_diagnostics(res["X"], res["y"], res["theta"])
    tracks = track(res["X"], res["y"], res["t"])
    print()
    print("Final tracked estimates (published IDIM-LS: "
          + ", ".join(f"{v:g}" for v in PUBLISHED["theta"]) + "):")
    for label, th in tracks.items():
        print(f"  {label:42s} " + ", ".join(f"{v:9.4f}" for v in th[-1]))
    out_dir = Path(args.out)
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / "emps_tracking.png"
    plot_tracks(tracks, res["t"], path)
    print(f"figure: {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
