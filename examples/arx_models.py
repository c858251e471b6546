r"""ARX, ARMAX and OE on a simulated plant with coloured noise.

The plant  A(q) y = B(q) u + C(q) e  with

    A = 1 - 1.5 q^-1 + 0.7 q^-2,  B = q^-1 (1 + 0.5 q^-1),  C = 1 - 0.6 q^-1 + 0.3 q^-2,

is simulated with scipy.signal.lfilter. ARX (least squares) is biased by the
coloured noise; ARMAX by recursive extended least squares (one compiled
pass) and by the batch Hannan–Rissanen fit with a prediction-error
refinement recovers the true parameters. The identified ARMAX model is then
converted to a python-control transfer function (if installed) and its
step response compared with the model's own simulation.

Usage::

    python examples/arx_models.py            # prints, saves arx_models.png if matplotlib is present
    python examples/arx_models.py --no-plot
"""

from __future__ import annotations

import argparse
import sys

import numpy as np
from scipy.signal import lfilter

from adaptid.models import ARMAX, ARX, OE

A = np.array([1.0, -1.5, 0.7])
B = np.array([0.0, 1.0, 0.5])
C = np.array([1.0, -0.6, 0.3])


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--no-plot", action="store_true", help="do not draw the figure")
    parser.add_argument("-n", type=int, default=20000, help="number of samples")
    args = parser.parse_args(argv)

    rng = np.random.default_rng(1)
    u = rng.standard_normal(args.n)
    e = 0.5 * rng.standard_normal(args.n)
    y = lfilter(B, A, u) + lfilter(C, A, e)
    truth = np.r_[A[1:], B[1:], C[1:]]

    arx = ARX(2, 2, 1, dt=0.1).fit(y, u)
    rels = ARMAX(2, 2, 2, 1, dt=0.1)
    traj = rels.fit_recursive(y, u)
    pem = ARMAX(2, 2, 2, 1, dt=0.1).fit(y, u, refine=True)
    oe = OE(2, 2, 1, dt=0.1).fit(y, u)

    print(f"{'':>6} {'truth':>8} {'ARX':>8} {'RELS':>8} {'PEM':>8} {'(std)':>8}")
    for i, name in enumerate(pem.names):
        a = f"{arx.theta[i]:8.4f}" if i < 4 else " " * 8
        print(f"{name:>6} {truth[i]:8.4f} {a} {rels.theta[i]:8.4f} {pem.theta[i]:8.4f} "
              f"({pem.stderr[i]:.4f})")
    print(f"AIC: ARX {arx.aic:.1f}, ARMAX {pem.aic:.1f};  FPE: ARX {arx.fpe:.4f}, ARMAX {pem.fpe:.4f}")
    print(f"simulation fit: ARX {arx.fit_percent(y, u):.1f} %, ARMAX {pem.fit_percent(y, u):.1f} %, "
          f"OE {oe.fit_percent(y, u):.1f} %;  one-step: ARMAX {pem.fit_percent(y, u, k=1):.1f} %")
    try:
        import control
    except ImportError:
        print("python-control not installed: pip install 'adaptid[control]'")
    else:
        sys_tf = pem.to_control()
        T = np.arange(100) * pem.dt
        step = control.step_response(sys_tf, T)
        gap = np.max(np.abs(np.squeeze(step.outputs) - pem.simulate(np.ones(100))))
        print(f"python-control step response vs simulate: max difference {gap:.2e}")

    if not args.no_plot:
        try:
            import matplotlib
            matplotlib.use("Agg")
            import matplotlib.pyplot as plt
        except ImportError:
            print("matplotlib not installed: no figure")
            return 0
        fig, ax = plt.subplots(figsize=(7, 4))
        ax.plot(traj.theta)
        for v in truth:
            ax.axhline(v, color="k", lw=0.5, ls="--")
        ax.set_xscale("log")
        ax.set_xlabel("sample")
        ax.set_ylabel("estimate")
        ax.set_title("ARMAX by recursive extended least squares")
        ax.legend(rels.names, ncol=3, fontsize="small")
        fig.tight_layout()
        fig.savefig("arx_models.png", dpi=120)
        print("figure saved to arx_models.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
