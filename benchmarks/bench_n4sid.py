#!/usr/bin/env python
r"""Benchmark of ``adaptid.models.n4sid`` against nfoursid on the same record.

Both identify a 2-input, 2-output system of order 4 from N samples with
``horizon`` = 10 block rows of past and future:

* adaptid ``n4sid((y, u), 4, horizon=10, method="moesp")`` — one QR of the
  transposed block-Hankel data matrix (the R factor only), projections from
  its blocks, B, D and x0 by one least-squares problem, K from the Riccati
  equation;
* nfoursid ``NFourSID(df, output_columns, input_columns, num_block_rows=10)
  .subspace_identification()`` then ``.system_identification(rank=4)`` — the
  same PO-MOESP weighting (Verhaegen & Verdult 2007), with explicit Hankel
  matrices, Q and R of a full QR, and B, D from its state sequence.

Data: the innovation model x+ = A x + B u + K e, y = C x + e, with A of
poles 0.9·e^{±0.5i}, 0.6·e^{±1.8i} in a random basis, white unit inputs and
innovations of standard deviation 0.1 (``--noise``). Each estimate's error
is the largest distance between its eigenvalues and the true ones (sorted);
the two must agree to a factor of two (equal accuracy) for the ratio to
count. Timings: adaptid the best of ``--repeat`` runs, after a warm-up
call; nfoursid one run (tens of seconds).

Usage::

    python benchmarks/bench_n4sid.py                 # N = 20 000 (nfoursid: ~30 s)
    python benchmarks/bench_n4sid.py --n 4000        # quicker
    python benchmarks/bench_n4sid.py --json out.json
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # both single-threaded: a fair, steady ratio

import numpy as np  # noqa: E402


def make_system(seed=0):
    rng = np.random.default_rng(seed)
    blocks = [r * np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
              for r, a in ((0.9, 0.5), (0.6, 1.8))]
    Ab = np.zeros((4, 4))
    Ab[:2, :2], Ab[2:, 2:] = blocks
    V = rng.standard_normal((4, 4))
    A = V @ Ab @ np.linalg.inv(V)
    B, C = rng.standard_normal((4, 2)), rng.standard_normal((2, 4))
    K = 0.3 * rng.standard_normal((4, 2))
    return A, B, C, K


def make_data(N, noise, seed=1):
    A, B, C, K = make_system()
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((N, 2))
    e = noise * rng.standard_normal((N, 2))
    x = np.zeros(4)
    y = np.empty((N, 2))
    for k in range(N):
        y[k] = C @ x + e[k]
        x = A @ x + B @ u[k] + K @ e[k]
    return y, u, np.linalg.eigvals(A)


def pole_error(est, true):
    key = lambda z: (round(z.real, 9), z.imag)  # noqa: E731 - conjugate pairs in one order
    return float(np.abs(np.array(sorted(est, key=key)) - np.array(sorted(true, key=key))).max())


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=20000, help="number of samples N (default 20 000)")
    ap.add_argument("--horizon", type=int, default=10, help="block rows (default 10)")
    ap.add_argument("--noise", type=float, default=0.1, help="innovation sd (default 0.1)")
    ap.add_argument("--repeat", type=int, default=5, help="adaptid repetitions (best of)")
    ap.add_argument("--json", help="write the results to this file")
    args = ap.parse_args(argv)

    import pandas as pd
    from nfoursid.nfoursid import NFourSID

    import adaptid
    from adaptid.models import n4sid

    y, u, poles = make_data(args.n, args.noise)
    n4sid((y[:500], u[:500]), 4, horizon=args.horizon)   # warm-up (imports, caches)
    t_ad = np.inf
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        model = n4sid((y, u), 4, horizon=args.horizon)
        t_ad = min(t_ad, time.perf_counter() - t0)
    err_ad = pole_error(model.poles(), poles)

    df = pd.DataFrame(np.hstack([y, u]), columns=["y1", "y2", "u1", "u2"])
    t0 = time.perf_counter()
    nf = NFourSID(df, output_columns=["y1", "y2"], input_columns=["u1", "u2"],
                  num_block_rows=args.horizon)
    nf.subspace_identification()
    ss, _ = nf.system_identification(rank=4)
    t_nf = time.perf_counter() - t0
    err_nf = pole_error(np.linalg.eigvals(ss.a), poles)

    equal = max(err_ad, err_nf) <= 2 * min(err_ad, err_nf) + 1e-12
    print(f"n4sid: N = {args.n}, 2 inputs, 2 outputs, order 4, horizon {args.horizon}, "
          f"innovation sd {args.noise:g}")
    print(f"  adaptid n4sid (moesp, best of {args.repeat}): {t_ad:.4f} s, "
          f"eigenvalue error {err_ad:.2e}")
    print(f"  nfoursid subspace + system identification: {t_nf:.3f} s, "
          f"eigenvalue error {err_nf:.2e}")
    print(f"  equal accuracy (within 2x): {equal}")
    print(f"  ratio nfoursid / adaptid (same run): {t_nf / t_ad:.1f}x")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"N": args.n, "horizon": args.horizon, "adaptid_s": t_ad, "nfoursid_s": t_nf,
                       "ratio": t_nf / t_ad, "adaptid_error": err_ad, "nfoursid_error": err_nf,
                       "equal_accuracy": bool(equal), "adaptid": adaptid.__version__,
                       "machine": platform.platform(),
                       "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}, fh, indent=1)


if __name__ == "__main__":
    main()
