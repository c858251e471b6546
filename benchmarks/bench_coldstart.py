"""Cold start: the first RLS(n).run and update in a fresh process, caches empty.

    python benchmarks/bench_coldstart.py [--n 3 5 8 24] [--repeat 1] [--src PATH] [--no-demo]

Each measurement is a new Python process whose numba cache folder
(``NUMBA_CACHE_DIR``) is a new empty temporary folder (and, for the code
before specialisation by size tags, ``ADAPTID_KERNEL_DIR`` too), so every
kernel is compiled from scratch: "cold" is the first process on that folder,
"warm" a second process on the same folder (everything loaded from the disk
cache). Printed: seconds for ``import adaptid`` + ``RLS(n)``, the first
``run`` on 1000 samples, and the first ``update`` after it.

Then ``adaptid demo`` (report written to a temporary folder) in the same
way: wall-clock seconds of the whole command with an empty cache folder
("fresh install") and again on that folder.

``--src`` runs another checkout's ``src`` (e.g. the commit before a change)
in the same way, for a same-run comparison.

"Cold" is a fresh install: numba's cache folder is empty, and the kernels
compiled when pip built adaptid (``adaptid/_kernels/_aot``,
:mod:`adaptid._kernels.toolchain._installed`) are used when they match, as for a user.
``--jit`` sets ``ADAPTID_AOT=0`` in the children: every kernel compiled from
nothing, as without that build step. The header line says which.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

CHILD = r"""
import time, json, sys
t0 = time.perf_counter()
import numpy as np
import adaptid
n = int(sys.argv[1])
est = adaptid.RLS(n, forgetting=0.99)
t1 = time.perf_counter()
rng = np.random.default_rng(0)
Phi = rng.standard_normal((1000, n)); y = Phi @ np.ones(n)
est.run(Phi, y)
t2 = time.perf_counter()
est.update(Phi[0], y[0])
t3 = time.perf_counter()
print(json.dumps({"import": t1 - t0, "run": t2 - t1, "update": t3 - t2}))
"""


AOT = {}  # ADAPTID_AOT for the children (set from --jit)


def measure(n, src, cache):
    env = dict(os.environ, NUMBA_CACHE_DIR=cache, ADAPTID_KERNEL_DIR=cache, **AOT)
    if src:
        env["PYTHONPATH"] = src + os.pathsep + env.get("PYTHONPATH", "")
    out = subprocess.run([sys.executable, "-c", CHILD, str(n)], env=env, check=True,
                         capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def measure_demo(src, cache):
    import time
    env = dict(os.environ, NUMBA_CACHE_DIR=cache, ADAPTID_KERNEL_DIR=cache, **AOT)
    if src:
        env["PYTHONPATH"] = src + os.pathsep + env.get("PYTHONPATH", "")
    with tempfile.TemporaryDirectory(prefix="adaptid-demo-") as out:
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-c", "import sys; from adaptid.cli import main; "
                        "sys.exit(main(sys.argv[1:]))", "demo", "-q", "-o",
                        os.path.join(out, "report")], env=env, check=True, capture_output=True)
        return time.perf_counter() - t0


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[3, 5, 8, 24])
    ap.add_argument("--no-demo", action="store_true", help="skip the adaptid demo timing")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--src", default=None, help="another checkout's src folder")
    ap.add_argument("--json", default=None)
    ap.add_argument("--jit", action="store_true",
                    help="ADAPTID_AOT=0: ignore the kernels compiled at install")
    args = ap.parse_args()
    if args.jit:
        AOT["ADAPTID_AOT"] = "0"
    status = json.loads(subprocess.run(
        [sys.executable, "-c", "import json; from adaptid._kernels.toolchain import _installed; "
         "print(json.dumps(_installed.status()))"], env=dict(os.environ, **AOT), check=True,
        capture_output=True, text=True).stdout)
    print("kernels compiled at install: " + (f"{status['kernels']}, used" if status["used"]
          else f"not used ({status['why_not']})"), flush=True)
    rows = []
    for n in args.n:
        cold, warm = [], []
        for _ in range(args.repeat):
            with tempfile.TemporaryDirectory(prefix="adaptid-cold-") as cache:
                cold.append(measure(n, args.src, cache))
                warm.append(measure(n, args.src, cache))
        med = {k: {key: statistics.median(r[key] for r in runs) for key in runs[0]}
               for k, runs in (("cold", cold), ("warm", warm))}
        rows.append({"n": n, **med})
        c, w = med["cold"], med["warm"]
        print(f"n={n:2d}  cold: import {c['import']:.2f} s, first run {c['run']:.2f} s, "
              f"first update {c['update']:.2f} s   warm: run {w['run']:.3f} s, "
              f"update {w['update']:.3f} s", flush=True)
    if not args.no_demo:
        with tempfile.TemporaryDirectory(prefix="adaptid-cold-") as cache:
            cold, warm = measure_demo(args.src, cache), measure_demo(args.src, cache)
        rows.append({"demo": {"cold": cold, "warm": warm}})
        print(f"adaptid demo (report included): cold {cold:.1f} s, warm {warm:.1f} s", flush=True)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)


if __name__ == "__main__":
    main()
