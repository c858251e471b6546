"""Smoke tests of benchmarks/bench_rls.py and of the runner benchmarks/run.py.

bench_rls.py: it runs, and it compares like with like. Only the correctness of
the comparison is checked (the contenders compute the same estimates on the
same data); speed is never asserted here — timings of ``--quick`` are
meaningless, and the real numbers live in BENCHMARKS.md. run.py: its quick
check runs at tiny sizes (``--smoke``) and prints its Markdown table with the
commit and the machine.
"""

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "benchmarks" / "bench_rls.py"
RUNNER = ROOT / "benchmarks" / "run.py"
NS = (4, 8, 16, 32)
HAVE_GCC = shutil.which("gcc") is not None

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def quick_results(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench") / "quick.json"
    proc = subprocess.run(
        [sys.executable, str(SCRIPT), "--quick", "--json", str(out)],
        cwd=ROOT, capture_output=True, text=True, timeout=600,
    )
    assert proc.returncode == 0, f"bench_rls.py --quick failed:\n{proc.stdout}\n{proc.stderr}"
    return json.loads(out.read_text()), proc.stdout


def test_quick_run_reports_every_contender(quick_results):
    res, stdout = quick_results
    assert "## Targets of the issue" in stdout
    assert res["meta"]["quick"] is True
    cases = res["cases"]
    for n in NS:
        for cid in ("rls", "rls_nostore", "numpy", "padasip", "statsmodels"):
            assert f"{cid}_n{n}" in cases
    for cid in ("update_n4", "batched", "batched_1call", "window", "window_lstsq"):
        assert cid in cases
    for c in cases.values():
        assert len(c["times_s"]) == res["meta"]["rounds"]
        assert all(t > 0 for t in c["times_s"])
    # every target is reported with a verdict (met or not: not asserted)
    for name, t in res["targets"].items():
        if HAVE_GCC or "_c" not in name:
            assert t["met"] in (True, False), name


def test_adaptid_equals_padasip_and_numpy_loop(quick_results):
    checks = quick_results[0]["checks"]
    for n in NS:
        c = checks[f"n{n}"]
        # padasip: same estimator (mu = forgetting, R0 = I/eps = P0 I), final theta
        assert c["padasip_final_rel"] < 1e-9, (n, c)
        # the plain NumPy loop of the covariance form, whole trajectory
        assert c["numpy_theta_traj_rel"] < 1e-8, (n, c)
        # statsmodels is lambda = 1 (OLS): both it and adaptid (lambda = 1, diffuse
        # prior) reproduce lstsq on the same data
        assert c["statsmodels_vs_lstsq_rel"] < 1e-8, (n, c)
        assert c["adaptid_lam1_vs_lstsq_rel"] < 1e-6, (n, c)
    # the contract the timings rely on: N updates == one run == a run in chunks
    assert checks["update_equals_run"] is True
    assert checks["chunked_equals_one_call"] is True
    assert checks["batched"]["chunked_equals_one_call"] is True


def test_adaptid_equals_c_reference(quick_results):
    res, _ = quick_results
    # .ci/run installs gcc where it is missing: without it this check fails, not skips
    assert HAVE_GCC, "gcc is not installed: bench_rls.py could not build its C reference"
    assert res["meta"]["c_available"] is True
    checks = res["checks"]
    for n in NS:
        c = checks[f"n{n}"]
        for key in ("c_fixed_theta_traj_rel", "c_fixed_error_rel", "c_fixed_final_rel",
                    "c_nostore_final_rel", "c_any_theta_traj_rel", "c_sym_theta_traj_rel"):
            assert c[key] < 1e-8, (n, key, c[key])
    assert checks["batched"]["c_theta_traj_rel"] < 1e-8
    assert checks["batched"]["c_chunked_final_rel"] < 1e-8


def test_sliding_window_equals_lstsq_resolve(quick_results):
    w = quick_results[0]["checks"]["window"]
    # the same cost (window + the prior as extra rows): equal to rounding
    assert w["vs_lstsq_with_prior_rel"] < 1e-9
    # the plain window lstsq the benchmark times differs only by the 1/P0 prior
    assert w["vs_plain_lstsq_rel"] < 1e-4


def test_runner_quick_smoke_prints_the_table():
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(ROOT / "src")] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]))
    proc = subprocess.run([sys.executable, str(RUNNER), "--quick", "--smoke"], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, f"run.py --quick --smoke failed:\n{proc.stdout}\n{proc.stderr}"
    out = proc.stdout
    assert out.startswith("Commit `") and "\nMachine: " in out
    rows = [line for line in out.splitlines() if line.startswith("| `")]
    assert [r.split(" | ")[0] for r in rows] == [
        "| `RLS(4).run`, store=False", "| `SlidingWindowRLS(4, 100).run`",
        "| `RLS(4).update` from Python"]
    if HAVE_GCC:  # a ratio to the C loop, not NaN
        assert re.search(r"\| [0-9.]+ × the fastest C loop \|", rows[0]), rows[0]


def test_runner_lists_every_maintained_benchmark():
    proc = subprocess.run([sys.executable, str(RUNNER), "--list"], cwd=ROOT, capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    scripts = {p.name for p in (ROOT / "benchmarks").glob("*.py")} - {"run.py"}
    listed = set(re.findall(r"benchmarks/(\w+\.py)", proc.stdout))
    assert listed == scripts - {"bench_rls_forms.py"}  # run through bench_rls.py --forms
