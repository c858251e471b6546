#!/usr/bin/env python
"""A/B of the covariance form's vector sweep above n = 32 (issue 19, point 1).

    python benchmarks/ab_covsweep.py [--rounds 3] [--ns 40 48 64]

The covariance form sweeps P as hand-written LLVM vector code for a compile-time
n <= ``_covsweep.VECTOR_SWEEP_MAX`` and as the scalar loops that LLVM's loop
vectoriser handles above it; the bound is 32 on AMD Zen and 64 elsewhere
(:mod:`adaptid._kernels.toolchain._covsweep`). This script times
``RLS(n, form="covariance").run(store=False)`` with the bound set to 64 (vector
code) and to 32 (scalar loops) in alternating child processes, each with its
own numba cache folder (the two builds have the same source stamp), and prints
M updates/s (best of 9 runs per process) and the ratio per round. The results
are the same least-squares estimate either way (the sums round differently).
Speed is never asserted.
"""
import argparse
import os
import statistics
import subprocess
import sys
import tempfile

CHILD = r"""
import sys, time, numpy as np
vmax = int(sys.argv[1]); ns = [int(a) for a in sys.argv[2:]]
from adaptid._kernels.toolchain import _covsweep
from adaptid._kernels.recursions import _covariance
_covsweep.VECTOR_SWEEP_MAX = vmax
_covariance.VECTOR_SWEEP_MAX = vmax
import adaptid
for n in ns:
    N = 4_000_000 // (n * n)
    rng = np.random.default_rng(n)
    Phi = rng.standard_normal((N, n)); y = Phi @ rng.standard_normal(n)
    adaptid.RLS(n, forgetting=0.99, P0=1e3, form="covariance").run(Phi[:50], y[:50])
    best = 1e9
    for _ in range(9):
        est = adaptid.RLS(n, forgetting=0.99, P0=1e3, form="covariance")
        t = time.perf_counter(); est.run(Phi, y, store=False); best = min(best, time.perf_counter() - t)
    print(n, N / best / 1e6)
"""


def child(vmax, ns, cache):
    env = dict(os.environ, NUMBA_CACHE_DIR=cache, OPENBLAS_NUM_THREADS="1")
    out = subprocess.run([sys.executable, "-c", CHILD, str(vmax), *map(str, ns)], env=env,
                         capture_output=True, text=True, check=True).stdout
    return {int(a): float(b) for a, b in (line.split() for line in out.splitlines())}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--ns", type=int, nargs="+", default=[40, 48, 64])
    args = ap.parse_args()
    from llvmlite import binding
    print(f"# covariance form, M updates/s; vector sweep (bound 64) against scalar loops "
          f"(bound 32); CPU {binding.get_host_cpu_name()}")
    with tempfile.TemporaryDirectory() as c64, tempfile.TemporaryDirectory() as c32:
        child(64, args.ns, c64), child(32, args.ns, c32)  # compile both first
        ratios = {n: [] for n in args.ns}
        for r in range(args.rounds):
            a, b = child(64, args.ns, c64), child(32, args.ns, c32)
            for n in args.ns:
                ratios[n].append(a[n] / b[n])
                print(f"round {r + 1} n={n:3d}: vector {a[n]:6.3f}  scalar {b[n]:6.3f}  "
                      f"ratio {a[n] / b[n]:.2f}", flush=True)
        for n in args.ns:
            print(f"n={n:3d}: median ratio vector / scalar {statistics.median(ratios[n]):.2f}")


if __name__ == "__main__":
    main()
