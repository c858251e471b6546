"""Reset a running RLS estimator when a structural-change monitor raises an alarm.

A three-parameter plant y = θᵀφ + e runs for 6000 samples; the coefficient
of a zero-mean regressor jumps from 1.0 to 1.5 at sample 3000 (the change
that a CUSUM of residuals cannot see: the residuals keep mean zero).

* RLS without forgetting (λ = 1) is the most accurate estimator while the
  plant is constant, and never tracks the jump;
* RLS with λ = 0.99 tracks, but is noisy all the time;
* RLS (λ = 1) beside an ME monitor (``adaptid.diagnostics.Monitor``,
  moving estimates against a stable history, Leisch, Hornik & Kuan 2000):
  on an alarm its covariance is reset (θ kept, P = P0: Goodwin & Sin's
  covariance resetting), and the monitor is re-armed with the next
  ``--history`` samples as its new history.

Run: ``python examples/monitor_reset.py [--history 300] [--no-plot]``
(the figure ``monitor_reset.png`` needs matplotlib).
"""

import argparse

import numpy as np

import adaptid
from adaptid.diagnostics import Monitor


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--history", type=int, default=300, help="samples of stable history per arming")
    ap.add_argument("--no-plot", action="store_true")
    args = ap.parse_args(argv)

    rng = np.random.default_rng(0)
    N, jump, n = 6000, 3000, 3
    Phi = np.column_stack([np.ones(N), rng.standard_normal(N), rng.standard_normal(N)])
    theta = np.tile([0.5, 1.0, -0.7], (N, 1))
    theta[jump:, 1] = 1.5
    y = np.einsum("ki,ki->k", Phi, theta) + 0.3 * rng.standard_normal(N)

    plain = adaptid.RLS(n).run(Phi, y).theta
    forgetting = adaptid.RLS(n, forgetting=0.99).run(Phi, y).theta

    # RLS beside a monitor, one sample at a time (as it would run on line)
    rls = adaptid.RLS(n)
    est = np.empty((N, n))
    alarms = []
    mon = None
    armed_at = 0                       # first sample of the current history
    for k in range(N):
        rls.update(Phi[k], y[k])
        est[k] = rls.theta
        if mon is None and k + 1 - armed_at == args.history:
            mon = Monitor(Phi[armed_at:k + 1], y[armed_at:k + 1], kind="me", horizon=10, h=0.5)
        elif mon is not None:
            if mon.update(Phi[k], y[k]) is not None:
                alarm = armed_at + mon.alarm          # monitor counts from its history's start
                alarms.append(alarm)
                # covariance resetting: keep theta, forget the information
                rls = adaptid.RLS(n, theta0=rls.theta, P0=1e2)
                mon, armed_at = None, k + 1
            elif mon.n_seen >= 10 * mon.n_hist:       # horizon reached: re-arm on recent data
                armed_at = k + 1 - args.history
                mon = Monitor(Phi[armed_at:k + 1], y[armed_at:k + 1], kind="me", horizon=10, h=0.5)

    def rmse(t, a, b):
        return float(np.sqrt(np.mean((t[a:b] - theta[a:b]) ** 2)))

    print(f"alarms at samples {alarms} (jump at {jump})")
    print(f"{'estimator':28s} {'RMSE before':>12s} {'RMSE after':>12s}")
    for name, t in (("RLS, no forgetting", plain), ("RLS, forgetting 0.99", forgetting),
                    ("RLS + ME monitor reset", est)):
        print(f"{name:28s} {rmse(t, 500, jump):12.4f} {rmse(t, jump + 500, N):12.4f}")

    if not args.no_plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(8, 4))
        ax.plot(theta[:, 1], "k", lw=2, label="true θ₂")
        ax.plot(plain[:, 1], lw=1, label="RLS λ = 1")
        ax.plot(forgetting[:, 1], lw=0.7, alpha=0.7, label="RLS λ = 0.99")
        ax.plot(est[:, 1], lw=1, label="RLS λ = 1 + monitor reset")
        for a in alarms:
            ax.axvline(a, color="r", ls=":", lw=1)
        ax.set_ylim(0.6, 1.9)
        ax.set_xlabel("sample")
        ax.legend(loc="upper left")
        fig.tight_layout()
        fig.savefig("monitor_reset.png", dpi=120)
        print("wrote monitor_reset.png")
    return alarms


if __name__ == "__main__":
    main()
