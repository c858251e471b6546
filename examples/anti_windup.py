"""Covariance windup and the forgetting strategies that prevent it.

A two-parameter plant is excited in one direction only for a long stretch
(a motor held at constant speed), then fully again while its parameters jump.
Plain exponential forgetting lets the unexcited part of P grow like λ⁻ᵏ
(``CovarianceWindupWarning``); the strategies of :mod:`adaptid.forgetting`
keep trace(P) bounded and still track the jump.

Run: ``python examples/anti_windup.py [--quiet-steps N] [--no-plot]``
(the figure ``anti_windup.png`` needs matplotlib).
"""

import argparse
import warnings

import numpy as np

import adaptid
from adaptid import forgetting as fg


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quiet-steps", type=int, default=20_000)
    ap.add_argument("--no-plot", action="store_true")
    args = ap.parse_args(argv)

    rng = np.random.default_rng(0)
    Nq, Nj = args.quiet_steps, 2000
    Phi = np.vstack([np.column_stack([rng.standard_normal(Nq), np.zeros(Nq)]),
                     rng.standard_normal((Nj, 2))])
    theta = np.where(np.arange(Nq + Nj)[:, None] < Nq, [1.0, -1.0], [1.5, -0.4])
    y = np.einsum("ki,ki->k", Phi, theta) + 0.01 * rng.standard_normal(Nq + Nj)

    setups = {
        "exponential λ=0.98": dict(forgetting=0.98),
        "directional λ=0.98": dict(forgetting=fg.Directional(0.98)),
        "constant trace": dict(forgetting=fg.ConstantTrace(0.98, 2.0)),
        "EFRA": dict(forgetting=fg.EFRA(0.5, 0.005, 0.005, 0.98)),
        "exponential + P_max=10": dict(forgetting=0.98, P_max=10.0),
    }
    rows, tracks = [], {}
    for name, opts in setups.items():
        est = adaptid.RLS(2, P0=1.0, **opts)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", adaptid.CovarianceWindupWarning)
            tr = est.run(Phi, y)
        wound = any(issubclass(w.category, adaptid.CovarianceWindupWarning) for w in caught)
        err = np.linalg.norm(tr.theta - theta, axis=1) / np.linalg.norm(theta, axis=1)
        late = np.flatnonzero(err[Nq:] > 0.05)
        delay = 0 if late.size == 0 else int(late[-1] + 1)
        P = est.P
        rows.append((name, np.trace(P) if np.all(np.isfinite(P)) else np.inf, wound, delay))
        tracks[name] = tr.theta
    print(f"{'strategy':26s} {'trace(P) at end':>16s} {'windup warning':>15s} {'delay after jump':>17s}")
    for name, tr_p, wound, delay in rows:
        print(f"{name:26s} {tr_p:16.4g} {str(wound):>15s} {delay:17d}")

    if not args.no_plot:
        try:
            import matplotlib
            matplotlib.use("Agg")
            import matplotlib.pyplot as plt
        except ImportError:
            print("(matplotlib not installed: no figure)")
            return 0
        k = np.arange(Nq - 200, Nq + Nj)
        fig, ax = plt.subplots(2, 1, sharex=True, figsize=(8, 6))
        for i in range(2):
            for name, th in tracks.items():
                ax[i].plot(k, th[k, i], label=name, lw=1)
            ax[i].plot(k, theta[k, i], "k--", lw=1, label="truth")
            ax[i].set_ylabel(f"θ{i + 1}")
            ax[i].set_ylim(theta[k, i].min() - 1, theta[k, i].max() + 1)
        ax[0].legend(fontsize=7)
        ax[1].set_xlabel("sample")
        fig.suptitle("after a long unexcited stretch, the parameters jump")
        fig.tight_layout()
        fig.savefig("anti_windup.png", dpi=110)
        print("figure: anti_windup.png")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
