#!/usr/bin/env python
r"""Benchmark of ``adaptid.models.NARX`` (FROLS) against sysidentpy's ``FROLS``.

Issue 35, point 4: N = 10 000 samples of a two-input polynomial NARX system
with noise, output and input lags 1 … 8 (24 base variables), degree 3, so
C(27, 3) = 2 925 candidate terms, and 10 terms selected by the error
reduction ratio, with least squares on them:

* adaptid ``NARX(8, 8, 3, n_terms=10).fit((y, u))`` — the candidate matrix
  is never formed: every step updates all candidates' ERR by one GEMM
  (:mod:`adaptid.models.nonlinear._basis`);
* sysidentpy ``FROLS(order_selection=False, n_terms=10, ylag=8,
  xlag=[[1, …, 8], [1, …, 8]], basis_function=Polynomial(degree=3),
  estimator=LeastSquares())`` ``.fit(X=u, y=y)`` — builds the 10 000 × 2 925
  matrix and runs Householder QR over it.

Both are timed in the same process (wall clock and process CPU time; best
of ``--repeat`` for adaptid, one run of sysidentpy by default), the
selected terms are checked to be the same, in the same order, and the
ratio sysidentpy / adaptid is printed. BLAS is limited to one thread.

With ``--large`` it also times adaptid alone on N = 25 000 samples and
10 660 candidates (output lags 1 … 10, input lags 1 … 14, degree 3), 10 terms
(the issue's "≥ 10 000 candidates on one core within a few seconds"), and
reports the peak memory of the fit (tracemalloc, which follows NumPy's
buffers) with the default budget and with ``max_memory`` (``--max-memory``
MiB: the prefix products recomputed in row blocks), against the 2 GiB the
25 000 × 10 660 candidate matrix would take.

Usage::

    python benchmarks/bench_frols.py              # N = 10 000 (sysidentpy: about 10 s)
    python benchmarks/bench_frols.py --large      # and the 25 000 × 10 660 case (time, memory)
    python benchmarks/bench_frols.py --n 2000     # quicker
    python benchmarks/bench_frols.py --json out.json
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time

for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import numpy as np  # noqa: E402

LAGS = 8


def make_data(N, seed=0):
    """y(k) = 0.2 + 0.5 y(k-1) - 0.2 y(k-2) + 0.8 u1(k-1) + 0.3 u2(k-3)
    - 0.3 u1(k-2) y(k-1) + 0.1 u2(k-1)^2 + 0.05 u1(k-1)^3 + 0.02 e(k)."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, (N, 2))
    e = 0.02 * rng.standard_normal(N)
    y = np.zeros(N)
    y[:3] = rng.uniform(0.2, 0.6, 3)  # nonzero: sysidentpy's Householder needs x[0] != 0
    for k in range(3, N):
        y[k] = (0.2 + 0.5 * y[k - 1] - 0.2 * y[k - 2] + 0.8 * u[k - 1, 0] + 0.3 * u[k - 3, 1]
                - 0.3 * u[k - 2, 0] * y[k - 1] + 0.1 * u[k - 1, 1] ** 2
                + 0.05 * u[k - 1, 0] ** 3 + e[k])
    return y, u


def timed(fn):
    t0, c0 = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - t0, time.process_time() - c0


def sysidentpy_terms(model, lags):
    """sysidentpy's regressor codes -> our term strings (y, u1, u2)."""
    names = {1000 + j: f"y(k-{j})" for j in range(1, lags + 1)}
    names.update({2000 + j: f"u1(k-{j})" for j in range(1, lags + 1)})
    names.update({3000 + j: f"u2(k-{j})" for j in range(1, lags + 1)})
    out = []
    for row in model.final_model:
        codes = [int(c) for c in row if c]
        if not codes:
            out.append("1")
            continue
        parts = []
        for c in sorted(set(codes), reverse=True):
            p = codes.count(c)
            parts.append(names[c] + (f"^{p}" if p > 1 else ""))
        out.append("*".join(parts))
    return out


def peak_fit(fit):
    """(model, wall s, CPU s, peak MiB of the fit's allocations): tracemalloc follows
    NumPy's buffers, so the peak is the largest memory the fit held at once."""
    import tracemalloc

    tracemalloc.start()
    try:
        out, t, c = timed(fit)
        peak = tracemalloc.get_traced_memory()[1] / 2**20
    finally:
        tracemalloc.stop()
    return out, t, c, peak


def large_case(terms, max_memory_mib):
    """N = 25 000, 10 660 candidates: adaptid alone, with the default memory budget
    and with ``max_memory`` (the prefix products in row blocks)."""
    from adaptid.models import NARX

    yl, ul = make_data(25_000, seed=1)
    ml, tl, cl, pk = peak_fit(lambda: NARX(10, 14, 3, n_terms=terms).fit((yl, ul)))
    budget = int(max_memory_mib * 2**20)
    mb, tb, cb, pb = peak_fit(lambda: NARX(10, 14, 3, n_terms=terms,
                                           max_memory=budget).fit((yl, ul)))
    out = {"N": 25_000, "candidates": int(ml.result.n_candidates), "terms": terms,
           "adaptid_s": tl, "adaptid_cpu_s": cl, "peak_mib": pk,
           "blocked_max_memory_mib": max_memory_mib, "blocked_s": tb, "blocked_cpu_s": cb,
           "blocked_peak_mib": pb, "blocked_same_terms": mb.terms == ml.terms,
           "full_matrix_mib": 25_000 * ml.result.n_candidates * 8 / 2**20}
    print(f"large: N = 25000, {ml.result.n_candidates} candidates (output lags 1-10, input "
          f"lags 1-14, degree 3), {terms} terms (the full candidate matrix would be "
          f"{out['full_matrix_mib']:.0f} MiB):")
    print(f"  adaptid, default budget:       {tl:.3f} s (CPU {cl:.3f} s), peak {pk:.0f} MiB")
    print(f"  adaptid, max_memory={max_memory_mib:g} MiB: {tb:.3f} s (CPU {cb:.3f} s), "
          f"peak {pb:.0f} MiB, same terms: {out['blocked_same_terms']}")
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=10_000, help="samples N (default 10 000)")
    ap.add_argument("--terms", type=int, default=10, help="terms selected (default 10)")
    ap.add_argument("--repeat", type=int, default=3, help="adaptid repetitions (best of)")
    ap.add_argument("--large", action="store_true",
                    help="also time adaptid on 25 000 samples, 10 660 candidates")
    ap.add_argument("--max-memory", type=float, default=32.0,
                    help="max_memory of the blocked large run, MiB (default 32)")
    ap.add_argument("--json", help="write the results to this file")
    args = ap.parse_args(argv)

    from sysidentpy.basis_function import Polynomial
    from sysidentpy.model_structure_selection import FROLS
    from sysidentpy.parameter_estimation import LeastSquares

    from adaptid.models import NARX

    y, u = make_data(args.n)
    NARX(2, 2, 2, n_terms=3).fit((y[:200], u[:200]))  # warm the imports

    t_ad = c_ad = np.inf
    for _ in range(args.repeat):
        m, t, c = timed(lambda: NARX(LAGS, LAGS, 3, n_terms=args.terms).fit((y, u)))
        t_ad, c_ad = min(t_ad, t), min(c_ad, c)
    ref = FROLS(order_selection=False, n_terms=args.terms, ylag=LAGS,
                xlag=[list(range(1, LAGS + 1))] * 2, basis_function=Polynomial(degree=3),
                estimator=LeastSquares())
    _, t_sy, c_sy = timed(lambda: ref.fit(X=u, y=y[:, None]))

    ours, theirs = list(m.terms), sysidentpy_terms(ref, LAGS)
    same = ours == theirs
    err_diff = float(np.max(np.abs(m.err - ref.err[: args.terms])))
    theta_diff = float(np.max(np.abs(m.theta - ref.theta.ravel())))
    res = {"N": args.n, "candidates": int(m.result.n_candidates), "terms": args.terms,
           "adaptid_s": t_ad, "adaptid_cpu_s": c_ad, "sysidentpy_s": t_sy,
           "sysidentpy_cpu_s": c_sy, "ratio": t_sy / t_ad, "ratio_cpu": c_sy / c_ad,
           "same_terms": same, "max_err_diff": err_diff, "max_theta_diff": theta_diff,
           "machine": platform.processor() or platform.machine()}
    print(f"N = {args.n}, {res['candidates']} candidates (lags 1-{LAGS}, degree 3), "
          f"{args.terms} terms")
    print(f"adaptid NARX.fit:     {t_ad:8.3f} s  (CPU {c_ad:.3f} s, best of {args.repeat})")
    print(f"sysidentpy FROLS.fit: {t_sy:8.3f} s  (CPU {c_sy:.3f} s)")
    print(f"ratio: {res['ratio']:.0f} x (CPU {res['ratio_cpu']:.0f} x)")
    print(f"same terms in the same order: {same}; max |ERR diff| {err_diff:.1e}, "
          f"max |theta diff| {theta_diff:.1e}")
    if not same:
        print("adaptid:   ", ours)
        print("sysidentpy:", theirs)
    if args.large:
        res["large"] = large_case(args.terms, args.max_memory)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(res, fh, indent=1)
    return 0 if same else 1


if __name__ == "__main__":
    raise SystemExit(main())
