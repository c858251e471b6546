"""Prototype: run_batched (n = 4, B = 10⁴, N = 2600, store=False) at the vector width LLVM picks.

    NUMBA_NUM_THREADS=1 ADAPTID_AOT=0 NUMBA_CACHE_DIR=<empty> python benchmarks/proto_soa_width.py default
    NUMBA_NUM_THREADS=1 ADAPTID_AOT=0 NUMBA_CACHE_DIR=<empty 2> NUMBA_CPU_NAME=emeraldrapids \
        NUMBA_CPU_FEATURES="<host features>,-prefer-256-bit" python benchmarks/proto_soa_width.py zmm

On Intel server CPUs LLVM's tuning prefers 256-bit vectors: the lane loops of the
structure-of-arrays kernels (``adaptid._kernels.lanes._soa``) are vectorised mostly in ymm
(``rls_soa_batched``: 131 zmm and 285 ymm instructions, 12 ``vdivpd ymm`` and 8
``vdivpd zmm``). Turning that tuning off (the second command; ``<host features>`` is
``llvmlite.binding.get_host_cpu_features().flatten()``) makes them zmm (635 zmm, 100
``vdivpd zmm``). Prints M updates/s for the U-D and covariance forms and a checksum of
θ (the same bits either way).

Result (2026-11-28, 2-vCPU Xeon, two interleaved rounds): U-D 35.8 / 41.6 → 43.5 /
45.8, covariance 34.2 / 41.4 → 46.1 / 46.9 M/s: +10–35 %, far from the 2× that
issue 19's point 3 would need; and it is a process-wide numba setting. Not adopted.
"""
import time, sys, numpy as np, adaptid
B, N, n = 10_000, 2600, 4
rng = np.random.default_rng(0)
Phi = rng.standard_normal((B, N, n)); y = (Phi @ rng.standard_normal(n)) + 0.1 * rng.standard_normal((B, N))
res = []
for form in ("ud", "covariance"):
    est = adaptid.RLS(n, forgetting=0.99, form=form, P0=1e3)
    est.run_batched(Phi[:32, :50], y[:32, :50], store=False)
    best = 9e9
    for r in range(3):
        est = adaptid.RLS(n, forgetting=0.99, form=form, P0=1e3)
        t = time.perf_counter()
        for c in range(10):
            est.run_batched(Phi[:, c*260:(c+1)*260], y[:, c*260:(c+1)*260], store=False)
        best = min(best, time.perf_counter() - t)
    res.append(f"{form}: {B*N/best/1e6:.1f} M/s")
    th = est.theta
print(sys.argv[1], " ".join(res), float(np.abs(th).sum()).hex())
