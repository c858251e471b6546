#!/usr/bin/env python
r"""Benchmark of adaptid's recursive core against other RLS implementations.

Contenders, all on the same generated data (λ = 0.99, P0 = 1e4·I, θ0 = 0,
Gaussian regressors φ ~ N(0, I), y = φᵀθ* + 0.1·noise):

* adaptid ``RLS(n, forgetting=0.99).run(Phi, y)`` — the default path (input
  validation, U-D / Bierman kernel specialised per n, θ stored per sample);
* a C loop of the textbook covariance form P ← (P − Kφᵀ P)/λ compiled at run
  time with ``gcc -O3 -march=native`` (``benchmarks/c/rls_ref.c``), built with
  n a compile-time constant and with n at run time (the targets use the faster
  of the two in each round), storing θ and ε per sample like adaptid, and
  without storing; and, for information, the symmetric (upper-triangle) form;
* the same textbook loop in NumPy, one Python iteration per sample;
* padasip ``FilterRLS(n, mu=0.99, eps=1e-4, w="zeros").run(y, Phi)`` (its
  ``mu`` is the forgetting factor and its initial P is ``I/eps``, so this is
  the same estimator with the same prior);
* statsmodels ``RecursiveLS(y, Phi).fit()`` — λ = 1 only (no forgetting; it
  also runs a smoother), timed anyway as the best-known Python RLS;
* ``update`` called from Python (µs per call, validation included);
* ``run_batched`` over B streams against the C loop over streams (serial, and
  OpenMP with as many threads as numba uses);
* ``SlidingWindowRLS(4, 100).run`` against re-solving the window with
  ``numpy.linalg.lstsq`` at every step (timed on a subset of steps,
  extrapolated per step).

Every timing processes N samples, N chosen from a pilot run so that it takes
at least ``--target-time`` seconds (0.2 s by default). The compiled contenders
(adaptid, C) process them as a stream of calls on consecutive chunks of
``--chunk-mib`` MiB of output (16 MiB: 524 288 samples at n = 4), each call
continuing the previous one's state — bit-for-bit the same result as one call
(checked) — so that the timing measures the estimator and not the kernel
zeroing fresh pages for a gigabyte of output; one-call timings ("1 call") of
the same N are reported beside them, for what a single huge call costs. The
timings are interleaved: each round runs every contender once, in a shuffled
order; the report gives median rates over rounds and the median of same-round
ratios. Before timing, a check phase compares the results of the contenders
(that is what the smoke test asserts; speed is never asserted).

BLAS is limited to one thread (``OPENBLAS_NUM_THREADS=1`` unless set): the
NumPy, padasip, statsmodels and lstsq contenders only do tiny products, and an
idle OpenBLAS pool spinning on the second core would slow the contender timed
next.

Usage::

    python benchmarks/bench_rls.py                  # full run (a few minutes)
    python benchmarks/bench_rls.py --quick          # small sizes, 2 rounds
    python benchmarks/bench_rls.py --json out.json  # also write raw results
"""

from __future__ import annotations

import argparse
import ctypes
import datetime as _dt
import gc
import hashlib
import json
import os
import platform
import shutil
import subprocess
import sys
import time
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before numpy is imported

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
C_SOURCE = HERE / "c" / "rls_ref.c"
BUILD_DIR = HERE / "_build"
C_FLAGS = ["-O3", "-march=native", "-std=gnu11", "-fPIC", "-shared", "-fopenmp"]

LAM = 0.99
P0 = 1e4
NOISE = 0.1
NS = (4, 8, 16, 32)
WINDOW = 100
BATCH_N_PARAMS = 4
CHUNK_MIB = 16

# Targets of the issue: (ratio name, comparison, threshold)
# The C reference of the targets is the textbook form, the faster of its two
# builds (n fixed at compile time, n at run time) in each round: gcc's fully
# unrolled n = 16 build is slower than its loop.
TARGETS = {
    "rls_vs_cbest_n4": (">=", 1.0),
    "rls_vs_cbest_n8": (">=", 1.0),
    "rls_vs_cbest_n16": (">=", 1.0),
    "rls_vs_cbest_n32": (">=", 0.5),
    "rls_vs_padasip_n4": (">=", 300.0),
    "rls_vs_padasip_n8": (">=", 300.0),
    "rls_vs_padasip_n16": (">=", 300.0),
    "rls_vs_padasip_n32": (">=", 300.0),
    "update_us_n4": ("<", 2.0),
    "batched_vs_c_serial": (">=", 1.0),
    "batched_vs_c_omp": (">=", 1.0),
    "window_vs_lstsq": (">=", 150.0),
}


# --------------------------------------------------------------------------
# data
# --------------------------------------------------------------------------
def make_data(n, N, seed, B=None):
    """Gaussian regressors and noisy outputs; (B, N, n) when B is given."""
    rng = np.random.default_rng([seed, n, 0 if B is None else B])
    theta_true = rng.standard_normal(n)
    shape = (N, n) if B is None else (B, N, n)
    Phi = rng.standard_normal(shape)
    y = Phi @ theta_true + NOISE * rng.standard_normal(shape[:-1])
    return Phi, y


# --------------------------------------------------------------------------
# the C reference
# --------------------------------------------------------------------------
def gcc_version():
    gcc = shutil.which("gcc")
    if gcc is None:
        return None
    out = subprocess.run([gcc, "--version"], capture_output=True, text=True, check=False)
    return out.stdout.splitlines()[0] if out.stdout else gcc


def build_c(fixed_n=None, symmetric=False):
    """Compile rls_ref.c (n fixed at compile time or not; textbook or symmetric update)
    into benchmarks/_build; None without gcc."""
    gcc = shutil.which("gcc")
    if gcc is None:
        return None
    flags = list(C_FLAGS) + ([f"-DRLS_N={fixed_n}"] if fixed_n else []) + \
        (["-DRLS_SYM=1"] if symmetric else [])
    src = C_SOURCE.read_bytes()
    tag = hashlib.sha256(src + " ".join(flags).encode() + (gcc_version() or "").encode()).hexdigest()[:12]
    BUILD_DIR.mkdir(parents=True, exist_ok=True)
    lib = BUILD_DIR / (f"rls_ref_{'n%d' % fixed_n if fixed_n else 'nany'}"
                       f"{'_sym' if symmetric else ''}_{tag}.so")
    if not lib.exists():
        tmp = lib.with_name(f".{lib.name}.{os.getpid()}.tmp")
        subprocess.run([gcc, *flags, str(C_SOURCE), "-o", str(tmp)], check=True)
        os.replace(tmp, lib)  # atomic: a concurrent run sees the old or the new file
    dll = ctypes.CDLL(str(lib))
    p = ctypes.c_void_p
    dll.rls_run.argtypes = [ctypes.c_int, ctypes.c_long, p, p, ctypes.c_double, p, p, p, p]
    dll.rls_run.restype = ctypes.c_int
    dll.rls_run_batched.argtypes = [ctypes.c_int, ctypes.c_long, ctypes.c_long, p, p,
                                    ctypes.c_double, p, p, p, p, ctypes.c_int]
    dll.rls_run_batched.restype = ctypes.c_int
    dll.path = str(lib)
    return dll


def _ptr(a):
    if a is None:
        return None
    assert a.dtype == np.float64 and a.flags.c_contiguous
    return a.ctypes.data


def _chunks(N, chunk):
    chunk = N if not chunk else chunk
    return [(s, min(N, s + chunk)) for s in range(0, N, chunk)]


def c_run(lib, Phi, y, store=True, chunk=None):
    """C loop on one stream, in calls of ``chunk`` samples (None: one call).

    Returns (elapsed, theta, Th, E) with Th, E those of the last call.
    """
    N, n = Phi.shape
    theta = np.zeros(n)
    P = np.eye(n) * P0
    parts = _chunks(N, chunk)
    Th = E = None
    t0 = time.perf_counter()
    for a, b in parts:
        Th = np.empty((b - a, n)) if store else None
        E = np.empty(b - a) if store else None
        rc = lib.rls_run(n, b - a, _ptr(Phi[a:b]), _ptr(y[a:b]), LAM, _ptr(theta), _ptr(P),
                         _ptr(Th), _ptr(E))
        if rc:
            raise RuntimeError(f"rls_run returned {rc}")
    t1 = time.perf_counter()
    return t1 - t0, theta, Th, E


def c_run_batched(lib, parts, nthreads, store=True):
    """C loop over streams; ``parts``: list of (Phi (B, N_i, n), y (B, N_i)) time blocks."""
    B, _, n = parts[0][0].shape
    theta = np.zeros((B, n))
    P = np.broadcast_to(np.eye(n) * P0, (B, n, n)).copy()
    Th = E = None
    t0 = time.perf_counter()
    for Phi, y in parts:
        Nc = Phi.shape[1]
        Th = np.empty((B, Nc, n)) if store else None
        E = np.empty((B, Nc)) if store else None
        rc = lib.rls_run_batched(n, B, Nc, _ptr(Phi), _ptr(y), LAM, _ptr(theta), _ptr(P),
                                 _ptr(Th), _ptr(E), nthreads)
        if rc:
            raise RuntimeError(f"rls_run_batched returned {rc}")
    t1 = time.perf_counter()
    return t1 - t0, theta, Th, E


# --------------------------------------------------------------------------
# the Python contenders
# --------------------------------------------------------------------------
def adaptid_run(Phi, y, store=True, chunk=None):
    """``RLS(n, forgetting=0.99).run`` in calls of ``chunk`` samples (None: one call)."""
    import adaptid
    est = adaptid.RLS(Phi.shape[1], forgetting=LAM, P0=P0)
    parts = _chunks(Phi.shape[0], chunk)
    traj = None
    t0 = time.perf_counter()
    for a, b in parts:
        traj = est.run(Phi[a:b], y[a:b], store=store)
    t1 = time.perf_counter()
    return t1 - t0, est.theta, traj


def adaptid_batched(parts):
    """``RLS(4, forgetting=0.99).run_batched`` on consecutive time blocks of B streams."""
    import adaptid
    est = adaptid.RLS(parts[0][0].shape[2], forgetting=LAM, P0=P0)
    traj = None
    t0 = time.perf_counter()
    for Phi, y in parts:
        traj = est.run_batched(Phi, y)
    t1 = time.perf_counter()
    return t1 - t0, est.theta, traj


def adaptid_update(rows, ys, n):
    """``update`` once per sample from a Python loop; rows: list of (n,) arrays, ys: floats."""
    import adaptid
    est = adaptid.RLS(n, forgetting=LAM, P0=P0)
    upd = est.update
    t0 = time.perf_counter()
    for phi, yk in zip(rows, ys):
        upd(phi, yk)
    t1 = time.perf_counter()
    return t1 - t0, est.theta


def numpy_loop(Phi, y):
    """The textbook covariance form, one Python iteration per sample."""
    N, n = Phi.shape
    t0 = time.perf_counter()
    theta = np.zeros(n)
    P = np.eye(n) * P0
    Th = np.empty((N, n))
    il = 1.0 / LAM
    for k in range(N):
        phi = Phi[k]
        e = y[k] - phi @ theta
        g = P @ phi
        h = phi @ P
        K = g / (LAM + phi @ g)
        theta = theta + K * e
        P = (P - np.outer(K, h)) * il
        Th[k] = theta
    t1 = time.perf_counter()
    return t1 - t0, theta, Th


def padasip_run(Phi, y):
    import padasip as pa
    f = pa.filters.FilterRLS(Phi.shape[1], mu=LAM, eps=1.0 / P0, w="zeros")
    t0 = time.perf_counter()
    f.run(y, Phi)
    t1 = time.perf_counter()
    return t1 - t0, f.w.copy()


def statsmodels_run(Phi, y):
    from statsmodels.regression.recursive_ls import RecursiveLS
    t0 = time.perf_counter()
    res = RecursiveLS(y, Phi).fit()
    t1 = time.perf_counter()
    return t1 - t0, np.asarray(res.params)


def window_run(Phi, y, chunk=None):
    import adaptid
    est = adaptid.SlidingWindowRLS(Phi.shape[1], WINDOW, P0=P0)
    traj = None
    t0 = time.perf_counter()
    for a, b in _chunks(Phi.shape[0], chunk):
        traj = est.run(Phi[a:b], y[a:b])
    t1 = time.perf_counter()
    return t1 - t0, traj


def lstsq_window(Phi, y, steps, prior=False):
    """Re-solve the window [k-M+1, k] by lstsq for k = M-1 .. M-1+steps-1."""
    n = Phi.shape[1]
    M = WINDOW
    out = np.empty((steps, n))
    lstsq = np.linalg.lstsq
    if prior:  # the same cost as SlidingWindowRLS (λ = 1): the prior as n extra rows
        R = np.eye(n) / np.sqrt(P0)
        z = np.zeros(n)
    t0 = time.perf_counter()
    for s in range(steps):
        k = M - 1 + s
        if prior:
            out[s] = lstsq(np.vstack([Phi[k - M + 1:k + 1], R]),
                           np.concatenate([y[k - M + 1:k + 1], z]), rcond=None)[0]
        else:
            out[s] = lstsq(Phi[k - M + 1:k + 1], y[k - M + 1:k + 1], rcond=None)[0]
    t1 = time.perf_counter()
    return t1 - t0, out


# --------------------------------------------------------------------------
# harness
# --------------------------------------------------------------------------
class Case:
    """One contender: ``fn()`` returns the elapsed seconds of one timing of ``count`` updates."""

    def __init__(self, cid, group, label, count, fn, unit="updates"):
        self.id, self.group, self.label, self.count, self.fn, self.unit = cid, group, label, count, fn, unit
        self.times = []

    def time_once(self):
        gc.collect()
        gc.disable()
        try:
            dt = self.fn()
        finally:
            gc.enable()
        self.times.append(dt)
        return dt

    def rates(self):
        return [self.count / t for t in self.times]

    def summary(self):
        r = self.rates()
        return {
            "label": self.label, "group": self.group, "count": self.count, "unit": self.unit,
            "times_s": self.times, "rates_per_s": r,
            "median_time_s": float(np.median(self.times)), "min_time_s": float(min(self.times)),
            "median_rate_per_s": float(np.median(r)),
        }


def pilot_rate(fn, count, repeats=2):
    """Updates/s of ``fn`` (count updates), best of a few runs after one warm-up."""
    fn()
    best = min(fn() for _ in range(repeats))
    return count / best


def sized(rate, target, lo, hi, margin):
    return int(min(hi, max(lo, np.ceil(rate * target * margin))))


def environment():
    import numba
    cpu = "?"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    versions = {"python": platform.python_version(), "numpy": np.__version__,
                "numba": numba.__version__}
    for mod in ("adaptid", "padasip", "statsmodels", "scipy"):
        try:
            m = __import__(mod)
            versions[mod] = getattr(m, "__version__", "?")
        except ImportError:
            versions[mod] = None
    try:
        from importlib.metadata import version
        versions["padasip"] = version("padasip")
    except Exception:  # pragma: no cover
        pass
    return {
        "date": _dt.datetime.now().astimezone().isoformat(timespec="seconds"),
        "command": " ".join([Path(sys.executable).name, *sys.argv]),
        "platform": platform.platform(), "cpu": cpu, "nproc": os.cpu_count(),
        "affinity": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None,
        "loadavg_start": os.getloadavg() if hasattr(os, "getloadavg") else None,
        "numba_threads": numba.get_num_threads(),
        "gcc": gcc_version(), "c_flags": " ".join(C_FLAGS),
        "versions": versions,
        "adaptid_path": str(Path(__import__("adaptid").__file__).parent),
        "numba_cache_dir": os.environ.get("NUMBA_CACHE_DIR"),
    }


def rel_diff(a, b):
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300))


# --------------------------------------------------------------------------
# correctness of the comparison (not speed)
# --------------------------------------------------------------------------
def run_checks(data, libs, libs_sym, lib_any, Nc, Phi_b, y_b, Phi4, y4, chunk_b):
    import adaptid
    checks = {}
    for n, (Phi, y) in data.items():
        P, Y = Phi[:Nc], y[:Nc]
        _, th_a, traj = adaptid_run(P, Y)
        c = {"N": Nc, "theta_norm": float(np.linalg.norm(th_a))}
        if libs.get(n) is not None:
            _, th_c, Th_c, E_c = c_run(libs[n], P, Y)
            c["c_fixed_theta_traj_rel"] = rel_diff(traj.theta, Th_c)
            c["c_fixed_error_rel"] = rel_diff(traj.error, E_c)
            c["c_fixed_final_rel"] = rel_diff(th_a, th_c)
            _, th_c2, _, _ = c_run(libs[n], P, Y, store=False)
            c["c_nostore_final_rel"] = rel_diff(th_a, th_c2)
        if lib_any is not None:
            _, th_g, Th_g, _ = c_run(lib_any, P, Y)
            c["c_any_theta_traj_rel"] = rel_diff(traj.theta, Th_g)
        if libs_sym.get(n) is not None:
            _, th_s, Th_s, _ = c_run(libs_sym[n], P, Y)
            c["c_sym_theta_traj_rel"] = rel_diff(traj.theta, Th_s)
        _, th_np, Th_np = numpy_loop(P, Y)
        c["numpy_theta_traj_rel"] = rel_diff(traj.theta, Th_np)
        Np = min(Nc, 2000)
        _, th_a_p, _ = adaptid_run(P[:Np], Y[:Np])
        _, th_pa = padasip_run(P[:Np], Y[:Np])
        c["padasip_N"] = Np
        c["padasip_final_rel"] = rel_diff(th_a_p, th_pa)
        # statsmodels is λ = 1 (OLS with a diffuse prior): compare with lstsq,
        # and adaptid with λ = 1 and a near-diffuse prior with the same lstsq.
        Ns = min(Nc, 500)
        _, th_sm = statsmodels_run(P[:Ns], Y[:Ns])
        th_ls = np.linalg.lstsq(P[:Ns], Y[:Ns], rcond=None)[0]
        est1 = adaptid.RLS(n, forgetting=1.0, P0=1e10)
        est1.run(P[:Ns], Y[:Ns])
        c["statsmodels_N"] = Ns
        c["statsmodels_vs_lstsq_rel"] = rel_diff(th_sm, th_ls)
        c["adaptid_lam1_vs_lstsq_rel"] = rel_diff(est1.theta, th_ls)
        checks[f"n{n}"] = c
    # update N times == run, bit for bit (the library's contract)
    Nu = min(Nc, 2000)
    est = adaptid.RLS(4, forgetting=LAM, P0=P0)
    for phi, yk in zip(list(Phi4[:Nu]), y4[:Nu].tolist()):
        est.update(phi, yk)
    _, th_run, _ = adaptid_run(Phi4[:Nu], y4[:Nu])
    checks["update_equals_run"] = bool(np.array_equal(est.theta, th_run))
    # the chunked timings compute exactly what one call computes
    Nk = min(Phi4.shape[0], 3 * 1000 + 17)
    _, th_one, _ = adaptid_run(Phi4[:Nk], y4[:Nk])
    _, th_chunk, _ = adaptid_run(Phi4[:Nk], y4[:Nk], chunk=1000)
    checks["chunked_equals_one_call"] = bool(np.array_equal(th_one, th_chunk))
    # batched (a subset of the streams), one call and in time blocks
    Bc = min(Phi_b.shape[0], 64)
    P_b, Y_b = np.ascontiguousarray(Phi_b[:Bc]), np.ascontiguousarray(y_b[:Bc])
    _, th_b, traj_b = adaptid_batched([(P_b, Y_b)])
    parts = [(np.ascontiguousarray(P_b[:, a:b]), np.ascontiguousarray(Y_b[:, a:b]))
             for a, b in _chunks(P_b.shape[1], chunk_b)]
    _, th_bk, _ = adaptid_batched(parts)
    cb = {"B": Bc, "N": Phi_b.shape[1], "chunked_equals_one_call": bool(np.array_equal(th_b, th_bk))}
    if libs.get(BATCH_N_PARAMS) is not None:
        _, th_cb, Th_cb, _ = c_run_batched(libs[BATCH_N_PARAMS], [(P_b, Y_b)], 2)
        cb["c_theta_traj_rel"] = rel_diff(traj_b.theta, Th_cb)
        _, th_cbk, _, _ = c_run_batched(libs[BATCH_N_PARAMS], parts, 2)
        cb["c_chunked_final_rel"] = rel_diff(th_bk, th_cbk)
    checks["batched"] = cb
    # sliding window vs lstsq on the window (with the prior rows: the same cost)
    Nw = min(Phi4.shape[0], WINDOW + 500)
    _, trajw = window_run(Phi4[:Nw], y4[:Nw])
    steps = Nw - WINDOW + 1
    _, th_ls = lstsq_window(Phi4[:Nw], y4[:Nw], steps, prior=True)
    _, th_ls0 = lstsq_window(Phi4[:Nw], y4[:Nw], steps, prior=False)
    checks["window"] = {
        "N": Nw,
        "vs_lstsq_with_prior_rel": rel_diff(trajw.theta[WINDOW - 1:], th_ls),
        "vs_plain_lstsq_rel": rel_diff(trajw.theta[WINDOW - 1:], th_ls0),
    }
    return checks


# --------------------------------------------------------------------------
# main
# --------------------------------------------------------------------------
def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true",
                    help="small sizes and 2 rounds (smoke test; timings meaningless)")
    ap.add_argument("--json", metavar="PATH", help="write the raw results to PATH")
    ap.add_argument("--rounds", type=int, default=None, help="rounds (default 7; 2 with --quick)")
    ap.add_argument("--target-time", type=float, default=None,
                    help="minimum seconds per timing (default 0.2; 0.005 with --quick)")
    ap.add_argument("--batch", type=int, default=None, help="streams B (default 10000; 64 with --quick)")
    ap.add_argument("--chunk-mib", type=float, default=CHUNK_MIB,
                    help="output per call of the chunked compiled timings (default 16 MiB)")
    ap.add_argument("--seed", type=int, default=20240521)
    ap.add_argument("--no-c", action="store_true", help="skip the C contenders")
    ap.add_argument("--forms", action="store_true",
                    help="only the table of RLS forms (U-D, square root, covariance, auto) "
                         "at n = 2..64 against the fastest C loop (bench_rls_forms.py)")
    args, rest = ap.parse_known_args(argv)
    if args.forms:
        sys.path.insert(0, str(HERE))
        import bench_rls_forms
        bench_rls_forms.main(rest + (["--quick"] if args.quick else [])
                             + (["--rounds", str(args.rounds)] if args.rounds else []))
        return 0
    if rest:
        ap.error(f"unrecognized arguments: {' '.join(rest)}")

    quick = args.quick
    rounds = args.rounds or (2 if quick else 7)
    target = args.target_time or (0.005 if quick else 0.2)
    margin = 1.2 if quick else 1.6     # aim above the target so every timing clears it
    B = args.batch or (64 if quick else 10_000)
    n_cap = 20_000 if quick else 50_000_000   # max samples of a single-stream run
    slow_min = 300 if quick else 1000         # min samples of the Python-loop contenders
    env = environment()
    chunk_bytes = int(args.chunk_mib * 2**20)
    env.update(quick=quick, rounds=rounds, target_time_s=target, batch=B, seed=args.seed,
               forgetting=LAM, P0=P0, window=WINDOW, chunk_mib=args.chunk_mib,
               blas_threads=os.environ.get("OPENBLAS_NUM_THREADS"))

    import adaptid  # noqa: F401  (import cost outside every timing)
    import padasip  # noqa: F401
    from statsmodels.regression.recursive_ls import RecursiveLS  # noqa: F401

    have_c = not args.no_c and shutil.which("gcc") is not None
    libs = {n: (build_c(n) if have_c else None) for n in NS}
    libs_sym = {n: (build_c(n, symmetric=True) if have_c else None) for n in NS}
    lib_any = build_c(None) if have_c else None
    env["c_available"] = have_c
    if not have_c:
        print("NOTE: gcc not found (or --no-c): the C contenders are skipped", file=sys.stderr)

    print(f"# adaptid RLS benchmark  ({env['date']})")
    print(f"# {env['cpu']}, nproc={env['nproc']}, numba {env['versions']['numba']} "
          f"({env['numba_threads']} threads), numpy {env['versions']['numpy']}, {env['gcc']}")
    print(f"# rounds={rounds}, target >= {target} s per timing, lambda={LAM}, P0={P0}"
          f"{'  [--quick: timings not meaningful]' if quick else ''}")
    sys.stdout.flush()

    cases = []
    data = {}
    tic = time.perf_counter()
    # ---------------------------------------------------------- single stream
    for n in NS:
        ck = max(1, chunk_bytes // (8 * n))   # samples per call of the chunked timings
        probe = 20_000 if quick else 200_000
        Phi, y = make_data(n, probe, args.seed)
        fast = [pilot_rate(lambda: adaptid_run(Phi, y, chunk=ck)[0], probe)]
        if libs[n] is not None:
            fast.append(pilot_rate(lambda: c_run(libs[n], Phi, y, store=False, chunk=ck)[0], probe))
        N = sized(max(fast), target, probe, n_cap, margin)
        Phi, y = make_data(n, N, args.seed)
        data[n] = (Phi, y)

        def add(cid, label, fn, count=N):
            cases.append(Case(f"{cid}_n{n}", f"n={n}", label, count, fn))

        add("rls", "adaptid RLS.run", lambda P=Phi, Y=y, c=ck: adaptid_run(P, Y, chunk=c)[0])
        add("rls_nostore", "adaptid RLS.run(store=False)",
            lambda P=Phi, Y=y, c=ck: adaptid_run(P, Y, store=False, chunk=c)[0])
        if libs[n] is not None:
            add("c", "C -O3, n fixed, store theta",
                lambda P=Phi, Y=y, L=libs[n], c=ck: c_run(L, P, Y, chunk=c)[0])
            add("c_nostore", "C -O3, n fixed, no store",
                lambda P=Phi, Y=y, L=libs[n], c=ck: c_run(L, P, Y, store=False, chunk=c)[0])
            add("c_any", "C -O3, n at run time, store theta",
                lambda P=Phi, Y=y, c=ck: c_run(lib_any, P, Y, chunk=c)[0])
            add("c_sym", "C -O3, n fixed, symmetric update, store",
                lambda P=Phi, Y=y, L=libs_sym[n], c=ck: c_run(L, P, Y, chunk=c)[0])
        add("rls_1call", "adaptid RLS.run, 1 call", lambda P=Phi, Y=y: adaptid_run(P, Y)[0])
        if libs[n] is not None:
            add("c_1call", "C -O3, n fixed, store theta, 1 call",
                lambda P=Phi, Y=y, L=libs[n]: c_run(L, P, Y)[0])
        small = slow_min
        r = pilot_rate(lambda: numpy_loop(Phi[:small], y[:small])[0], small, 1)
        Nn = sized(r, target, slow_min, N, margin)
        add("numpy", "NumPy per-sample loop", lambda P=Phi[:Nn], Y=y[:Nn]: numpy_loop(P, Y)[0], Nn)
        r = pilot_rate(lambda: padasip_run(Phi[:small], y[:small])[0], small, 1)
        Npa = sized(r, target, slow_min, N, margin)
        add("padasip", "padasip FilterRLS.run", lambda P=Phi[:Npa], Y=y[:Npa]: padasip_run(P, Y)[0], Npa)
        r = pilot_rate(lambda: statsmodels_run(Phi[:small], y[:small])[0], small, 1)
        Nsm = sized(r, target, slow_min, N, margin)
        add("statsmodels", "statsmodels RecursiveLS.fit (lambda=1)",
            lambda P=Phi[:Nsm], Y=y[:Nsm]: statsmodels_run(P, Y)[0], Nsm)
        print(f"# sized n={n}: N={N} (compiled; {ck} samples per chunked call), "
              f"numpy {Nn}, padasip {Npa}, statsmodels {Nsm}")
        sys.stdout.flush()

    # ---------------------------------------------------------- update per call
    Phi4, y4 = data[4]
    small = 2000 if quick else 20_000
    rows_s, ys_s = list(Phi4[:small]), y4[:small].tolist()
    r = pilot_rate(lambda: adaptid_update(rows_s, ys_s, 4)[0], small, 1)
    Nu = sized(r, target, small, Phi4.shape[0], margin)
    rows, ys = list(Phi4[:Nu]), y4[:Nu].tolist()
    ys_np = list(y4[:Nu])  # numpy.float64 scalars: the non-fast path of y
    cases.append(Case("update_n4", "update", "adaptid RLS.update per call (y: float)", Nu,
                      lambda: adaptid_update(rows, ys, 4)[0], unit="calls"))
    cases.append(Case("update_np_n4", "update", "adaptid RLS.update per call (y: numpy.float64)", Nu,
                      lambda: adaptid_update(rows, ys_np, 4)[0], unit="calls"))

    # ---------------------------------------------------------- batched
    n = BATCH_N_PARAMS
    ckb = max(1, chunk_bytes // (8 * n * B))  # time steps per chunked call
    Nb0 = 20 if quick else 50
    Pb, yb = make_data(n, Nb0, args.seed, B=B)
    fast = [pilot_rate(lambda: adaptid_batched([(Pb, yb)])[0], B * Nb0)]
    nthreads = env["numba_threads"]
    if libs[n] is not None:
        fast.append(pilot_rate(lambda: c_run_batched(libs[n], [(Pb, yb)], nthreads, store=False)[0],
                               B * Nb0))
    del Pb, yb
    Nb = max(Nb0, int(np.ceil(max(fast) * target * margin / B)))
    Phi_b, y_b = make_data(n, Nb, args.seed, B=B)
    parts_b = [(np.ascontiguousarray(Phi_b[:, a:b]), np.ascontiguousarray(y_b[:, a:b]))
               for a, b in _chunks(Nb, ckb)]
    whole_b = [(Phi_b, y_b)]
    cases.append(Case("batched", "batched", f"adaptid RLS.run_batched (B={B}, n={n})", B * Nb,
                      lambda: adaptid_batched(parts_b)[0]))
    cases.append(Case("batched_1call", "batched", "adaptid RLS.run_batched, 1 call", B * Nb,
                      lambda: adaptid_batched(whole_b)[0]))
    if libs[n] is not None:
        cases.append(Case("batched_c_serial", "batched", "C loop over streams, 1 thread", B * Nb,
                          lambda: c_run_batched(libs[n], parts_b, 1)[0]))
        cases.append(Case("batched_c_omp", "batched", f"C loop over streams, OpenMP {nthreads} threads",
                          B * Nb, lambda: c_run_batched(libs[n], parts_b, nthreads)[0]))
        cases.append(Case("batched_c_omp_1call", "batched",
                          f"C loop over streams, OpenMP {nthreads} threads, 1 call",
                          B * Nb, lambda: c_run_batched(libs[n], whole_b, nthreads)[0]))
    print(f"# sized batched: B={B}, N={Nb} per stream ({ckb} time steps per chunked call)")

    # ---------------------------------------------------------- sliding window
    ckw = max(1, chunk_bytes // (8 * 4))
    small = 20_000 if quick else 200_000
    small = min(small, Phi4.shape[0])
    r = pilot_rate(lambda: window_run(Phi4[:small], y4[:small], chunk=ckw)[0], small)
    Nw = sized(r, target, small, Phi4.shape[0], margin)
    cases.append(Case("window", "window", f"adaptid SlidingWindowRLS(4, {WINDOW}).run", Nw,
                      lambda: window_run(Phi4[:Nw], y4[:Nw], chunk=ckw)[0]))
    s0 = 100 if quick else 500
    r = pilot_rate(lambda: lstsq_window(Phi4, y4, s0)[0], s0, 1)
    S = sized(r, target, s0, Phi4.shape[0] - WINDOW + 1, margin)
    cases.append(Case("window_lstsq", "window",
                      f"numpy.linalg.lstsq re-solve per step ({S} steps timed)", S,
                      lambda: lstsq_window(Phi4, y4, S)[0], unit="steps"))
    print(f"# sized window: N={Nw}; lstsq timed on {S} steps, rate extrapolated per step")
    print(f"# sizing took {time.perf_counter() - tic:.1f} s")
    sys.stdout.flush()

    # ---------------------------------------------------------- checks
    checks = run_checks(data, libs, libs_sym, lib_any, 2000 if quick else 5000, Phi_b, y_b,
                        Phi4, y4, max(1, Nb // 3))

    # ---------------------------------------------------------- rounds
    rng = np.random.default_rng(args.seed)
    for rd in range(rounds):
        t_r = time.perf_counter()
        for i in rng.permutation(len(cases)):
            cases[i].time_once()
        print(f"# round {rd + 1}/{rounds}: {time.perf_counter() - t_r:.1f} s")
        sys.stdout.flush()
    env["loadavg_end"] = os.getloadavg() if hasattr(os, "getloadavg") else None

    by = {c.id: c for c in cases}

    def ratio(num, den):
        if num not in by or den not in by:
            return None
        return [x_ / y_ for x_, y_ in zip(by[num].rates(), by[den].rates())]

    ratios = {}

    def put(name, num, den, note=""):
        if isinstance(den, tuple):  # the fastest of several contenders, round by round
            if num not in by or any(d not in by for d in den):
                return
            best = np.max([by[d].rates() for d in den], axis=0)
            per = [float(x / b) for x, b in zip(by[num].rates(), best)]
        else:
            per = ratio(num, den)
        if per is None:
            return
        ratios[name] = {"num": num, "den": den, "per_round": per, "median": float(np.median(per)),
                        "min": float(min(per)), "max": float(max(per)), "note": note}

    for n in NS:
        put(f"rls_vs_c_n{n}", f"rls_n{n}", f"c_n{n}")
        put(f"rls_vs_c_any_n{n}", f"rls_n{n}", f"c_any_n{n}")
        put(f"rls_vs_cbest_n{n}", f"rls_n{n}", (f"c_n{n}", f"c_any_n{n}"),
            "C textbook: the faster of n fixed / n at run time, per round")
        put(f"c_vs_padasip_n{n}", f"c_n{n}", f"padasip_n{n}", "C textbook (n fixed) over padasip")
        put(f"rls_vs_c_sym_n{n}", f"rls_n{n}", f"c_sym_n{n}")
        put(f"rls_1call_vs_c_1call_n{n}", f"rls_1call_n{n}", f"c_1call_n{n}",
            "one call on all N samples: fresh output pages")
        put(f"nostore_vs_c_nostore_n{n}", f"rls_nostore_n{n}", f"c_nostore_n{n}")
        put(f"rls_vs_numpy_n{n}", f"rls_n{n}", f"numpy_n{n}")
        put(f"rls_vs_padasip_n{n}", f"rls_n{n}", f"padasip_n{n}")
        put(f"rls_vs_statsmodels_n{n}", f"rls_n{n}", f"statsmodels_n{n}",
            "statsmodels is lambda=1 only (and also smooths)")
    put("batched_vs_c_serial", "batched", "batched_c_serial")
    put("batched_vs_c_omp", "batched", "batched_c_omp")
    put("batched_1call_vs_c_omp_1call", "batched_1call", "batched_c_omp_1call",
        "one call on all N steps: fresh output pages")
    put("window_vs_lstsq", "window", "window_lstsq", "lstsq timed on a subset of steps")
    # update: µs per call, and padasip's per-sample cost over update's per call
    upd = by["update_n4"]
    us = [1e6 * t / upd.count for t in upd.times]
    ratios["update_us_n4"] = {"per_round": us, "median": float(np.median(us)),
                              "min": float(min(us)), "max": float(max(us)), "note": "µs per call"}
    us_np = [1e6 * t / by["update_np_n4"].count for t in by["update_np_n4"].times]
    ratios["update_np_us_n4"] = {"per_round": us_np, "median": float(np.median(us_np)),
                                 "min": float(min(us_np)), "max": float(max(us_np)),
                                 "note": "µs per call, y given as numpy.float64"}
    pad_us = [1e6 * t / by["padasip_n4"].count for t in by["padasip_n4"].times]
    per = [p / u for p, u in zip(pad_us, us)]
    ratios["padasip_run_us_over_update_us_n4"] = {
        "per_round": per, "median": float(np.median(per)), "min": float(min(per)),
        "max": float(max(per)), "note": "padasip whole-array run, µs per sample / update µs per call"}

    targets = {}
    for name, (op, thr) in TARGETS.items():
        if name not in ratios:
            targets[name] = {"target": f"{op} {thr}", "median": None, "met": None}
            continue
        m = ratios[name]["median"]
        met = m >= thr if op == ">=" else m < thr
        targets[name] = {"target": f"{op} {thr}", "median": m, "met": bool(met)}

    results = {"meta": env, "cases": {c.id: c.summary() for c in cases}, "ratios": ratios,
               "targets": targets, "checks": checks}
    print_report(results)
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1, default=float))
        print(f"# raw results written to {args.json}")
    return 0


def _fmt_rate(r):
    for div, suf in ((1e9, "G"), (1e6, "M"), (1e3, "k")):
        if r >= div:
            return f"{r / div:7.3g} {suf}"
    return f"{r:7.3g}  "


def print_report(res):
    cases, ratios, targets = res["cases"], res["ratios"], res["targets"]

    def target_cell(name):
        t = targets.get(name)
        if not t:
            return ""
        if t["met"] is None:
            return f"target {t['target']}: n/a"
        return f"target {t['target']}: {'MET' if t['met'] else 'NOT MET'}"

    print()
    print("## Results (median over rounds; ratio = adaptid / contender, median of same-round ratios"
          " [min-max])")
    hdr = f"{'contender':44s} {'N':>10s} {'median s':>9s} {'rate /s':>10s} {'ratio':>24s}  target"
    groups = []
    for c in cases.values():
        if c["group"] not in groups:
            groups.append(c["group"])
    ratio_of = {
        "c": "rls_vs_c", "c_any": "rls_vs_c_any", "c_nostore": "nostore_vs_c_nostore",
        "c_sym": "rls_vs_c_sym", "c_1call": "rls_1call_vs_c_1call",
        "numpy": "rls_vs_numpy", "padasip": "rls_vs_padasip", "statsmodels": "rls_vs_statsmodels",
    }
    for g in groups:
        print(f"\n### {g}")
        print(hdr)
        for cid, c in cases.items():
            if c["group"] != g:
                continue
            rname = None
            if g.startswith("n="):
                base = cid.rsplit("_n", 1)[0]
                if base in ratio_of:
                    rname = f"{ratio_of[base]}_{cid.rsplit('_', 1)[1]}"
            elif cid == "batched_c_serial":
                rname = "batched_vs_c_serial"
            elif cid == "batched_c_omp":
                rname = "batched_vs_c_omp"
            elif cid == "batched_c_omp_1call":
                rname = "batched_1call_vs_c_omp_1call"
            elif cid == "window_lstsq":
                rname = "window_vs_lstsq"
            rcell = ""
            if rname and rname in ratios:
                r = ratios[rname]
                rcell = f"{r['median']:8.3g} [{r['min']:.3g}-{r['max']:.3g}]"
            unit = "" if c["unit"] == "updates" else f" {c['unit']}"
            print(f"{c['label'] + unit:44s} {c['count']:10d} {c['median_time_s']:9.3f} "
                  f"{_fmt_rate(c['median_rate_per_s']):>10s} {rcell:>24s}  {target_cell(rname or '')}")
        if g.startswith("n=") and f"rls_vs_cbest_{g.replace('=', '')}" in ratios:
            nm = f"rls_vs_cbest_{g.replace('=', '')}"
            r = ratios[nm]
            print(f"  {'adaptid / best C textbook (per round)':42s} {r['median']:8.3g} "
                  f"[{r['min']:.3g}-{r['max']:.3g}]  {target_cell(nm)}")
            nm = f"c_vs_padasip_{g.replace('=', '')}"
            if nm in ratios:
                r = ratios[nm]
                print(f"  {'(C textbook n fixed / padasip)':42s} {r['median']:8.3g} "
                      f"[{r['min']:.3g}-{r['max']:.3g}]")
        if g == "update":
            for nm in ("update_us_n4", "update_np_us_n4", "padasip_run_us_over_update_us_n4"):
                r = ratios[nm]
                print(f"  {nm:40s} {r['median']:8.3g} [{r['min']:.3g}-{r['max']:.3g}]  "
                      f"{r['note']}  {target_cell(nm)}")

    print("\n## Targets of the issue")
    for name, t in targets.items():
        status = "n/a" if t["met"] is None else ("MET" if t["met"] else "NOT MET")
        med = "-" if t["median"] is None else f"{t['median']:.3g}"
        print(f"  {name:26s} {t['target']:>8s}   median {med:>8s}   {status}")
    print("\n## Checks (relative max differences; correctness of the comparison, not speed)")
    for k, v in res["checks"].items():
        if isinstance(v, dict):
            print(f"  {k}: " + ", ".join(f"{a}={b:.3g}" if isinstance(b, float) else f"{a}={b}"
                                         for a, b in v.items()))
        else:
            print(f"  {k}: {v}")
    short = [c for c in cases.values() if c["min_time_s"] < res["meta"]["target_time_s"]]
    if short and not res["meta"]["quick"]:
        print("\nWARNING: timings below the target time: " + ", ".join(c["label"] for c in short))


if __name__ == "__main__":
    sys.exit(main())
