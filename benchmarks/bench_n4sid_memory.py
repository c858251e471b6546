#!/usr/bin/env python
r"""Peak memory of ``adaptid.models.n4sid`` on a long record, in memory and on Dask.

The block-Hankel data matrix of a record of N samples with m inputs, p
outputs and ``horizon`` = i block rows has 2i(m + p) rows and N − 2i + 1
columns: 640 MB for N = 10⁶, m = p = 2, i = 10. n4sid must never hold it
whole (issue 34, point 5): its LQ factor comes from a QR of chunks of rows
(in memory) or from Dask's tall-skinny QR over chunks of the record (Dask),
and B, D, x0 and K from an ordered pass over chunks.

It also measures ``model.estimate_cov`` (the parameter covariance behind the
bands of ``freqresp``, ``step_response`` and ``poles``) on the same record:
the whitened Jacobian of the one-step prediction errors, N × p × (d + n)
(768 MB here), is reduced to its R factor chunk by chunk (``max_memory=``,
32 MiB of Jacobian rows by default), in memory and on Dask alike.

This script identifies the system of ``bench_n4sid.py`` (2 inputs, 2
outputs, order 4, innovation sd 0.1) from N samples and reports, for the
in-memory call and the Dask call (``--dask``, the record as Dask arrays in
chunks of ``--chunk`` rows), the peak of the memory that Python and NumPy
allocate during the call (``tracemalloc``: the record itself, made before,
is not counted), its ratio to the size of the data matrix, the time, and
the largest distance between the two estimates' eigenvalues.

Usage::

    python benchmarks/bench_n4sid_memory.py                   # N = 10⁶, in memory
    python benchmarks/bench_n4sid_memory.py --dask            # and on Dask
    python benchmarks/bench_n4sid_memory.py --n 100000 --json out.json
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
import tracemalloc

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402 - after the thread setting


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_n4sid import make_data, pole_error  # noqa: E402


def measure(fn):
    """(result, seconds, peak MB of traced allocations) of one call."""
    tracemalloc.start()
    tracemalloc.reset_peak()
    t0 = time.perf_counter()
    out = fn()
    dt = time.perf_counter() - t0
    peak = tracemalloc.get_traced_memory()[1] / 1e6
    tracemalloc.stop()
    return out, dt, peak


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=1_000_000, help="number of samples N (default 10⁶)")
    ap.add_argument("--horizon", type=int, default=10, help="block rows i (default 10)")
    ap.add_argument("--dask", action="store_true", help="also run n4sid on Dask arrays")
    ap.add_argument("--chunk", type=int, default=100_000, help="Dask chunk rows (default 10⁵)")
    ap.add_argument("--json", help="write the results to this file")
    args = ap.parse_args(argv)

    import adaptid
    from adaptid.models import n4sid

    y, u, poles = make_data(args.n, 0.1)
    i, N = args.horizon, args.n
    matrix_mb = 2 * i * (y.shape[1] + u.shape[1]) * (N - 2 * i + 1) * 8 / 1e6
    record_mb = (y.nbytes + u.nbytes) / 1e6
    n4sid((y[:2000], u[:2000]), 4, horizon=i)            # warm-up (imports, caches)
    model, t_mem, peak_mem = measure(lambda: n4sid((y, u), 4, horizon=i))
    res = {"N": N, "horizon": i, "data_matrix_MB": matrix_mb, "record_MB": record_mb,
           "memory_s": t_mem, "memory_peak_MB": peak_mem,
           "memory_error": pole_error(np.linalg.eigvals(model.A), poles)}
    n, m, p = model.order, model.n_inputs, model.n_outputs
    jac_mb = N * p * (n * n + n * m + p * n + p * m + n * p + n) * 8 / 1e6
    cov, t_cov, peak_cov = measure(lambda: model.estimate_cov((y, u)))
    res.update(jacobian_MB=jac_mb, cov_s=t_cov, cov_peak_MB=peak_cov)
    print(f"n4sid memory: N = {N}, 2 inputs, 2 outputs, order 4, horizon {i}")
    print(f"  data matrix 2i(m+p) x (N-2i+1): {matrix_mb:.0f} MB; the record (y, u): "
          f"{record_mb:.0f} MB (made before, not counted)")
    print(f"  in memory: {t_mem:.2f} s, peak {peak_mem:.0f} MB = "
          f"{peak_mem / matrix_mb:.3f} x the data matrix; eigenvalue error "
          f"{res['memory_error']:.2e}")
    print(f"  estimate_cov in memory: {t_cov:.2f} s, peak {peak_cov:.0f} MB = "
          f"{peak_cov / jac_mb:.3f} x the whole Jacobian N x p x (d+n) ({jac_mb:.0f} MB)")
    if args.dask:
        import dask.array as da

        yd = da.from_array(y, chunks=(args.chunk, y.shape[1]))
        ud = da.from_array(u, chunks=(args.chunk, u.shape[1]))
        dmodel, t_dask, peak_dask = measure(lambda: n4sid((yd, ud), 4, horizon=i))
        dcov, t_dcov, peak_dcov = measure(lambda: dmodel.cov)    # from its Dask record
        same = pole_error(np.linalg.eigvals(dmodel.A), np.linalg.eigvals(model.A))
        res.update(dask_s=t_dask, dask_peak_MB=peak_dask, dask_chunk=args.chunk,
                   dask_vs_memory=same, dask_cov_s=t_dcov, dask_cov_peak_MB=peak_dcov,
                   dask_cov_vs_memory=float(np.abs(dcov - cov).max() / np.abs(cov).max()))
        print(f"  on Dask (chunks of {args.chunk} rows, threaded scheduler): {t_dask:.2f} s, "
              f"peak {peak_dask:.0f} MB = {peak_dask / matrix_mb:.3f} x the data matrix; "
              f"eigenvalues equal to the in-memory ones to {same:.1e}")
        print(f"  estimate_cov on Dask: {t_dcov:.2f} s, peak {peak_dcov:.0f} MB; equal to the "
              f"in-memory one to {res['dask_cov_vs_memory']:.1e} (relative to its largest entry)")
    if args.json:
        res.update(adaptid=adaptid.__version__, machine=platform.platform(),
                   date=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()))
        with open(args.json, "w") as fh:
            json.dump(res, fh, indent=1)


if __name__ == "__main__":
    main()
