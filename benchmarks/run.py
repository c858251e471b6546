#!/usr/bin/env python
r"""Run adaptid's benchmarks and print the tables of BENCHMARKS.md (Markdown).

    python benchmarks/run.py --quick            # the 30-second check (about 30 s warm)
    python benchmarks/run.py                    # every benchmark (an hour; ruptures alone minutes)
    python benchmarks/run.py rls_forms lms      # some of them
    python benchmarks/run.py --list             # their names and commands

Every benchmark is one of the maintained scripts of ``benchmarks/``, run in its
own process from the repository root with the command printed above its table
(adaptid as this interpreter imports it: set ``PYTHONPATH=src`` to time a
checkout). The output starts with the commit (``+`` when the work tree has
uncommitted changes) and the machine, so that it can replace the matching
sections of BENCHMARKS.md as it is. A benchmark whose package or tool is
missing is reported as skipped, not run.

``--quick`` prints RLS.run against the fastest C loop at n = 4, 8, 16, the
sliding window against re-solving each window with ``numpy.linalg.lstsq``, and
one ``update`` call. It runs ``/work/shared/bench/quick_ratios.py`` (the
reference check of the project's machines) when that file exists, and otherwise
the same measurement here (the C loops of ``/work/shared/bench/rls_ref.c`` if
present, else the repository's ``benchmarks/c/rls_ref.c``). ``--smoke`` shrinks
every size so that a run only shows that the machinery works (the test suite's
smoke test); its figures mean nothing. Speed is never asserted.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile
import time
import timeit
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
SHARED = Path("/work/shared/bench")
QUICK_RATIOS = SHARED / "quick_ratios.py"


# --------------------------------------------------------------------------
# output of the scripts -> Markdown tables
# --------------------------------------------------------------------------
def _pipe_lines(out):
    """The Markdown table lines a script printed itself."""
    return [line for line in out.splitlines() if line.startswith("|")]


def _table(head, rows):
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return lines


def t_rls(outs, jsons):
    res = jsons[0]
    rows = []
    for name, t in res["targets"].items():
        status = "n/a" if t["met"] is None else ("met" if t["met"] else "not met")
        med = "–" if t["median"] is None else f"{t['median']:.3g}"
        rows.append((f"`{name}`", t["target"], med, status))
    return _table(("figure (same-round median)", "target", "measured", ""), rows)


def t_forms(outs, jsons):
    rows = []
    for line in outs[0].splitlines():
        f = line.split()
        if f and f[0].isdigit():  # n  best C  M  variant  ud x  sqrt x  cov x  auto x
            rows.append((f[0], f"{f[1]} M ({f[3]})", f[4], f[6], f[8], f[10]))
    return _table(("n", "best C, updates/s (variant)", "ud", "sqrt", "covariance",
                   "auto (default)"), rows)


def t_update(outs, jsons):
    rows = []
    for line in outs[0].splitlines():
        m = re.match(r"(.+?)\s+([0-9.]+) us per update\s+\((.*)\)$", line)
        if m:
            rows.append((f"`{m[1]}`", m[2], m[3]))
    return _table(("estimator (n = 4)", "µs per update", "compiled entry"), rows)


def t_batched(outs, jsons):
    lines = []
    for out in outs:
        threads = re.search(r"numba threads = (\d+)", out)
        head = [line[3:] for line in out.splitlines() if line.startswith("## ")]
        lines += [f"numba threads: {threads[1] if threads else '?'}"
                  + (f" ({head[0]})" if head else "") + ":", ""] + _pipe_lines(out) + [""]
    return lines[:-1]


_LMS = re.compile(r"(N?LMS)\s+n=\s*(\d+): adaptid\s+([0-9.]+) M/s \(store=False\s+([0-9.]+)\), "
                  r"padasip ([0-9.]+) M/s \((\d+) x\)(?:; C (\S+)\s+([0-9.]+) M/s -> ([0-9.]+) x "
                  r"the fastest C loop \(store=False, C (\S+): ([0-9.]+) x)?")


def t_lms(outs, jsons):
    rows = []
    for line in outs[0].splitlines():
        m = _LMS.match(line)
        if m:
            c = (f"{m[8]} ({m[7]})", m[9], m[11]) if m[7] else ("–", "–", "–")
            rows.append((m[1], m[2], m[3], m[4], c[0], c[1], c[2], m[6]))
    return _table(("", "n", "adaptid M/s", "store=False", "fastest C M/s (variant)",
                   "÷ C", "÷ C, store=False", "× padasip"), rows)


_COLD = re.compile(r"n=\s*(\d+)\s+cold: import ([0-9.]+) s, first run ([0-9.]+) s, first update "
                   r"([0-9.]+) s\s+warm: run ([0-9.]+) s, update ([0-9.]+) s")


def t_cold(outs, jsons):
    lines = []
    for out in outs:
        rows, demo, head = [], None, out.splitlines()[0] if out.strip() else ""
        for line in out.splitlines():
            m = _COLD.match(line)
            if m:
                rows.append(m.groups())
            d = re.match(r"adaptid demo .*: cold ([0-9.]+) s, warm ([0-9.]+) s", line)
            if d:
                demo = d.groups()
        lines += [f"{head}:", ""] + _table(
            ("n", "import + RLS(n), s", "first run, s", "first update, s", "warm run, s",
             "warm update, s"), rows)
        if demo:
            lines += ["", f"`adaptid demo`: {demo[0]} s with an empty cache folder, "
                          f"{demo[1]} s warm."]
        lines.append("")
    return lines[:-1]


def t_fleet(outs, jsons):
    rows = []
    for line in outs[0].splitlines():
        if line.startswith("#") or not line.strip():
            continue
        m = re.match(r"\s*(.+?)\s{2,}(.+)$", line)
        if m:
            rows.append((m[1].rstrip(":"), re.sub(r"\s+", " ", m[2].strip())))
    return _table(("what", "measured"), rows)


def t_breakpoints(outs, jsons):
    r = jsons[0]
    return _table(("N, n, h", "breaks (BIC)", "adaptid (all m), s CPU",
                   "ruptures Dynp (one m), s CPU", "ratio, CPU", "same segmentation"),
                  [(f"{r['N']}, {r['n']}, {r['h']}", r["m"], f"{r['adaptid_cpu_s']:.3f}",
                    f"{r['ruptures_cpu_s']:.1f}", f"{r['ratio_cpu']:.0f} ×", r["same"])])


def t_n4sid(outs, jsons):
    r = jsons[0]
    return _table(("N, horizon", "adaptid n4sid, s", "nfoursid, s", "ratio",
                   "eigenvalue error adaptid / nfoursid"),
                  [(f"{r['N']}, {r['horizon']}", f"{r['adaptid_s']:.4f}", f"{r['nfoursid_s']:.2f}",
                    f"{r['ratio']:.0f} ×", f"{r['adaptid_error']:.2e} / {r['nfoursid_error']:.2e}")])


def t_n4sid_memory(outs, jsons):
    r = jsons[0]
    rows = [(f"{r['N']}, {r['horizon']}", "in memory", f"{r['memory_s']:.1f}",
             f"{r['memory_peak_MB']:.0f}", f"{r['memory_peak_MB'] / r['data_matrix_MB']:.2f}")]
    if "dask_s" in r:
        rows.append((f"{r['N']}, {r['horizon']}", f"Dask, chunks of {r['dask_chunk']}",
                     f"{r['dask_s']:.1f}", f"{r['dask_peak_MB']:.0f}",
                     f"{r['dask_peak_MB'] / r['data_matrix_MB']:.2f}"))
    table = _table(("N, horizon", "n4sid", "time, s", "peak, MB",
                    f"peak ÷ data matrix ({r['data_matrix_MB']:.0f} MB)"), rows)
    if "cov_s" not in r:
        return table
    cov = [(f"{r['N']}", "in memory", f"{r['cov_s']:.1f}", f"{r['cov_peak_MB']:.0f}",
            f"{r['cov_peak_MB'] / r['jacobian_MB']:.3f}")]
    if "dask_cov_s" in r:
        cov.append((f"{r['N']}", f"Dask, chunks of {r['dask_chunk']}", f"{r['dask_cov_s']:.1f}",
                    f"{r['dask_cov_peak_MB']:.0f}",
                    f"{r['dask_cov_peak_MB'] / r['jacobian_MB']:.3f}"))
    return table + [""] + _table(("N", "estimate_cov", "time, s", "peak, MB",
                                    f"peak ÷ whole Jacobian ({r['jacobian_MB']:.0f} MB)"), cov)


def t_frols(outs, jsons):
    r = jsons[0]
    rows = [(f"{r['N']}, {r['candidates']}, {r['terms']}", f"{r['adaptid_s']:.3f}",
             f"{r['sysidentpy_s']:.2f}", f"{r['ratio']:.0f} × (CPU {r['ratio_cpu']:.0f} ×)",
             r["same_terms"])]
    if "large" in r:
        g = r["large"]
        rows.append((f"{g['N']}, {g['candidates']}, {g['terms']}",
                     f"{g['adaptid_s']:.3f} (peak {g['peak_mib']:.0f} MiB)", "–", "–", "–"))
        if "blocked_s" in g:
            rows.append((f"same, max_memory={g['blocked_max_memory_mib']:g} MiB",
                         f"{g['blocked_s']:.3f} (peak {g['blocked_peak_mib']:.0f} MiB)",
                         "–", "–", g["blocked_same_terms"]))
    return _table(("N, candidates, terms", "adaptid NARX.fit, s", "sysidentpy FROLS.fit, s",
                   "ratio", "same terms"), rows)


def t_pipes(outs, jsons):
    return _pipe_lines(outs[0])


# --------------------------------------------------------------------------
# the benchmarks
# --------------------------------------------------------------------------
@dataclass
class Bench:
    """A maintained benchmark: its runs (environment, arguments), what it needs, its table."""

    script: str
    runs: list                      # [(env overrides, args)]; "{json}": a temporary file
    table: Callable
    what: str
    smoke: list = field(default_factory=list)   # args replacing each run's under --smoke
    modules: tuple = ()
    tools: tuple = ("gcc",)


BENCHES = {
    "rls": Bench("bench_rls.py", [({}, ["--json", "{json}"])], t_rls,
                 "RLS against padasip, statsmodels, a NumPy loop and C; update, batched, window",
                 smoke=[["--quick", "--json", "{json}"]], modules=("padasip", "statsmodels")),
    "rls_forms": Bench("bench_rls.py", [({}, ["--forms", "--rounds", "7"])], t_forms,
                       "RLS.run per form ÷ the fastest C loop of rls_ref.c",
                       smoke=[["--forms", "--quick"]]),
    "update": Bench("bench_update.py", [({}, ["--rounds", "7"])], t_update,
                    "one update() call from Python, per algorithm",
                    smoke=[["--rounds", "1", "--calls", "200"]], tools=()),
    "batched": Bench("bench_batched.py",
                     [({"NUMBA_NUM_THREADS": "1"}, ["--rounds", "5", "--ns", "4"]),
                      ({}, ["--rounds", "5", "--ns", "4"])], t_batched,
                     "run_batched / run_segments per core ÷ one C thread",
                     smoke=[["--rounds", "1", "--ns", "4", "--streams", "64"]] * 2),
    "lms": Bench("bench_lms.py", [({}, ["--rounds", "7"])], t_lms,
                 "LMS / NLMS against the fastest C loop and padasip",
                 smoke=[["--quick"]], modules=("padasip",)),
    "coldstart": Bench("bench_coldstart.py",
                       [({}, ["--repeat", "2", "--n", "3", "5", "8", "24", "64", "100"]),
                        ({}, ["--repeat", "1", "--jit", "--no-demo", "--n", "3", "8"])], t_cold,
                       "first run / update in a fresh process, empty numba cache",
                       smoke=[["--n", "3", "--no-demo"], ["--jit", "--n", "3", "--no-demo"]],
                       tools=()),
    "fleet": Bench("bench_fleet.py", [({}, [])], t_fleet,
                   "fleet.identify against pandas groupby-apply; Dask scaling",
                   smoke=[["--devices", "40", "--samples", "200", "--repeat", "1",
                           "--partitions", "2"]], modules=("pandas", "dask", "distributed"),
                   tools=()),
    "breakpoints": Bench("bench_breakpoints.py", [({}, ["--n", "5000", "--json", "{json}"])],
                         t_breakpoints, "break dating against ruptures Dynp",
                         smoke=[["--n", "300", "--repeat", "1", "--json", "{json}"]],
                         modules=("ruptures",), tools=()),
    "n4sid": Bench("bench_n4sid.py", [({}, ["--json", "{json}"])], t_n4sid,
                   "n4sid against nfoursid (2 in, 2 out, order 4, horizon 10, N = 20 000)",
                   smoke=[["--n", "1000", "--repeat", "1", "--json", "{json}"]],
                   modules=("nfoursid", "pandas"), tools=()),
    "n4sid_memory": Bench("bench_n4sid_memory.py", [({}, ["--dask", "--json", "{json}"])],
                          t_n4sid_memory,
                          "n4sid and estimate_cov peak memory at N = 10⁶, in memory and on Dask",
                          smoke=[["--n", "3000", "--chunk", "1000", "--dask", "--json", "{json}"]],
                          modules=("dask",), tools=()),


    "frols": Bench("bench_frols.py", [({}, ["--large", "--json", "{json}"])], t_frols,
                   "NARX structure selection (FROLS) against sysidentpy",
                   smoke=[["--n", "400", "--repeat", "1", "--json", "{json}"]],
                   modules=("sysidentpy",), tools=()),
    "codegen": Bench("bench_codegen.py", [({}, [])], t_pipes,
                     "generated C (to_c) against run and the C loop",
                     smoke=[["--quick", "--ns", "2", "--rounds", "1"]]),
    "fastrls": Bench("bench_fastrls.py", [({}, [])], t_pipes,
                     "FastRLS (FTF, QR lattice) against RLS and the O(n²) C loop, n = 16..1024",
                     smoke=[["--quick", "--ns", "8", "16"]]),
    "fastrls_stability": Bench("bench_fastrls_stability.py", [({}, ["--samples", "1000000"])],
                               t_pipes, "FastRLS against U-D RLS over a long coloured record",
                               smoke=[["--samples", "2000", "--ns", "8"]], tools=()),
    "embedded": Bench("embedded_sizes.py", [({}, [])], t_pipes,
                      "object size and stack of the generated C on a Cortex-M4F",
                      tools=("arm-none-eabi-gcc", "arm-none-eabi-size", "arm-none-eabi-nm")),
}


def missing(b: Bench):
    import importlib.util
    out = [m for m in b.modules if importlib.util.find_spec(m) is None]
    out += [t for t in b.tools if shutil.which(t) is None]
    return out


def shown(env, args):
    """The command as a reader types it (the runner's temporary JSON file left out)."""
    args = list(args)
    if "--json" in args:
        i = args.index("--json")
        del args[i:i + 2]
    pre = "".join(f"{k}={v} " for k, v in env.items())
    return f"{pre}python benchmarks/{{script}} {' '.join(args)}".rstrip()


def run_bench(name, b: Bench, smoke):
    print(f"\n## {name}: {b.what}\n")
    lack = missing(b)
    if lack:
        print(f"Skipped: {', '.join(lack)} not available.")
        return False
    runs = b.runs if not smoke or not b.smoke else [(e, a) for (e, _), a in zip(b.runs, b.smoke)]
    outs, jsons = [], []
    with tempfile.TemporaryDirectory(prefix="adaptid-run-") as tmp:
        for i, (env, args) in enumerate(runs):
            js = os.path.join(tmp, f"{i}.json")
            argv = [a.replace("{json}", js) for a in args]
            end = "  " if i < len(runs) - 1 else ""  # a Markdown line break between commands
            print(f"`{shown(env, args).format(script=b.script)}`{end}")
            proc = subprocess.run([sys.executable, str(HERE / b.script), *argv], cwd=ROOT,
                                  env=dict(os.environ, **env), capture_output=True, text=True)
            if proc.returncode != 0:
                print(f"\nFailed (exit {proc.returncode}):\n\n```\n{proc.stderr[-2000:]}\n```")
                return False
            outs.append(proc.stdout)
            jsons.append(json.loads(Path(js).read_text()) if os.path.exists(js) else None)
    print()
    print("\n".join(b.table(outs, jsons)))
    return True


# --------------------------------------------------------------------------
# the quick check
# --------------------------------------------------------------------------
_QR = (re.compile(r"RLS\.run n=\s*(\d+):\s+([0-9.]+) M updates/s, ([0-9.]+) x the fastest C loop"),
       re.compile(r"SlidingWindowRLS\(4, 100\)\.run:\s+([0-9.]+) M steps/s, "
                  r"([0-9.]+) x re-solving"),
       re.compile(r"RLS\(4\)\.update from Python: ([0-9.]+) us per call"))


def quick_rows(text):
    """Rows (figure, measured, against) of quick_ratios.py's output."""
    rows = []
    for line in text.splitlines():
        if m := _QR[0].match(line):
            rows.append((f"`RLS({m[1]}).run`, store=False", f"{m[2]} M updates/s",
                         f"{m[3]} × the fastest C loop"))
        elif m := _QR[1].match(line):
            rows.append(("`SlidingWindowRLS(4, 100).run`", f"{m[1]} M steps/s",
                         f"{m[2]} × lstsq on each window"))
        elif m := _QR[2].match(line):
            rows.append(("`RLS(4).update` from Python", f"{m[1]} µs per call", ""))
    return rows


def best_of(fn, rounds):
    out = []
    for _ in range(rounds):
        t = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t)
    return min(out)


def own_quick(smoke):
    """quick_ratios.py's measurement, here (its sizes; tiny ones with ``smoke``)."""
    for v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "NUMBA_NUM_THREADS"):
        os.environ.setdefault(v, "1")
    sys.path.insert(0, str(HERE))
    import numpy as np

    import adaptid
    import bench_rls
    import bench_rls_forms
    lam, p0 = 0.99, 1e3
    shared_c = SHARED / "rls_ref.c"
    lib = bench_rls_forms.build(shared_c) if shared_c.exists() and shutil.which("gcc") else None
    sizes = ((4, 3000),) if smoke else ((4, 300_000), (8, 150_000), (16, 60_000))
    rounds = 1 if smoke else 5
    lines = []
    for n, N in sizes:
        rng = np.random.default_rng(n)
        Phi = np.ascontiguousarray(rng.standard_normal((N, n)))
        y = Phi @ rng.standard_normal(n) + 0.1 * rng.standard_normal(N)
        adaptid.RLS(n, forgetting=lam, P0=p0).run(Phi[:100], y[:100])
        t_a = best_of(lambda: adaptid.RLS(n, forgetting=lam, P0=p0).run(Phi, y, store=False),
                      rounds)
        if lib is not None:  # the fastest of rls_run / rls_tri / rls_fu, as quick_ratios.py
            calls = bench_rls_forms.c_callers(lib, n, Phi, y).values()
            t_c = min(best_of(c, rounds) for c in calls)
        elif shutil.which("gcc"):  # the repository's textbook loop, n fixed
            c = bench_rls.build_c(fixed_n=n)
            t_c = best_of(lambda: bench_rls.c_run(c, Phi, y, store=False), rounds)
        else:
            t_c = float("nan")
        lines.append(f"RLS.run n={n:2d}: {N / t_a / 1e6:6.1f} M updates/s, "
                     f"{t_c / t_a:.2f} x the fastest C loop")
    n, M, N = 4, 100, (2000 if smoke else 200_000)
    rng = np.random.default_rng(1)
    Phi = rng.standard_normal((N, n))
    y = Phi @ np.ones(n) + 0.1 * rng.standard_normal(N)
    adaptid.SlidingWindowRLS(n, M).run(Phi[:300], y[:300])
    t_w = best_of(lambda: adaptid.SlidingWindowRLS(n, M).run(Phi, y), 1 if smoke else 3)
    S = 50 if smoke else 3000
    t_l = best_of(lambda: [np.linalg.lstsq(Phi[k - M:k], y[k - M:k], rcond=None)
                           for k in range(M, M + S)], 1 if smoke else 2) / S
    lines.append(f"SlidingWindowRLS(4, 100).run: {N / t_w / 1e6:6.1f} M steps/s, "
                 f"{t_l * N / t_w:.0f} x re-solving each window with lstsq")
    est = adaptid.RLS(4, forgetting=lam)
    phis = rng.standard_normal((1000, 4))
    calls = 500 if smoke else 20_000
    k = iter(range(10**9))
    t_u = min(timeit.repeat(lambda: est.update(phis[next(k) % 1000], 1.0), number=calls,
                            repeat=3)) / calls
    lines.append(f"RLS(4).update from Python: {t_u * 1e6:.2f} us per call")
    c_name = ("/work/shared/bench/rls_ref.c (fastest variant)" if lib is not None
              else "benchmarks/c/rls_ref.c (textbook loop, n fixed)")
    return "\n".join(lines), c_name


def quick(smoke):
    print("\n## quick: RLS, window and update against C and lstsq\n")
    if QUICK_RATIOS.exists() and not smoke:
        cmd = f"python {QUICK_RATIOS}"
        proc = subprocess.run([sys.executable, str(QUICK_RATIOS)], cwd=ROOT, capture_output=True,
                              text=True)
        if proc.returncode != 0:
            print(f"Failed (exit {proc.returncode}):\n\n```\n{proc.stderr[-2000:]}\n```")
            return False
        text, c_name = proc.stdout, "/work/shared/bench/rls_ref.c (fastest variant)"
    else:
        cmd = "python benchmarks/run.py --quick" + (" --smoke" if smoke else "")
        text, c_name = own_quick(smoke)
    print(f"`{cmd}`; C: {c_name}\n")
    print("\n".join(_table(("figure", "measured", "against"), quick_rows(text))))
    return True


# --------------------------------------------------------------------------
# commit and machine
# --------------------------------------------------------------------------
def commit():
    def git(*a):
        r = subprocess.run(["git", *a], cwd=ROOT, capture_output=True, text=True)
        return r.stdout.strip() if r.returncode == 0 else ""
    head = git("rev-parse", "--short", "HEAD") or "unknown"
    return head + ("+" if git("status", "--porcelain", "--untracked-files=no") else "")


def machine():
    info = {}
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True).stdout
        info = {k.strip(): v.strip() for k, v in
                (line.split(":", 1) for line in out.splitlines() if ":" in line)}
    except OSError:
        pass
    cpu = info.get("Model name", platform.processor() or platform.machine())
    parts = [f"{cpu}, {info.get('CPU(s)', os.cpu_count())} CPUs"]
    if info.get("Hypervisor vendor"):
        parts[0] += f" under {info['Hypervisor vendor']}"
    if info.get("L1d cache"):
        parts.append(f"L1d {info['L1d cache']}")
    try:
        import llvmlite.binding as llvm
        parts.append(f"LLVM target `{llvm.get_host_cpu_name()}`")
    except Exception:  # noqa: BLE001 - informative only
        pass
    vers = []
    for mod in ("numba", "llvmlite", "numpy", "scipy"):
        try:
            vers.append(f"{mod} {__import__(mod).__version__}")
        except Exception:  # noqa: BLE001
            pass
    gcc = shutil.which("gcc")
    if gcc:
        vers.append(subprocess.run([gcc, "--version"], capture_output=True,
                                   text=True).stdout.splitlines()[0])
    return "; ".join(parts) + f"; Python {platform.python_version()}, " + ", ".join(vers)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog="benchmarks: " + ", ".join(BENCHES))
    ap.add_argument("names", nargs="*", metavar="NAME",
                    help="benchmarks to run (default: all; see --list)")
    ap.add_argument("--quick", action="store_true",
                    help="only the 30-second check (RLS, window and update ratios)")
    ap.add_argument("--smoke", action="store_true",
                    help="tiny sizes: shows that the runner works; the figures mean nothing")
    ap.add_argument("--list", action="store_true", help="list the benchmarks and their commands")
    args = ap.parse_args(argv)
    if args.list:
        for name, b in BENCHES.items():
            cmds = "; ".join(shown(e, a).format(script=b.script) for e, a in b.runs)
            print(f"{name:12s} {b.what}\n{'':12s} {cmds}")
        return 0
    unknown = [n for n in args.names if n not in BENCHES]
    if unknown:
        ap.error(f"unknown benchmark {', '.join(unknown)}; choose from {', '.join(BENCHES)}")
    if args.quick and args.names:
        ap.error("--quick runs the quick check only; give no benchmark names with it")
    print(f"Commit `{commit()}`, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}"
          + (" (--smoke: sizes too small for the figures to mean anything)" if args.smoke else ""))
    print(f"Machine: {machine()}")
    if args.quick:
        return 0 if quick(args.smoke) else 1
    ok = True
    for name in args.names or BENCHES:
        ok &= run_bench(name, BENCHES[name], args.smoke)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
