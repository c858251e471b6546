"""Continuous TLSM versus its exact discretisation and the naive Euler one.

Yamamoto (1991), "Continuous and discrete time adaptive algorithms by the
TLSM" (seed document ``yamamoto1991-tlsm.ja.txt``): the parameters of
``y = θᵀv`` jump at t = 2 s; the regressor is sampled every T = 10 ms and
held (zero-order hold). For algorithms 2 (f = 1), 3 (f = e^{−α(t−s)}) and
4 (f = λ₂(s) e^{−∫λ₁}, time-varying λ₁, λ₂) the figure shows

* left: θ(t) of the continuous law (``adaptid.continuous.integrate``, a
  line, also between samples), the discrete recursive estimator
  (``SlidingWindowRLS`` configured by ``discretize``, markers), the naive
  forward-Euler discretisation of dQ/dt (eqs. 35–36, dashed) and the true θ;
* right: the distance of each discrete curve from the continuous one at the
  sample instants — rounding level for the exact discretisation, O(T) for
  naive Euler.

Usage: ``python examples/continuous_vs_discrete.py [--out DIR]``; writes
``continuous_vs_discrete.png`` into DIR (default: the current folder).
"""

import argparse
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from adaptid.continuous import discretize, integrate  # noqa: E402

T = 0.01            # sample time
N = 600             # samples: t in [0, 6)
T_N = 1.0           # window tₙ = M T, M = 100
T_JUMP = 2.0        # the parameters jump here (a sample instant)
THETA_OLD = np.array([1.0, -0.5])
THETA_NEW = np.array([0.3, 0.8])
Q0 = 30.0           # usual initialisation Q(0) = 30 I (naive Euler needs T vᵀQv < 1)


def held(samples):
    """Zero-order hold of samples[k] on [kT, (k+1)T) as a callable."""
    last = samples.shape[0] - 1

    def fn(t):
        return samples[min(max(int(math.floor(t / T)), 0), last)]
    return fn


def main(out: Path) -> Path:
    tk = T * np.arange(N)
    V = np.column_stack([np.ones(N),
                         np.sin(2 * np.pi * 1.1 * tk) + 0.6 * np.cos(2 * np.pi * 0.35 * tk)])
    theta_true = np.where((tk < T_JUMP)[:, None], THETA_OLD, THETA_NEW)
    Y = np.einsum("kn,kn->k", V, theta_true)             # noise-free
    lam1 = 0.5 + 0.4 * np.sin(tk)                        # algorithm 4's weights, held
    lam2 = 1.0 + 0.5 * np.cos(2.0 * tk)
    cases = {
        "algorithm 2  (f = 1)": dict(algorithm=2),
        "algorithm 3  (f = exp(−α(t−s)), α = 1)": dict(algorithm=3, alpha=1.0),
        "algorithm 4  (f = λ₂(s) exp(−∫λ₁), time-varying)": dict(algorithm=4),
    }
    t_fine = np.linspace(0.0, N * T, 5 * N + 1)          # every 5th point is a sample instant
    breaks = T * np.arange(N + 1)

    fig, axes = plt.subplots(3, 2, figsize=(13, 10), constrained_layout=True,
                             gridspec_kw={"width_ratios": [1.6, 1.0]})
    for row, (title, kw) in enumerate(cases.items()):
        weights = {}
        if kw["algorithm"] == 4:
            weights = dict(lambda1=held(lam1), lambda2=held(lam2))
            dweights = dict(lambda1=lam1, lambda2=lam2)
        else:
            dweights = {k: v for k, v in kw.items() if k == "alpha"}
            weights = dict(dweights)
        alg = kw["algorithm"]
        cont = integrate(held(V), held(Y), t_fine, algorithm=alg, t_n=T_N, theta0=np.zeros(2),
                         Q0=Q0, breakpoints=breaks, rtol=1e-10, atol=1e-12, **weights)
        d = discretize(T, algorithm=alg, t_n=T_N, theta0=np.zeros(2), Q0=Q0, **dweights)
        disc = d.run(V, Y)                       # SlidingWindowRLS, weights and prior from d
        euler = d.run_euler(V, Y)                # the paper's counter-example
        at_samples = cont.theta[::5]             # continuous θ at t_k = kT
        err_d = np.max(np.abs(disc.theta - at_samples), axis=1)
        err_e = np.max(np.abs(euler.theta - at_samples), axis=1)
        print(f"{title}: {d!r}")
        print(f"    max |discrete − continuous| = {err_d.max():.2e},  "
              f"max |naive Euler − continuous| = {err_e.max():.2e},  "
              f"|θ(t_jump + tₙ) − θ_new| = "
              f"{np.max(np.abs(at_samples[int(round((T_JUMP + T_N) / T))] - THETA_NEW)):.2e}")

        ax = axes[row, 0]
        for i, color in enumerate(("tab:blue", "tab:red")):
            ax.plot(t_fine, cont.theta[:, i], color=color, lw=1.6,
                    label=f"θ{i + 1} continuous" if row == 0 else None)
            ax.plot(disc.t[::10], disc.theta[::10, i], "o", ms=3.5, mfc="none", color=color,
                    label=f"θ{i + 1} discrete (SlidingWindowRLS)" if row == 0 else None)
            ax.plot(euler.t, euler.theta[:, i], "--", lw=1.0, color=color, alpha=0.7,
                    label=f"θ{i + 1} naive Euler" if row == 0 else None)
            ax.step(np.r_[tk, N * T], np.r_[theta_true[:, i], theta_true[-1, i]], where="post",
                    color="0.5", lw=0.8, ls=":")
        ax.axvline(T_JUMP, color="0.6", lw=0.8)
        ax.axvline(T_JUMP + T_N, color="0.6", lw=0.8, ls="--")
        ax.set_title(title, loc="left", fontsize=10)
        ax.set_ylabel("θ(t)")
        ax.set_ylim(-1.2, 1.6)

        ax = axes[row, 1]
        ax.semilogy(disc.t, np.maximum(err_d, 1e-17), lw=1.0, label="exact discretisation (lemma)")
        ax.semilogy(euler.t, np.maximum(err_e, 1e-17), lw=1.0, label="naive forward Euler of dQ/dt")
        ax.axvline(T_JUMP, color="0.6", lw=0.8)
        ax.set_ylim(1e-17, 1.0)
        ax.set_ylabel("max |θ_discrete − θ_continuous|")
    axes[0, 0].legend(fontsize=8, ncol=3, loc="upper left")
    axes[0, 1].legend(fontsize=8, loc="center right")
    axes[-1, 0].set_xlabel("t [s]   (jump at 2 s; dashed line: 2 s + tₙ)")
    axes[-1, 1].set_xlabel("t [s]")
    fig.suptitle(f"TLSM, Yamamoto (1991): continuous vs sampled (T = {T:g} s, tₙ = {T_N:g} s, "
                 f"zero-order hold, Q(0) = {Q0:g} I)", fontsize=11)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "continuous_vs_discrete.png"
    fig.savefig(path, dpi=130)
    plt.close(fig)
    print(f"wrote {path}")
    return path


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("."), help="output folder")
    main(parser.parse_args().out)
