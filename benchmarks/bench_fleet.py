"""Fleet benchmark: adaptid.fleet.identify against a pandas groupby loop, and Dask scaling.

Run:  python benchmarks/bench_fleet.py [--devices 10000] [--samples 1000] [--repeat 3]

1. Throughput of ``adaptid.fleet.identify`` (RLS, n = 4, in-process Dask,
   compiled segmented kernel) against ``df.groupby("device").apply`` calling
   adaptid's own single-stream ``RLS(4).run`` per device (target ≥ 10×).
2. Scaling from 1 to 2 Dask workers: a ``LocalCluster`` of single-threaded
   worker processes (numba limited to the worker's thread), the data in a
   Parquet data set indexed by device (known divisions, so no shuffle); each
   worker reads and identifies its partitions (target ≥ 1.6× on 2 cores).

Times are the best of ``--repeat`` runs after a warm-up (numba compilation
and worker start-up excluded). Not part of the test suite.
"""

from __future__ import annotations

import argparse
import os
import platform
import tempfile
import time

import numpy as np

PHI = ["i", "di_dt", "omega", "sign_i"]


def best_of(fn, repeat):
    times = []
    out = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--devices", type=int, default=10_000)
    ap.add_argument("--samples", type=int, default=1000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--partitions", type=int, default=16,
                    help="Parquet partitions for the scaling test")
    args = ap.parse_args(argv)

    import dask.dataframe as dd
    import distributed
    import pandas as pd

    import adaptid
    from adaptid import fleet
    from adaptid.datasets import fleet as make_fleet

    G, N = args.devices, args.samples
    print(f"# fleet benchmark: {G} devices x {N} samples, n = 4, RLS; "
          f"{os.cpu_count()} cores, {platform.processor() or platform.machine()}, "
          f"load average {os.getloadavg()[0]:.2f}")
    df = make_fleet(n_devices=G, n_samples=N, seed=0)
    df.attrs = {}
    rows = G * N

    # ---------------------------------------------------------------- 1. loop
    def baseline():
        def one(g):
            traj = adaptid.RLS(4).run(g[PHI].to_numpy(), g["v"].to_numpy(), store=False)
            return pd.Series(traj.error[-1:])
        return df.groupby("device", sort=True).apply(one)

    # The groupby loop runs the estimator only; identify also tests every device
    # for a change. The BDE CUSUM of the a-priori errors (compiled, one pass) is the
    # work of the earlier runs of this benchmark; the default supF (a per-device
    # F test, issue 17) is timed beside it.
    def ours(test="a-priori"):
        return fleet.identify(df, group="device", y="v", phi=PHI, time="time", change_test=test)

    fleet.identify(df.iloc[: 20 * N], group="device", y="v", phi=PHI, time="time")  # compile
    ours()
    adaptid.RLS(4).run(df[PHI].to_numpy()[:N], df["v"].to_numpy()[:N])
    t_loop, _ = best_of(baseline, max(1, args.repeat - 1))
    t_ours, res = best_of(ours, args.repeat)
    print(f"groupby().apply(RLS.run)        {t_loop:8.3f} s  {rows / t_loop / 1e6:7.2f} M samples/s")
    print(f"fleet.identify (in-process)     {t_ours:8.3f} s  {rows / t_ours / 1e6:7.2f} M samples/s")
    print(f"speed-up identify / groupby:    {t_loop / t_ours:8.1f} x   (target >= 10)")
    t_supf, _ = best_of(lambda: ours("supF"), args.repeat)
    print(f"fleet.identify, supF per device {t_supf:8.3f} s  {rows / t_supf / 1e6:7.2f} M samples/s"
          f"  ({t_loop / t_supf:.1f} x groupby)")
    print(f"  flagged {int(res['change'].sum())} of {G} devices")

    # ------------------------------------------------------------- 2. scaling
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "fleet.parquet")
        dd.from_pandas(df.set_index("device"), npartitions=args.partitions, sort=True) \
            .to_parquet(path)
        del df

        def run(client):
            data = dd.read_parquet(path, index="device", calculate_divisions=True)
            return fleet.identify(data, group="device", y="v", phi=PHI, time="time",
                                  client=client, change_test="a-priori")

        t = {}
        for workers in (1, 2):
            with distributed.LocalCluster(n_workers=workers, threads_per_worker=1,
                                          processes=True, dashboard_address=None) as lc, \
                    distributed.Client(lc, set_as_default=False) as client:
                run(client)  # warm-up: workers import and load the compiled kernels
                t[workers], _ = best_of(lambda: run(client), args.repeat)
            print(f"LocalCluster {workers} worker(s) x 1 thread  {t[workers]:8.3f} s  "
                  f"{rows / t[workers] / 1e6:7.2f} M samples/s")
        print(f"scaling 1 -> 2 workers:         {t[1] / t[2]:8.2f} x   (target >= 1.6)")


if __name__ == "__main__":
    main()
