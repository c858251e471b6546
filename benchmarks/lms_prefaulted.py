#!/usr/bin/env python
"""LMS / NLMS compute alone: adaptid's kernel against the C loop on outputs already in memory.

    python benchmarks/lms_prefaulted.py [--kind nlms] [--n 8] [--rounds 3]

``bench_lms.py`` times ``run`` as a user calls it, output arrays allocated in
the call (for C too), so at n = 8 half of both times is the page faults of
72 MB of fresh output. This diagnostic calls the compiled kernel of
``adaptid.LMS`` / ``NLMS`` and the C loop (``benchmarks/c/lms_ref.c``, n fixed
at compile time, and with the four partial sums) on preallocated, prefaulted
θ and ε arrays, 10⁶ samples, and prints the best of 7 calls per round: the
arithmetic and the stores alone. A diagnostic of issue 16, not a speed claim.
"""
import argparse
import time

import numpy as np

import bench_lms as B


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--kind", choices=("lms", "nlms"), default="nlms")
    ap.add_argument("--n", type=int, default=8)
    ap.add_argument("--rounds", type=int, default=3)
    a = ap.parse_args()
    kind, n, N = a.kind, a.n, 1_000_000
    rng = np.random.default_rng(1)
    Phi = rng.standard_normal((N, n))
    y = Phi @ np.linspace(1, -1, n) + 0.1 * rng.standard_normal(N)
    est = B.adaptid_est(kind, n)
    est.run(Phi[:100], y[:100])
    kern = est._kern
    Th, E, sk = np.zeros((N, n, 1)), np.zeros((N, 1)), np.zeros(N, bool)
    ThC, EC = np.zeros((N, n)), np.zeros(N)
    libs = {"fixed_n": B.build_c(n), "split4": B.build_c(n, split4=True)}

    def ad():
        e = B.adaptid_est(kind, n)
        P, Y, w = e._run_arrays(Phi, y, None, batched=False, precheck=False)
        lam = e._lam_run(None, P.shape[:1])
        t = time.perf_counter()
        kern.run(e._S, P, Y, lam, w, Th, E, sk, np.empty(0), None, e._opt, e._mat,
                 e._ntag, e._ptag)
        return time.perf_counter() - t

    def c(lib):
        th = np.zeros(n)
        t = time.perf_counter()
        lib.lms_run(n, N, Phi.ctypes.data, y.ctypes.data, B.MU[kind], B.EPS, kind == "nlms",
                    th.ctypes.data, ThC.ctypes.data, EC.ctypes.data)
        return time.perf_counter() - t

    print(f"# {kind.upper()} n = {n}, {N} samples, outputs prefaulted; ms, best of 7 per round")
    for _ in range(a.rounds):
        row = [f"adaptid kernel {1e3 * min(ad() for _ in range(7)):6.2f}"]
        row += [f"C {k} {1e3 * min(c(lib) for _ in range(7)):6.2f}" for k, lib in libs.items()]
        print("   ".join(row), flush=True)


if __name__ == "__main__":
    main()
