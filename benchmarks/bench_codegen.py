#!/usr/bin/env python
r"""Updates per second of the generated C (adaptid.codegen.to_c) on the host.

Contenders, on the same data (λ = 0.99, P0 = 1e4·I, θ0 = 0, φ ~ N(0, I),
y = φᵀθ* + 0.1·noise), none of them storing the per-sample θ:

* ``gen -O2``: the C that ``to_c(RLS(n, forgetting=0.99))`` writes, built as
  the tests build it (``gcc -std=c99 -O2``, no FMA), called once per sample
  from a C loop (``NAME_update`` across a translation-unit boundary, as
  firmware calls it);
* ``gen -O3 FMA``: the same with ``-O3 -march=native -DNAME_USE_FMA`` (bit for
  bit adaptid's trajectory);
* adaptid ``RLS(n, forgetting=0.99).run(Phi, y, store=False)`` (numba);
* the C reference loops of ``/work/shared/bench/rls_ref.c`` (covariance
  form, P kept symmetric; ``rls_run_nN``, ``rls_tri_nN``, ``rls_fu_nN``)
  built like ``benchmarks/bench_rls.py`` builds its reference
  (``gcc -O3 -march=native``), the fastest variant in each round.

The contenders run interleaved in shuffled order for several rounds; the
report gives median updates/s and the median of same-round ratios. Speed is
never asserted anywhere (rule 7).

Usage::

    python benchmarks/bench_codegen.py            # n = 2, 4, 8, 16
    python benchmarks/bench_codegen.py --quick
"""

from __future__ import annotations

import argparse
import ctypes
import os
import random
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
#: The shared reference loops (rls_run_nN / rls_tri_nN / rls_fu_nN); if absent,
#: the repository's benchmarks/c/rls_ref.c (bench_rls.py's, rls_run with n fixed).
REF_SOURCE = Path(os.environ.get("ADAPTID_RLS_REF", "/work/shared/bench/rls_ref.c"))
if not REF_SOURCE.exists():
    REF_SOURCE = HERE / "c" / "rls_ref.c"
LAM, P0, NOISE = 0.99, 1e4, 0.1

WRAPPER = r"""
#include "gen.h"
/* N samples through gen_update, one call each; the final theta is returned. */
void gen_run(long n_rows, const double *Phi, const double *y, double *theta)
{
    static gen_t s;
    long k;
    gen_init(&s);
    for (k = 0; k < n_rows; k++) {
        gen_update(&s, Phi + k * GEN_N, y[k]);
    }
    gen_theta(&s, theta);
}
"""


def _gcc():
    gcc = shutil.which("gcc")
    if gcc is None:
        sys.exit("bench_codegen: gcc not found")
    return gcc


def build_generated(n, folder, flags):
    import adaptid
    from adaptid.codegen import to_c
    est = adaptid.RLS(n, forgetting=LAM, P0=P0)
    to_c(est, folder, name="gen")
    (folder / "wrap.c").write_text(WRAPPER)
    lib = folder / f"gen_{n}_{abs(hash(tuple(flags)))}.so"
    subprocess.run([_gcc(), "-std=c99", *flags, "-fPIC", "-shared", "-I", str(folder),
                    str(folder / "wrap.c"), str(folder / "gen.c"), "-o", str(lib), "-lm"],
                   check=True)
    dll = ctypes.CDLL(str(lib))
    dll.gen_run.argtypes = [ctypes.c_long, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]
    dll.gen_run.restype = None
    return dll


def build_reference(folder, n):
    """The reference loops for n as a list of f(N, Phi, y, theta, P) (built like bench_rls.py)."""
    lib = folder / f"rls_ref_{n}.so"
    subprocess.run([_gcc(), "-O3", "-march=native", "-std=gnu11", "-fPIC", "-shared",
                    f"-DRLS_N={n}", str(REF_SOURCE), "-o", str(lib), "-lm"], check=True)
    dll = ctypes.CDLL(str(lib))
    p = ctypes.c_void_p
    if hasattr(dll, f"rls_fu_n{n}"):  # the shared file: three variants per n
        out = []
        for v in ("rls_run", "rls_tri", "rls_fu"):
            f = getattr(dll, f"{v}_n{n}")
            f.argtypes = [ctypes.c_long, ctypes.c_int, p, p, ctypes.c_double, p, p]
            f.restype = None
            out.append(lambda N, Phi, y, th, P, f=f: f(N, 1, Phi, y, LAM, th, P))
        return out
    f = dll.rls_run
    f.argtypes = [ctypes.c_int, ctypes.c_long, p, p, ctypes.c_double, p, p, p, p]
    f.restype = ctypes.c_int
    return [lambda N, Phi, y, th, P: f(n, N, Phi, y, LAM, th, P, None, None)]


def make_data(n, N, seed=0):
    rng = np.random.default_rng([seed, n])
    Phi = rng.standard_normal((N, n))
    y = Phi @ rng.standard_normal(n) + NOISE * rng.standard_normal(N)
    return Phi, y


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--ns", type=int, nargs="*", default=[2, 4, 8, 16])
    ap.add_argument("--rounds", type=int, default=None)
    args = ap.parse_args(argv)
    rounds = args.rounds or (2 if args.quick else 7)
    N = 50_000 if args.quick else 400_000
    import adaptid

    tmp = Path(tempfile.mkdtemp(prefix="adaptid-bench-codegen-"))
    print(f"# generated C vs adaptid run vs C reference ({REF_SOURCE.name}); N = {N}, "
          f"{rounds} rounds; median updates/s (M/s) and median same-round speed ratios "
          "(a/b > 1: a faster)")
    print(f"# {subprocess.run([_gcc(), '--version'], capture_output=True, text=True).stdout.splitlines()[0]}; "
          f"numpy {np.__version__}; adaptid {adaptid.__version__}")
    header = ("| n | gen -O2 | gen -O3 FMA | adaptid run | C ref (best) | gen-O2/run | "
              "genFMA/run | gen-O2/ref | genFMA/ref |")
    print(header)
    print("|---" * 9 + "|")
    for n in args.ns:
        Phi, y = make_data(n, N)
        g2 = build_generated(n, tmp / f"o2_{n}", ["-O2"])
        g3 = build_generated(n, tmp / f"o3_{n}", ["-O3", "-march=native", "-DGEN_USE_FMA"])
        variants = build_reference(tmp, n)
        th = np.zeros(n)

        def t_gen(dll):
            t0 = time.perf_counter()
            dll.gen_run(N, Phi.ctypes.data, y.ctypes.data, th.ctypes.data)
            return time.perf_counter() - t0

        def t_run():
            est = adaptid.RLS(n, forgetting=LAM, P0=P0)
            t0 = time.perf_counter()
            est.run(Phi, y, store=False)
            return time.perf_counter() - t0

        def t_ref():
            best = np.inf
            for f in variants:
                theta = np.zeros(n)
                P = np.eye(n) * P0
                t0 = time.perf_counter()
                f(N, Phi.ctypes.data, y.ctypes.data, theta.ctypes.data, P.ctypes.data)
                best = min(best, time.perf_counter() - t0)
            return best

        # check before timing: the FMA build is adaptid's final theta bit for bit
        g3.gen_run(N, Phi.ctypes.data, y.ctypes.data, th.ctypes.data)
        est = adaptid.RLS(n, forgetting=LAM, P0=P0)
        est.run(Phi, y, store=False)
        assert np.array_equal(th, est.theta), "generated C (FMA) differs from adaptid"
        theta, P = np.zeros(n), np.eye(n) * P0
        variants[-1](N, Phi.ctypes.data, y.ctypes.data, theta.ctypes.data, P.ctypes.data)
        assert np.allclose(theta, est.theta, rtol=1e-6, atol=1e-9), "C reference differs"
        contenders = {"g2": lambda: t_gen(g2), "g3": lambda: t_gen(g3), "run": t_run, "ref": t_ref}
        for fn in contenders.values():  # warm-up (numba compile, page faults)
            fn()
        times = {k: [] for k in contenders}
        for _ in range(rounds):
            order = list(contenders)
            random.shuffle(order)
            for k in order:
                times[k].append(contenders[k]())
        T = {k: np.array(v) for k, v in times.items()}
        rate = {k: N / np.median(v) / 1e6 for k, v in T.items()}
        ratio = lambda a, b: float(np.median(T[b] / T[a]))  # noqa: E731 - same-round speed ratio
        print(f"| {n} | {rate['g2']:.1f} | {rate['g3']:.1f} | {rate['run']:.1f} | {rate['ref']:.1f} | "
              f"{ratio('g2', 'run'):.2f} | {ratio('g3', 'run'):.2f} | {ratio('g2', 'ref'):.2f} | "
              f"{ratio('g3', 'ref'):.2f} |")
    shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
