"""Piecewise polynomial fits by constrained least squares.

Reproduces the reference's example (Boyd & Vandenberghe (2018), §16.1.1;
seed document ``constrained-least-squares.ja.txt``): 70 points on each side
of 0 from ``y = x³ − x + 0.4/(1 + 25x²)``, two cubics on [−1, 0] and [0, 1]
with equal value and slope at 0; then a spline with six intervals and
continuity of value, slope and curvature, compared with SciPy's
least-squares spline on the same knots.

Usage: ``python examples/constrained_piecewise.py [--out DIR]``; writes
``constrained_piecewise.png`` into DIR (default: the current folder).
"""

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy.interpolate import make_lsq_spline  # noqa: E402

from adaptid.constrained import piecewise_polyfit  # noqa: E402


def main(out: Path) -> Path:
    rng = np.random.default_rng(2018)
    M = 70
    x = np.concatenate([rng.random(M) - 1.0, rng.random(M)])
    y = x**3 - x + 0.4 / (1.0 + 25.0 * x**2)
    grid = np.linspace(-1.0, 1.0, 801)

    # The reference: two cubics, value and slope continuous at 0.
    two = piecewise_polyfit(x, y, [-1.0, 0.0, 1.0], degree=3, continuity=1)
    jump = [abs(two(np.nextafter(0.0, -1.0), k) - two(0.0, k)) for k in range(3)]
    print(two)
    print("jumps at 0 of value, slope, curvature:", np.array(jump))

    # Six intervals, continuity 0, 1, 2; continuity 2 is the LSQ cubic spline.
    knots = np.linspace(-1.0, 1.0, 7)
    fits = {c: piecewise_polyfit(x, y, knots, degree=3, continuity=c) for c in (0, 1, 2)}
    order = np.argsort(x)
    spline = make_lsq_spline(x[order], y[order], np.r_[[-1.0] * 4, knots[1:-1], [1.0] * 4], k=3)
    print("max |continuity-2 fit − scipy make_lsq_spline| on a grid:",
          np.max(np.abs(fits[2](grid) - spline(grid))))
    for c, f in fits.items():
        print(f"continuity {c}: residual sum of squares {f.rss:.6f}")

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
    ax = axes[0]
    ax.plot(x, y, ".k", ms=3, label="data")
    left, right = grid <= 0, grid >= 0
    ax.plot(grid[left], two(grid[left]), "-g", label="cubic on [−1, 0]")
    ax.plot(grid[right], two(grid[right]), "-r", label="cubic on [0, 1]")
    ax.axvline(0.0, color="0.7", lw=0.8)
    ax.set(title="Two cubics, equal value and slope at 0", xlabel="x", ylabel="y")
    ax.legend()
    ax = axes[1]
    ax.plot(x, y, ".k", ms=3, label="data")
    for c, style in zip((0, 1, 2), ("--", "-.", "-")):
        ax.plot(grid, fits[c](grid), style, label=f"continuity {c} (rss {fits[c].rss:.4f})")
    ax.plot(grid, spline(grid), ":", color="k", lw=2, label="scipy make_lsq_spline")
    for t in knots[1:-1]:
        ax.axvline(t, color="0.8", lw=0.8)
    ax.set(title="Six cubic pieces", xlabel="x")
    ax.legend(fontsize=8)
    path = out / "constrained_piecewise.png"
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
