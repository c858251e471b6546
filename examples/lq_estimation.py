"""Linear quadratic state estimation of a 2-D double-integrator track.

The reference's example (Boyd & Vandenberghe (2018), §17.3; seed document
``constrained-least-squares.ja.txt``): positions measured with noise,
``y_t = (s_t, sin s_t + noise)``, s from 0 to 5, T = 100, λ = 10³. A second
panel drops 15 samples (NaN rows) and the third chooses λ by validation on
20 % held-out samples.

Usage: ``python examples/lq_estimation.py [--out DIR]``; writes
``lq_estimation.png`` into DIR (default: the current folder).
"""

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from adaptid.constrained import lq_estimate, lq_estimate_cv  # noqa: E402

I2, Z2 = np.eye(2), np.zeros((2, 2))
A = np.block([[I2, I2], [Z2, I2]])
B = np.vstack([Z2, I2])
C = np.hstack([I2, Z2])


def measurements(T, rng):
    s = np.linspace(0.0, 5.0, T)
    return np.column_stack([s, np.sin(s) + 0.5 * rng.random(T)])


def main(out: Path) -> Path:
    T, lam = 100, 1e3
    rng = np.random.default_rng(17)
    y = measurements(T, rng)
    est = lq_estimate(A, B, C, y, lam)
    print(est)

    y_gap = y.copy()
    y_gap[40:55] = np.nan
    est_gap = lq_estimate(A, B, C, y_gap, lam)
    print(est_gap)

    cv = lq_estimate_cv(A, B, C, y, np.logspace(-1, 5, 25), holdout=0.2, rng=rng)
    print(cv)

    fig, axes = plt.subplots(1, 3, figsize=(15, 4.3), constrained_layout=True)
    ax = axes[0]
    ax.plot(y[:, 0], y[:, 1], ".k", label="measurements")
    ax.plot(est.y[:, 0], est.y[:, 1], ".-r", ms=3, label=f"estimate, λ = {lam:g}")
    ax.set(title="LQ state estimation", aspect="equal")
    ax.legend()
    ax = axes[1]
    ax.plot(y_gap[:, 0], y_gap[:, 1], ".k", label="measurements (15 missing)")
    ax.plot(est_gap.y[:, 0], est_gap.y[:, 1], ".-b", ms=3, label="estimate")
    ax.plot(est_gap.y[40:55, 0], est_gap.y[40:55, 1], "o", mfc="none", color="b",
            label="across the gap")
    ax.set(title="Missing measurements", aspect="equal")
    ax.legend(fontsize=8)
    ax = axes[2]
    ax.loglog(cv.lams, cv.train_rms, "-o", ms=3, label="training RMS")
    ax.loglog(cv.lams, cv.test_rms, "-s", ms=3, label="held-out RMS")
    ax.axvline(cv.lam, color="0.5", ls="--", label=f"chosen λ = {cv.lam:.3g}")
    ax.set(title="Choosing λ by validation", xlabel="λ")
    ax.legend(fontsize=8)
    path = out / "lq_estimation.png"
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
