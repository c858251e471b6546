"""Finite-horizon linear quadratic control versus the open-loop response.

The reference's example (Boyd & Vandenberghe (2018), §17.2; seed document
``constrained-least-squares.ja.txt``): a 3-state, 1-input, 1-output system,
T = 100, ρ = 0.2, x_des = 0. With u = 0 the output does not reach 0 at
t = T; the LQ input drives the state exactly to 0. A second panel solves
three initial states at once (x_init of shape (n, q)).

Usage: ``python examples/lq_control.py [--out DIR]``; writes
``lq_control.png`` into DIR (default: the current folder).
"""

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from adaptid.constrained import lq_control, open_loop  # noqa: E402

A = np.array([[0.855, 1.161, 0.667],
              [0.015, 1.073, 0.053],
              [-0.084, 0.059, 1.022]])
B = np.array([-0.076, -0.139, 0.342])
C = np.array([0.218, -3.597, -1.683])
X_INIT = np.array([0.496, -0.745, 1.394])


def main(out: Path) -> Path:
    T, rho = 100, 0.2
    ol = open_loop(A, C, X_INIT, T)
    lq = lq_control(A, B, C, X_INIT, np.zeros(3), T, rho)
    print(lq)
    print("open loop: y_T =", ol.y[-1, 0], " x_T =", ol.x[-1])
    print("LQ control: y_T =", lq.y[-1, 0], " x_T =", lq.x[-1])

    inits = np.column_stack([X_INIT, -X_INIT, [1.0, 0.0, 0.0]])
    many = lq_control(A, B, C, inits, np.zeros(3), T, rho)

    t = np.arange(1, T + 1)
    fig, axes = plt.subplots(1, 3, figsize=(14, 4), constrained_layout=True)
    axes[0].plot(t, ol.y[:, 0], label="open loop (u = 0)")
    axes[0].plot(t, lq.y[:, 0], label=f"linear quadratic control (ρ = {rho})")
    axes[0].axhline(0.0, color="0.7", lw=0.8)
    axes[0].set(title="Output y_t", xlabel="t")
    axes[0].legend()
    axes[1].step(t[:-1], lq.u[:, 0], where="post")
    axes[1].set(title="LQ input u_t", xlabel="t")
    for j in range(inits.shape[1]):
        axes[2].plot(t, many.y[:, 0, j], label=f"x_init = {np.round(inits[:, j], 3)}")
    axes[2].set(title="Three initial states, one factorisation", xlabel="t")
    axes[2].legend(fontsize=8)
    path = out / "lq_control.png"
    fig.savefig(path, dpi=120)
    plt.close(fig)
    print("wrote", path)
    return path


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("."), help="output folder")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    main(args.out)
