#!/usr/bin/env python
r"""Benchmark of FastRLS (O(n) per sample) against O(n²) RLS, in one process (issue 38).

Contenders on the same record (white input u ~ N(0, 1), y the output of a
random FIR filter of n taps plus 0.1·noise, λ = 0.999, δ = 1e-2), per n in
16, 64, 256, 1024:

* ``FastRLS(n, method="ftf").run_fir(u, y, store_theta=False)`` — the
  stabilised fast transversal filter;
* ``FastRLS(n, method="lattice", track_theta=False).run_fir(u, y)`` — the QR
  lattice, a-priori errors only (O(n));
* ``RLS(n, forgetting=λ).run(Phi, y, store=False)`` — adaptid's O(n²) RLS on
  the tapped-delay regressors;
* the O(n²) C loop ``benchmarks/c/rls_ref.c`` (covariance form) compiled in
  this run with ``gcc -O3 -march=native -DRLS_N=n`` (n a compile-time
  constant: gcc unrolls and vectorises), on the same regressors.

The O(n²) contenders run a shorter record (their cost per sample is what is
reported). Each figure is the best of ``--rounds`` timed calls after a
warm-up call. Printed: the cost per sample (ns) of every contender, the ratio
of the C loop's cost to the FTF's and lattice's (how many times faster the
fast filters are), and the slope of log(cost) against log(n) fitted over
the n's (1: linear in n, 2: quadratic). Before timing, the FTF's a-priori
errors on the short record are checked against RLS's (≤ 1e-8 relative).
Speed is never asserted.

``--floor`` times, instead, the cost floor of one stage of the lattice at
n = 256 in numba and in C (``benchmarks/c/lattice_floor.c``, gcc -O3
-march=native -fno-math-errno): a square root and a reciprocal of n
independent values (the lattice needs two per stage), one chain of
rotations (each stage waits for the previous multiply-add), and the
chained Givens rotation the lattice had before (square root and two
divisions on the chain). Printed: ns per stage of each, and the floor of one
stage of the lattice if every pass ran at the speed of its slowest part:
the forward pass (fused with the previous joint process) one chain, the
reflection pass max(its chain, one sqrt + reciprocal), the angle pass one
sqrt + reciprocal.

Usage::

    python benchmarks/bench_fastrls.py              # n = 16, 64, 256, 1024 (about a minute)
    python benchmarks/bench_fastrls.py --quick      # small records, 2 rounds
    python benchmarks/bench_fastrls.py --floor      # the lattice's cost floor per stage
"""

from __future__ import annotations

import argparse
import ctypes
import hashlib
import json
import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")
import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
LAM, DELTA = 0.999, 1e-2


def c_loop(n):
    """rls_run of benchmarks/c/rls_ref.c compiled with n fixed; None without gcc."""
    gcc = shutil.which("gcc")
    if gcc is None:
        return None
    src = HERE / "c" / "rls_ref.c"
    h = hashlib.sha256(src.read_bytes()).hexdigest()[:12]
    so = Path(tempfile.gettempdir()) / f"adaptid_rls_ref_{h}_n{n}_{os.getuid()}.so"
    if not so.exists():
        tmp = so.with_suffix(f".{os.getpid()}.tmp")
        subprocess.run([gcc, "-O3", "-march=native", "-shared", "-fPIC", f"-DRLS_N={n}",
                        str(src), "-o", str(tmp)], check=True)
        os.replace(tmp, so)
    fn = ctypes.CDLL(str(so)).rls_run
    dp = ctypes.POINTER(ctypes.c_double)
    fn.argtypes = [ctypes.c_int, ctypes.c_long, dp, dp, ctypes.c_double, dp, dp, dp, dp]
    fn.restype = ctypes.c_int

    def run(Phi, y):
        th, P = np.zeros(n), np.eye(n) / DELTA
        if fn(n, Phi.shape[0], Phi.ctypes.data_as(dp), y.ctypes.data_as(dp), LAM,
              th.ctypes.data_as(dp), P.ctypes.data_as(dp), None, None) != 0:
            raise RuntimeError("rls_ref.c refused n")
        return th
    return run


def delay_rows(u, n):
    N = u.shape[0]
    Phi = np.zeros((N, n))
    for i in range(min(n, N)):
        Phi[i:, i] = u[: N - i]
    return Phi


def best(fn, rounds):
    fn()  # warm-up (compilation, page faults)
    out = []
    for _ in range(rounds):
        t = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t)
    return min(out)


def measure(n, n_fast, n_slow, rounds):
    import adaptid
    rng = np.random.default_rng(n)
    u = rng.standard_normal(n_fast)
    y = np.convolve(u, rng.standard_normal(n))[:n_fast] + 0.1 * rng.standard_normal(n_fast)
    us, ys = u[:n_slow].copy(), y[:n_slow].copy()
    Phi = delay_rows(us, n)
    P0 = np.diag(LAM ** np.arange(n)) / DELTA
    e_ftf = adaptid.FastRLS(n, forgetting=LAM, delta=DELTA).run_fir(us, ys).error
    e_rls = adaptid.RLS(n, forgetting=LAM, P0=P0).run(Phi, ys).error
    check = float(np.max(np.abs(e_ftf - e_rls)) / np.max(np.abs(e_rls)))
    if check > 1e-8:
        raise SystemExit(f"n={n}: FTF and RLS differ by {check:.2e} (relative)")
    t = {
        "ftf": best(lambda: adaptid.FastRLS(n, forgetting=LAM, delta=DELTA)
                    .run_fir(u, y, store_theta=False), rounds) / n_fast,
        "lattice": best(lambda: adaptid.FastRLS(n, forgetting=LAM, delta=DELTA,
                                                method="lattice", track_theta=False)
                        .run_fir(u, y), rounds) / n_fast,
        "rls": best(lambda: adaptid.RLS(n, forgetting=LAM, P0=P0).run(Phi, ys, store=False),
                    rounds) / n_slow,
    }
    c = c_loop(n)
    t["c"] = None if c is None else best(lambda: c(Phi, ys), rounds) / n_slow
    return t, check


def floor_loops():
    """The numba versions of benchmarks/c/lattice_floor.c's loops (the kernel's flags)."""
    from numba import njit
    from adaptid._config import NJIT

    @njit(**NJIT)
    def sqrt_recip(q, r, v, reps):
        for _ in range(reps):
            for i in range(q.shape[0]):
                r[i] = np.sqrt(q[i])
            for i in range(q.shape[0]):
                v[i] = np.true_divide(1.0, r[i])

    @njit(**NJIT)
    def rot_chain(c, s, x, reps, ls):
        acc = 0.0
        for _ in range(reps):
            f = 0.25
            for i in range(x.shape[0]):
                t = x[i] * ls
                x[i] = s[i] * f + c[i] * t
                f = c[i] * f - s[i] * t
            acc += f
        return acc

    @njit(**NJIT)
    def givens_chain(x, e, reps):
        acc = 0.0
        for _ in range(reps):
            t, f = 1.0, 0.1
            for i in range(x.shape[0] - 1, -1, -1):
                h = np.sqrt(t * t + x[i] * x[i])
                cc, ss = t / h, x[i] / h
                a = e[i]
                e[i] = cc * a - ss * f
                f = cc * f + ss * a
                t = h
            acc += f + t
        return acc
    return sqrt_recip, rot_chain, givens_chain


def c_floor_loops():
    """benchmarks/c/lattice_floor.c compiled in this run; None without gcc."""
    gcc = shutil.which("gcc")
    if gcc is None:
        return None
    src = HERE / "c" / "lattice_floor.c"
    h = hashlib.sha256(src.read_bytes()).hexdigest()[:12]
    so = Path(tempfile.gettempdir()) / f"adaptid_lattice_floor_{h}_{os.getuid()}.so"
    if not so.exists():
        tmp = so.with_suffix(f".{os.getpid()}.tmp")
        subprocess.run([gcc, "-O3", "-march=native", "-fno-math-errno", "-shared", "-fPIC",
                        str(src), "-o", str(tmp), "-lm"], check=True)
        os.replace(tmp, so)
    lib = ctypes.CDLL(str(so))
    dp, i, lg, d = ctypes.POINTER(ctypes.c_double), ctypes.c_int, ctypes.c_long, ctypes.c_double
    lib.sqrt_recip.argtypes = [dp, dp, dp, i, lg]
    lib.rot_chain.argtypes = [dp, dp, dp, i, lg, d]
    lib.rot_chain.restype = d
    lib.givens_chain.argtypes = [dp, dp, i, lg]
    lib.givens_chain.restype = d

    def p(a):
        return a.ctypes.data_as(dp)
    return (lambda q, r, v, reps: lib.sqrt_recip(p(q), p(r), p(v), q.shape[0], reps),
            lambda c, s, x, reps, ls: lib.rot_chain(p(c), p(s), p(x), x.shape[0], reps, ls),
            lambda x, e, reps: lib.givens_chain(p(x), p(e), x.shape[0], reps))


FLOOR = ("sqrt + reciprocal, vectorised", "rotation chain (multiply-adds)",
         "chained Givens (sqrt, 2 div)")


def floor(n, reps, rounds):
    """ns per stage of each loop of FLOOR, {name: (numba, C or None)}."""
    rng = np.random.default_rng(0)
    q = rng.random(n) + 0.5
    ang = rng.random(n)
    c, s = np.cos(ang), np.sin(ang)
    x, e = 0.1 * rng.standard_normal(n), 0.01 * rng.standard_normal(n)
    r, v = np.empty(n), np.empty(n)
    args = ((q, r, v, reps), (c, s, x, reps, 0.9995), (x, e, reps))
    nb, cl = floor_loops(), c_floor_loops()
    out = {}
    for k, name in enumerate(FLOOR):
        fns = (nb[k], None if cl is None else cl[k])
        out[name] = tuple(None if f is None else
                          1e9 * best(lambda f=f: f(*args[k]), rounds) / (reps * n) for f in fns)
    return out


def print_floor(n, reps, rounds):
    """The floor table and the floor of one stage: the forward pass (with the previous
    joint process) is one chain; the reflection pass one chain beside one sqrt +
    reciprocal per stage; the angle pass one sqrt + reciprocal per stage, no chain."""
    res = floor(n, reps, rounds)
    print(f"ns per stage at n = {n} (best of {rounds}):")
    print()
    print("| loop | numba | C (gcc -O3 -march=native -fno-math-errno) |")
    print("|---|---|---|")
    for name, (nb, c) in res.items():
        print(f"| {name} | {nb:.2f} | {'–' if c is None else f'{c:.2f}'} |")
    sr, ch = res[FLOOR[0]][0], res[FLOOR[1]][0]
    fl = ch + max(ch, sr) + sr
    print()
    print(f"floor of one stage (numba): chain + max(chain, sqrt+recip) + sqrt+recip = "
          f"{fl:.2f} ns; {n} stages: {n * fl:.0f} ns per sample")


def slope(ns, costs):
    return float(np.polyfit(np.log(ns), np.log(costs), 1)[0])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    ap.add_argument("--ns", type=int, nargs="+", default=[16, 64, 256, 1024])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--quick", action="store_true", help="small records, 2 rounds")
    ap.add_argument("--json", help="write the figures to this file")
    ap.add_argument("--floor", action="store_true",
                    help="time the lattice's cost floor per stage (n = 256) instead")
    a = ap.parse_args(argv)
    if a.floor:
        print_floor(256, 20000, a.rounds)
        return
    rounds = 2 if a.quick else a.rounds
    work_fast, work_slow = (2e6, 2e7) if a.quick else (2e7, 3e8)
    res = {}
    for n in a.ns:
        n_fast = int(max(2000, work_fast / n))
        n_slow = int(min(n_fast, max(300, 2 * n, work_slow / n ** 2)))
        res[n], chk = measure(n, n_fast, n_slow, rounds)
        print(f"n={n:5d}: {n_fast} samples (O(n) filters), {n_slow} (O(n²)); "
              f"FTF vs RLS errors {chk:.1e}", flush=True)
    print()
    print("| n | FTF ns/sample | lattice ns/sample | RLS ns/sample | C loop ns/sample "
          "| C ÷ FTF | C ÷ lattice | RLS ÷ FTF |")
    print("|---|---|---|---|---|---|---|---|")
    for n, t in res.items():
        c = t["c"]
        cs = "–" if c is None else f"{1e9 * c:.0f}"
        r1 = "–" if c is None else f"{c / t['ftf']:.1f}"
        r2 = "–" if c is None else f"{c / t['lattice']:.1f}"
        print(f"| {n} | {1e9 * t['ftf']:.0f} | {1e9 * t['lattice']:.0f} | {1e9 * t['rls']:.0f} "
              f"| {cs} | {r1} | {r2} | {t['rls'] / t['ftf']:.1f} |")
    ns = list(res)
    slopes = {k: slope(ns, [res[n][k] for n in ns]) for k in ("ftf", "lattice", "rls", "c")
              if len(ns) > 1 and all(res[n][k] is not None for n in ns)}
    print()
    print("| fitted slope of log(cost per sample) against log(n) | "
          + " | ".join(slopes) + " |")
    print("|---|" + "---|" * len(slopes))
    print("| over n = " + ", ".join(map(str, ns)) + " | "
          + " | ".join(f"{v:.2f}" for v in slopes.values()) + " |")
    if a.json:
        Path(a.json).write_text(json.dumps({"per_sample_s": {str(n): t for n, t in res.items()},
                                            "slopes": slopes}, indent=1))


if __name__ == "__main__":
    main()
