r"""Hair dryer (DaISy 96-006): ARX [2 2 3] by least squares, then validation.

The classic procedure (MATLAB System Identification Toolbox demo
"Estimating Simple Models from Real Laboratory Process Data", iddemo_dryer2;
Ljung, *System Identification*, 2nd ed., p. 525) on the laboratory dryer
(PT326, Ts = 0.08 s): estimate on samples 1–300 with the means removed,
the ARX model with na = 2, nb = 2, nk = 3,

    y(t) + a1 y(t-1) + a2 y(t-2) = b1 u(t-3) + b2 u(t-4) + e(t),

by least squares on the rows t = 5 … 300 whose regressors are all measured
(the first max(na, nb + nk - 1) = 4 rows discarded), then validate on
samples 301–1000 (their own means removed) by simulating the model from the
input alone, zero initial conditions, and report the fit (MATLAB
``compare``'s NRMSE fit). The regressor is built here with numpy.

No numeric coefficients have been published for this procedure by
MathWorks or Ljung (see adaptid/datasets/data/README.md); the reference
values printed for comparison are our own plain-LS numbers recorded in the
data description (``REFERENCE``), which the test suite checks.

Usage::

    python examples/dryer_arx.py
"""

from __future__ import annotations

import sys

import numpy as np
from scipy import signal

from adaptid.datasets import load_daisy
from adaptid.diagnostics import autocorrelation_test, cross_correlation_test, fit_percent

NA, NB, NK = 2, 2, 3
N_EST = 300
NAMES = ("a1", "a2", "b1", "b2")

#: Plain LS, samples 1..300, means removed, first 4 rows discarded
#: (shared/data/daisy/SOURCE.md, "Our plain LS").
REFERENCE = {"theta": (-1.273739, 0.393546, 0.066618, 0.044482),
             "std": (0.0209, 0.0191, 0.0021, 0.0033)}


def arx_regression(u, y, na=NA, nb=NB, nk=NK):
    """Regressor and target of an ARX model, rows whose past is measured.

    Returns ``Phi`` (N - s, na + nb) with rows
    ``[-y(t-1), …, -y(t-na), u(t-nk), …, u(t-nk-nb+1)]`` and ``y(t)`` for
    t = s … N-1 (0-based), s = max(na, nb + nk - 1).
    """
    N = y.size
    s = max(na, nb + nk - 1)
    t = np.arange(s, N)
    cols = [-y[t - i] for i in range(1, na + 1)] + [u[t - nk - j] for j in range(nb)]
    return np.column_stack(cols), y[s:]


def _least_squares(Phi, y):
    """θ and its standard errors (σ̂² = SSR / (N − n)) from adaptid.lstsq."""
    from adaptid import lstsq

    res = lstsq(Phi, y)
    return np.asarray(res.theta), np.asarray(res.stderr), "adaptid.lstsq"


def simulate(theta, u, na=NA, nb=NB, nk=NK):
    """Simulated output of the ARX model from the input alone (zero initial state)."""
    a = np.concatenate([[1.0], theta[:na]])
    b = np.concatenate([np.zeros(nk), theta[na:na + nb]])
    return signal.lfilter(b, a, u)


def identify():
    """Estimate on samples 1–300, validate on 301–1000; returns a dict."""
    d = load_daisy("dryer")
    ue, ye = d.u[:N_EST] - d.u[:N_EST].mean(), d.y[:N_EST] - d.y[:N_EST].mean()
    uv, yv = d.u[N_EST:] - d.u[N_EST:].mean(), d.y[N_EST:] - d.y[N_EST:].mean()
    Phi, target = arx_regression(ue, ye)
    theta, stderr, solver = _least_squares(Phi, target)
    resid = target - Phi @ theta
    y_sim = simulate(theta, uv)
    Phi_v, target_v = arx_regression(uv, yv)
    return {
        "theta": theta, "stderr": stderr, "solver": solver, "n_rows": target.size,
        "loss": float(resid @ resid / resid.size),
        "fit_simulation_percent": fit_percent(yv, y_sim),
        "fit_prediction_percent": fit_percent(target_v, Phi_v @ theta),
        "whiteness": autocorrelation_test(resid, 20),
        # the residuals belong to samples s..299, s = max(na, nb + nk - 1)
        "independence": cross_correlation_test(ue[N_EST - target.size:], resid, 20),
        "Ts": d.Ts,
    }


def main():
    res = identify()
    print("Hair dryer (DaISy 96-006), ARX [na nb nk] = [2 2 3], samples 1-300, means removed")
    print(f"least squares ({res['solver']}), {res['n_rows']} rows (t = 5 ... 300):")
    print(f"{'':>4} {'estimate':>10} {'std':>8}   reference (SOURCE.md)")
    for i, name in enumerate(NAMES):
        print(f"{name:>4} {res['theta'][i]:10.6f} {res['stderr'][i]:8.4f}   "
              f"{REFERENCE['theta'][i]:10.6f} ({REFERENCE['std'][i]:.4f})")
    a1, a2, b1, b2 = res["theta"]
    print(f"A(q) = 1 {a1:+.4g} q^-1 {a2:+.4g} q^-2,  B(q) = {b1:.4g} q^-3 {b2:+.4g} q^-4")
    print(f"loss function V = {res['loss']:.4e}")
    print(f"validation on samples 301-1000 (Ts = {res['Ts']} s): "
          f"simulation fit {res['fit_simulation_percent']:.2f} %, "
          f"one-step prediction fit {res['fit_prediction_percent']:.2f} %")
    w, x = res["whiteness"], res["independence"]
    print(f"estimation residuals: Ljung-Box Q({w.dof}) = {w.q_stat:.1f}, p = {w.p_value:.3g}; "
          f"input cross-correlation Q({x.dof}) = {x.q_stat:.1f}, p = {x.p_value:.3g}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
