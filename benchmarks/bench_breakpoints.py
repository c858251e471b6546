#!/usr/bin/env python
r"""Benchmark of ``adaptid.diagnostics.breakpoints`` against ruptures ``Dynp(model="linear")``.

Both find the least-squares partition of a linear regression into segments
of at least ``h`` samples (Bai & Perron's criterion; ruptures' ``linear``
cost is the residual sum of squares of ``lstsq`` on the segment):

* adaptid ``breakpoints(X, y, h=h)`` — the dynamic programme over the
  triangular RSS matrix built from recursive residuals in one compiled
  kernel, for **every** number of breaks m = 0 … ⌈N/h⌉ − 2 at once, the
  number chosen by BIC;
* ruptures ``Dynp(model="linear", min_size=h, jump=1).fit(signal)
  .predict(n_bkps=m)`` with the m adaptid's BIC chose — one number of
  breaks only; ``jump=1`` so that it searches every date (the exact
  optimum, as adaptid).

Data: N samples of y = a_j + b_j x + 0.5 e with x, e ~ N(0, 1) and two
breaks (at 30 % and 65 % of the sample); n = 2 regressors (1, x);
h = ⌊0.15 N⌋. Both are timed in the same process, adaptid after a
compile-warming call (wall-clock and process CPU time), and the script checks that the two segmentations are
identical before printing the ratio (ruptures' time / adaptid's). Timings
are the best of ``--repeat`` runs for adaptid and one run for ruptures
(ruptures takes minutes at N = 5000: its recursion computes O(N²)
segment costs, each an ``lstsq`` on up to N rows).

Usage::

    python benchmarks/bench_breakpoints.py              # N = 5000 (ruptures: minutes)
    python benchmarks/bench_breakpoints.py --n 1000     # quicker
    python benchmarks/bench_breakpoints.py --json out.json
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402


def make_data(N: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    x = rng.standard_normal(N)
    t = np.arange(N)
    a = np.where(t < 0.3 * N, 0.0, np.where(t < 0.65 * N, 1.0, 0.3))
    b = np.where(t < 0.3 * N, 1.0, np.where(t < 0.65 * N, 1.5, 0.8))
    y = a + b * x + 0.5 * rng.standard_normal(N)
    return np.column_stack([np.ones(N), x]), y


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=5000, help="number of samples N (default 5000)")
    ap.add_argument("--trim", type=float, default=0.15, help="h as a fraction of N (default 0.15)")
    ap.add_argument("--repeat", type=int, default=5, help="adaptid repetitions (best of)")
    ap.add_argument("--json", help="write the results to this file")
    args = ap.parse_args(argv)

    import ruptures as rpt

    import adaptid
    from adaptid.diagnostics import breakpoints

    X, y = make_data(args.n)
    N, n = X.shape
    h = int(np.floor(args.trim * N))
    Xw, yw = make_data(300, seed=1)
    breakpoints(Xw, yw, h=45)                      # compile (or load the cache) first

    t_ad = c_ad = np.inf
    for _ in range(args.repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        bp = breakpoints(X, y, h=h)
        t_ad = min(t_ad, time.perf_counter() - t0)
        c_ad = min(c_ad, time.process_time() - c0)
    m = bp.n_breaks
    ours = [int(b) + 1 for b in bp.breakpoints] + [N]   # ruptures: exclusive segment ends

    signal = np.column_stack([y, X])                # ruptures "linear": y first, then covariates
    t0, c0 = time.perf_counter(), time.process_time()
    theirs = rpt.Dynp(model="linear", min_size=h, jump=1).fit(signal).predict(n_bkps=m)
    t_rp = time.perf_counter() - t0
    c_rp = time.process_time() - c0
    same = [int(b) for b in theirs] == ours
    rss_ours = float(bp.rss[m])
    rss_theirs = float(sum(np.linalg.lstsq(X[a:b], y[a:b], rcond=None)[1].sum()
                           for a, b in zip([0] + list(theirs[:-1]), theirs)))
    print(f"breakpoints: N = {N}, n = {n}, h = {h} ({args.trim:g} N), BIC chose m = {m} breaks")
    print(f"  adaptid breakpoints (all m = 0..{bp.max_breaks}, best of {args.repeat}): "
          f"{t_ad:.3f} s wall, {c_ad:.3f} s CPU  -> segment ends {ours}, RSS {rss_ours:.6f}")
    print(f"  ruptures Dynp(linear, jump=1, n_bkps={m}): "
          f"{t_rp:.3f} s wall, {c_rp:.3f} s CPU  -> segment ends {list(map(int, theirs))}, "
          f"RSS {rss_theirs:.6f}")
    print(f"  same segmentation: {same}")
    print(f"  ratio ruptures / adaptid (same run): {t_rp / t_ad:.1f}x wall-clock, "
          f"{c_rp / c_ad:.1f}x CPU time (both single-threaded; CPU time is robust to a busy machine)")
    if not same:
        raise SystemExit("the two segmentations differ: ratio not comparable")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"N": N, "n": n, "h": h, "m": m, "adaptid_s": t_ad, "ruptures_s": t_rp,
                       "ratio": t_rp / t_ad, "adaptid_cpu_s": c_ad, "ruptures_cpu_s": c_rp,
                       "ratio_cpu": c_rp / c_ad, "same": same, "adaptid": adaptid.__version__,
                       "ruptures": rpt.__version__, "machine": platform.platform(),
                       "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}, fh, indent=1)


if __name__ == "__main__":
    main()
