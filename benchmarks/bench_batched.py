#!/usr/bin/env python
r"""Many RLS streams at once: ``run_batched`` / ``run_segments`` against one C thread.

Same process, same data (φ ~ N(0, I), y = φᵀθ* + 0.1·noise, λ = 0.99,
P0 = 1e3·I, θ0 = 0), B = 10 000 streams at n = 2, 4, 8:

* adaptid ``RLS(n, forgetting=0.99).run_batched(Phi (B, N, n), y)`` — the
  structure-of-arrays kernels of ``_kernels/lanes/_soa.py`` (the engine's fast path),
  with ``store=False`` and with the default ``store=True``;
* the same for ``RLS(n, form="covariance")`` (n <= 7: the covariance form's
  lane kernels, ``_kernels/lanes/_soa_cov.py``) — "cov";
* the same call on the kernels it replaced (``_kernels/recursions/_rls.py``, one scalar
  stream per ``prange`` iteration; the engine's dispatch switched off in this
  process) — "old";
* ``run_segments`` on the same samples as B segments of N, and on segments of
  random lengths (1 … 2N − 1, the same total);
* the C reference ``/work/shared/bench/rls_ref.c`` (the library's yardstick:
  textbook ``rls_run_nN``, triangle ``rls_tri_nN``, fused ``rls_fu_nN``,
  each with n a compile-time constant), compiled here with
  ``gcc -O3 -march=native`` as ``quick_ratios.py`` compiles it, with a loop over
  the streams in C (a wrapper that includes the file; it is not edited); the
  fastest variant of each round is the reference — one thread. C keeps no
  trajectory and no errors: compare it with ``store=False``.

N = 2600 samples per stream, the N of the batched case of
``benchmarks/bench_rls.py`` (B = 10 000, N = 2596 in its recorded runs), fed as
10 consecutive calls of 260 samples (each call continues the previous state,
for C too): the calls' output then fits in reused heap pages instead of a
gigabyte of freshly zeroed ones (as bench_rls.py's chunked timings). Segments
cannot continue a state, so ``run_segments`` takes 10 calls on 260-sample
pieces (B segments per call).

And a floor that no kernel of this layout can beat: a numba loop over the
streams (parallel, as adaptid's) that only reads each sample's φ and y and
writes ε = y − Σφᵢ into a fresh (B, N) array per call — the data movement of
``run_batched(store=False)`` without its arithmetic ("memory floor"). Its
"per core" figure is the ceiling of the structure-of-arrays kernels on this
machine's memory bandwidth.

Timings are interleaved (each round runs every contender once, shuffled); the
table gives the median updates/s over the rounds and the ratio "per core":
adaptid's updates/s divided by the numba threads it used, over one C thread's.
Results are compared before timing (bit for bit old vs SoA; C within 1e-8
relative — another algorithm in float64). Speed is never asserted.

    python benchmarks/bench_batched.py [--rounds 5] [--ns 2 4 8] [--streams 10000]
"""

from __future__ import annotations

import argparse
import ctypes
import hashlib
import os
import statistics
import subprocess
import tempfile
import time

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_v, "1")
import numpy as np  # noqa: E402

C_SOURCE = "/work/shared/bench/rls_ref.c"
LAM, P0 = 0.99, 1e3
CALLS, CHUNK = 10, 260
VARIANTS = ("rls_run", "rls_tri", "rls_fu")
WRAPPER = """#include "rls_ref.c"
#define LOOP(F) void loop_##F(long B, long N, const double *Phi, const double *y, double lam, \\
                               double *theta, double *P, int n) { \\
    for (long b = 0; b < B; ++b) F(N, 1, Phi + b * N * n, y + b * N, lam, theta + b * n, P + b * n * n); }
"""


def c_lib(ns):
    """rls_ref.c plus a loop over streams per variant and n, built in the temp folder."""
    src = WRAPPER + "".join(f"LOOP({v}_n{n})\n" for n in ns for v in VARIANTS)
    ref = open(C_SOURCE, "rb").read()
    h = hashlib.sha256(ref + src.encode()).hexdigest()[:12]
    so = os.path.join(tempfile.gettempdir(), f"rls_ref_loops_{h}_{os.getuid()}.so")
    if not os.path.exists(so):
        c = so[:-3] + ".c"
        with open(c, "w") as fh:
            fh.write(src)
        subprocess.run(["gcc", "-O3", "-march=native", "-shared", "-fPIC",
                        "-I", os.path.dirname(C_SOURCE), c, "-o", so + ".tmp"], check=True)
        os.replace(so + ".tmp", so)
    lib = ctypes.CDLL(so)
    dp = ctypes.POINTER(ctypes.c_double)
    for n in ns:
        for v in VARIANTS:
            f = getattr(lib, f"loop_{v}_n{n}")
            f.argtypes = [ctypes.c_long, ctypes.c_long, dp, dp, ctypes.c_double, dp, dp,
                          ctypes.c_int]
    return lib


def c_run(lib, variant, Phi, y):
    B, N, n = Phi.shape
    dp = ctypes.POINTER(ctypes.c_double)
    theta = np.zeros((B, n))
    P = np.broadcast_to(np.eye(n) * P0, (B, n, n)).copy()
    f = getattr(lib, f"loop_{variant}_n{n}")
    t = time.perf_counter()
    for _ in range(CALLS):
        f(B, N, Phi.ctypes.data_as(dp), y.ctypes.data_as(dp), LAM, theta.ctypes.data_as(dp),
          P.ctypes.data_as(dp), n)
    return time.perf_counter() - t, theta


def ad_batched(Phi, y, store, form="ud"):
    import adaptid
    est = adaptid.RLS(Phi.shape[2], forgetting=LAM, P0=P0, form=form)
    t = time.perf_counter()
    for _ in range(CALLS):
        est.run_batched(Phi, y, store=store)
    return time.perf_counter() - t, est.theta


def ad_segments(P2, y2, off, form="ud"):
    import adaptid
    est = adaptid.RLS(P2.shape[1], forgetting=LAM, P0=P0, form=form)
    t = time.perf_counter()
    for _ in range(CALLS):
        res = est.run_segments(P2, y2, off)
    return time.perf_counter() - t, res.theta


def floor_kernel():
    """The memory floor: read φ and y, write ε = y − Σφᵢ (no RLS arithmetic)."""
    import numba

    @numba.njit(parallel=True, fastmath=True)
    def floor(Phi, y, E):
        for b in numba.prange(Phi.shape[0]):
            for k in range(Phi.shape[1]):
                s = y[b, k]
                for i in range(Phi.shape[2]):
                    s -= Phi[b, k, i]
                E[b, k] = s
    return floor


def floor_run(kernel, Phi, y):
    t = time.perf_counter()
    for _ in range(CALLS):
        kernel(Phi, y, np.empty(y.shape))
    return time.perf_counter() - t, None


def old_path(fn):
    """Run fn with the engine's structure-of-arrays dispatch switched off."""
    from adaptid._kernels.lanes import _soa
    keep = _soa.MIN_STREAMS
    _soa.MIN_STREAMS = 1 << 62
    try:
        return fn()
    finally:
        _soa.MIN_STREAMS = keep


def cases_for(n, B, lib, rng):
    Phi = rng.standard_normal((B, CHUNK, n))
    y = Phi @ rng.standard_normal(n) + 0.1 * rng.standard_normal((B, CHUNK))
    P2, y2 = Phi.reshape(B * CHUNK, n), y.reshape(B * CHUNK)
    off = np.arange(B + 1) * CHUNK
    lengths = rng.integers(1, 2 * CHUNK, B)
    lengths[-1] += B * CHUNK - lengths.sum()  # the same total
    if lengths[-1] < 0:
        lengths = np.full(B, CHUNK)
    off_r = np.concatenate([[0], np.cumsum(lengths)])
    cases = {
        "batched store=False": lambda: ad_batched(Phi, y, False),
        "batched store=False old": lambda: old_path(lambda: ad_batched(Phi, y, False)),
        "batched store=True": lambda: ad_batched(Phi, y, True),
        "batched store=True old": lambda: old_path(lambda: ad_batched(Phi, y, True)),
        "segments (B x N)": lambda: ad_segments(P2, y2, off),
        "segments (B x N) old": lambda: old_path(lambda: ad_segments(P2, y2, off)),
        "segments random lengths": lambda: ad_segments(P2, y2, off_r),
        "segments random lengths old": lambda: old_path(lambda: ad_segments(P2, y2, off_r)),
    }
    from adaptid._kernels.lanes._soa import COV_MAX_N
    if n <= COV_MAX_N:  # the covariance form's lane kernels
        cases.update({
            "cov batched store=False": lambda: ad_batched(Phi, y, False, "covariance"),
            "cov batched store=False old":
                lambda: old_path(lambda: ad_batched(Phi, y, False, "covariance")),
            "cov segments (B x N)": lambda: ad_segments(P2, y2, off, "covariance"),
            "cov segments (B x N) old":
                lambda: old_path(lambda: ad_segments(P2, y2, off, "covariance")),
        })
    floor = floor_kernel()
    cases["memory floor (no arithmetic)"] = lambda: floor_run(floor, Phi, y)
    if lib is not None:
        for v in VARIANTS:
            cases[f"C {v}_n{n}"] = (lambda v=v: c_run(lib, v, Phi, y))
    return cases


def check(cases, B):
    """Old and new kernels bit for bit; C within 1e-8 relative (final θ)."""
    out = {k: fn()[1] for k, fn in cases.items()}
    out = {k: v for k, v in out.items() if v is not None}  # the memory floor has no θ
    for k in list(out):
        if k.endswith(" old"):
            assert np.array_equal(out[k], out[k[:-4]]), k
    c = [v for k, v in out.items() if k.startswith("C ")]
    for th in c:
        rel = np.max(np.abs(th - out["batched store=False"])) / np.max(np.abs(th))
        assert rel < 1e-8, rel


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--ns", type=int, nargs="+", default=[2, 4, 8])
    ap.add_argument("--streams", type=int, default=10_000)
    args = ap.parse_args(argv)
    import numba
    threads = numba.get_num_threads()
    lib = c_lib(args.ns) if os.path.exists(C_SOURCE) else None
    rng = np.random.default_rng(0)
    B = args.streams
    print(f"# B = {B} streams, N = {CALLS} x {CHUNK} samples, numba threads = {threads}, "
          f"C: {C_SOURCE} (1 thread)")
    for n in args.ns:
        cases = cases_for(n, B, lib, rng)
        check(cases, B)
        times = {k: [] for k in cases}
        for _ in range(args.rounds):
            for k in rng.permutation(list(cases)):
                times[k].append(cases[k]()[0])
        upd = B * CALLS * CHUNK
        rate = {k: upd / statistics.median(v) for k, v in times.items()}
        c_best = [max(upd / times[k][r] for k in cases if k.startswith("C "))
                  for r in range(args.rounds)] if lib is not None else None
        c_rate = statistics.median(c_best) if c_best else float("nan")
        print(f"\n## n = {n}: C best variant per round, median {c_rate / 1e6:.1f} M updates/s")
        print(f"| {'case':32s} | M updates/s | per core / 1 C thread |")
        print(f"|{'-' * 34}|-------------|-----------------------|")
        for k, r in rate.items():
            if k.startswith("C "):
                print(f"| {k:32s} | {r / 1e6:11.1f} | {r / c_rate:21.2f} |")
                continue
            per_core = statistics.median(
                [upd / times[k][i] / threads / c_best[i] for i in range(args.rounds)]) \
                if c_best else float("nan")
            print(f"| {k:32s} | {r / 1e6:11.1f} | {per_core:21.2f} |")


if __name__ == "__main__":
    main()
