"""RLS.run in each form (U-D, square root, covariance, auto) against the fastest C loop.

    python benchmarks/bench_rls.py --forms [--quick] [--c-source PATH]
    python benchmarks/bench_rls_forms.py [--quick] [--c-source PATH]

For n = 2, 4, 8, 16, 32, 64: updates/s of ``RLS(n, forgetting=0.99, P0=1e3,
form=F).run(Phi, y, store=False)`` and of every C variant of ``rls_ref.c``
(``rls_run_nN``, ``rls_tri_nN``, ``rls_fu_nN``; gcc -O3 -march=native, built
here into a temporary file named by the source's hash), same data, same run,
best of R rounds each, interleaved. The table gives each form's ratio to the
fastest C variant at that n (> 1: adaptid is faster). Single-threaded (the
C loops are). Default C source: /work/shared/bench/rls_ref.c if present (it has
the fused variant), else benchmarks/c/rls_ref.c.
"""
from __future__ import annotations

import argparse
import ctypes
import hashlib
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")
import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
SHARED = Path("/work/shared/bench/rls_ref.c")
SIZES = (2, 4, 8, 16, 32, 64)
FORMS = ("ud", "sqrt", "covariance", "auto")
VARIANTS = ("rls_run", "rls_tri", "rls_fu")
LAM, P0 = 0.99, 1e3


def build(src: Path):
    h = hashlib.sha256(src.read_bytes()).hexdigest()[:12]
    so = Path(tempfile.gettempdir()) / f"adaptid_rls_ref_{h}_{os.getuid()}.so"
    if not so.exists():
        tmp = str(so) + f".{os.getpid()}.tmp"
        subprocess.run(["gcc", "-O3", "-march=native", "-shared", "-fPIC", str(src), "-o", tmp],
                       check=True)
        os.replace(tmp, so)
    return ctypes.CDLL(str(so))


def best_of(fn, rounds):
    out = []
    for _ in range(rounds):
        t = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t)
    return min(out)


def c_callers(lib, n, Phi, y):
    dp = ctypes.POINTER(ctypes.c_double)
    out = {}
    for v in VARIANTS:
        fn = getattr(lib, f"{v}_n{n}", None)
        if fn is None:
            continue
        fn.argtypes = [ctypes.c_long, ctypes.c_int, dp, dp, ctypes.c_double, dp, dp]

        def call(fn=fn):
            th, P = np.zeros(n), np.eye(n) * P0
            fn(Phi.shape[0], 1, Phi.ctypes.data_as(dp), y.ctypes.data_as(dp), LAM,
               th.ctypes.data_as(dp), P.ctypes.data_as(dp))
        out[v] = call
    return out


def measure(n, N, rounds, lib):
    import adaptid
    rng = np.random.default_rng(n)
    Phi = np.ascontiguousarray(rng.standard_normal((N, n)))
    y = Phi @ rng.standard_normal(n) + 0.1 * rng.standard_normal(N)
    runs = {f: (lambda f=f: adaptid.RLS(n, forgetting=LAM, P0=P0, form=f).run(Phi, y, store=False))
            for f in FORMS}
    for f in FORMS:  # compile (or load from the cache) outside the timing
        adaptid.RLS(n, forgetting=LAM, P0=P0, form=f).run(Phi[:50], y[:50])
    calls = dict(runs)
    calls.update({f"C {v}": c for v, c in c_callers(lib, n, Phi, y).items()})
    times = {k: np.inf for k in calls}
    for _ in range(rounds):  # interleaved: drifts of the machine hit every contender
        for k, fn in calls.items():
            times[k] = min(times[k], best_of(fn, 1))
    return {k: N / t for k, t in times.items()}


def table(results):
    head = f"{'n':>3} {'best C':>10} {'C variant':>10} " + " ".join(f"{f:>11}" for f in FORMS)
    lines = [head, "-" * len(head)]
    for n, rates in results.items():
        cs = {k: r for k, r in rates.items() if k.startswith("C ")}
        best = max(cs, key=cs.get)
        row = f"{n:>3} {cs[best] / 1e6:8.2f} M {best[2:]:>10} "
        row += " ".join(f"{rates[f] / cs[best]:9.2f} x" for f in FORMS)
        lines.append(row)
    lines.append("(C: M updates/s of the fastest variant; forms: updates/s / that of the best C)")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="small N, 2 rounds (smoke test)")
    ap.add_argument("--rounds", type=int, default=None)
    ap.add_argument("--c-source", type=Path, default=None)
    args = ap.parse_args(argv)
    src = args.c_source or (SHARED if SHARED.exists() else HERE / "c" / "rls_ref.c")
    lib = build(src)
    rounds = args.rounds or (2 if args.quick else 7)
    budget = 2e4 if args.quick else 3e7  # ~ n² flops per update: N scaled to equal work
    results = {n: measure(n, max(200, int(budget / (n * n + 8 * n))), rounds, lib)
               for n in SIZES}
    import adaptid
    print(f"adaptid {adaptid.__version__}, C: {src}, forgetting {LAM}, P0 {P0}, "
          f"best of {rounds}")
    print(table(results))
    return results


if __name__ == "__main__":
    sys.exit(0 if main() is not None else 1)
