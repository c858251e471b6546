"""The `adaptid` command line: demo, fit, info, errors.

Oracles: the simulator's truth (demo), numpy.linalg.lstsq on regressors built
here by hand (batch, ARX), the core estimators run directly on the arrays the
test wrote (recursive fits), a single run over the whole file (save/resume),
the core run on the data with the NaN rows removed (--nan skip).
Most cases call the CLI in-process with typer's CliRunner; one subprocess
test runs the installed console script, one `python -m adaptid`.
"""

import csv
import json
import shutil
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

import adaptid
from adaptid.cli._app import app

runner = CliRunner()


def invoke(*args):
    return runner.invoke(app, [str(a) for a in args])


def run_json(*args):
    res = invoke(*args, "--json")
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


def assert_one_line_error(res, *needles):
    """Exit 2, exactly one line on stderr naming the culprit, nothing on stdout, no traceback."""
    assert res.exit_code == 2, (res.exit_code, res.output)
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, res.stderr
    assert lines[0].startswith("adaptid: error: "), lines[0]
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])
    assert "Traceback" not in res.output
    assert res.stdout == ""


# ------------------------------------------------------------------ data
@pytest.fixture
def regression(rng, tmp_path):
    """A 3-parameter regression written to CSV with full float precision."""
    N = 600
    Phi = rng.standard_normal((N, 3))
    theta = np.where(np.arange(N)[:, None] < 300, [1.0, -2.0, 0.5], [1.5, -2.0, 0.25])
    y = np.einsum("ki,ki->k", Phi, theta) + 0.05 * rng.standard_normal(N)
    df = pd.DataFrame({"a": Phi[:, 0], "b": Phi[:, 1], "c": Phi[:, 2], "y": y})
    path = tmp_path / "data.csv"
    df.to_csv(path, index=False, float_format="%.17g")
    return path, Phi, y, df


# ------------------------------------------------------------------ demo
@pytest.fixture(scope="module")
def demo_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo") / "report"
    res = invoke("demo", "--out", out)
    assert res.exit_code == 0, res.output
    return out, res


def test_demo_writes_report_and_estimates_match_truth(demo_dir):
    out, res = demo_dir
    for name in ("index.html", "tracks.png", "errors.png", "cusum.png", "estimates.csv"):
        assert (out / name).is_file() and (out / name).stat().st_size > 0, name
    for png in ("tracks.png", "errors.png", "cusum.png"):
        assert (out / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    html = (out / "index.html").read_text(encoding="utf-8")
    for png in ("tracks.png", "errors.png", "cusum.png"):
        assert f'src="{png}"' in html
    assert "<script" not in html and "http://" not in html and "https://" not in html
    # oracle: the simulator's truth at the last sample
    _, truth = adaptid.datasets.dc_motor(seed=0)
    last = truth.iloc[-1]
    est = pd.read_csv(out / "estimates.csv")
    assert list(est.columns) == ["name", "method", "estimate", "stderr", "truth"]
    assert set(est.method) == {"rls", "window", "kalman"}
    for method in ("rls", "window", "kalman"):
        for p in ("R", "Ke", "J"):
            row = est[(est.method == method) & (est.name == p)]
            assert len(row) == 1
            value = float(row.estimate.iloc[0])
            assert abs(value / last[p] - 1) < 0.02, (method, p, value, last[p])
            assert float(row.stderr.iloc[0]) > 0
    # the summary table is printed: every method, the delay and the truth
    for text in ("RLS", "window", "Kalman", "J delay", "truth"):
        assert text in res.stdout


def test_demo_json():
    res = invoke("demo", "--no-report", "--json")
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)
    assert set(data["methods"]) == {"rls", "window", "kalman"}
    for m in data["methods"].values():
        assert m["delay_J_s"] is not None and 0 <= m["delay_J_s"] < 10
        assert m["rms_error"]["electrical"] > 0


# ------------------------------------------------------------------- fit
@pytest.mark.parametrize("opts, make", [
    (["--method", "rls", "--forgetting", "0.98", "--P0", "1e6"],
     lambda: adaptid.RLS(3, forgetting=0.98, P0=1e6)),
    (["--method", "window", "--window", "50", "--P0", "1e8"],
     lambda: adaptid.SlidingWindowRLS(3, 50, P0=1e8)),
    (["--method", "kalman", "--process-cov", "1e-5", "--noise-var", "0.0025"],
     lambda: adaptid.KalmanRLS(3, process_cov=1e-5, noise_var=0.0025)),
    ([], lambda: adaptid.RLS(3)),
])
def test_fit_reproduces_core_estimator(regression, opts, make):
    path, Phi, y, _ = regression
    out = run_json("fit", path, "--y", "y", "--phi", "a,b,c", *opts)
    est = make()
    est.run(Phi, y)
    np.testing.assert_allclose(out["theta"], est.theta, rtol=0, atol=1e-12)
    assert out["names"] == ["a", "b", "c"]
    assert out["n_samples"] == len(y) and out["n_skipped"] == 0
    assert out["method"] == (opts[1] if opts else "rls")
    # documented stderr (issue 13 point 3 changed the rule; docs/guide.md "Standard errors
    # of a recursive fit"), written out here: c_k = λ^(N-k) for rls, 1 in the last M
    # samples of the window and 0 before, 1 for kalman; σ̂² = Σ c r² / (Σ c − n) with the
    # residuals of the final estimate; se = sqrt(σ̂² diag(P) / R2)
    N = len(y)
    c = {"window": (np.arange(N) >= N - 50).astype(float),
         "kalman": np.ones(N)}.get(out["method"], getattr(est, "forgetting", 1.0)
                                    ** np.arange(N - 1, -1, -1.0))
    r = y - Phi @ est.theta
    s2 = (c @ (r * r)) / (c.sum() - 3) / getattr(est, "noise_var", 1.0)
    # same sums in another order: rounding only
    np.testing.assert_allclose(out["stderr"], np.sqrt(s2 * np.diag(est.P)), rtol=1e-9)


def test_fit_batch_against_numpy(regression):
    path, Phi, y, _ = regression
    out = run_json("fit", path, "--y", "y", "--phi", "a,b,c", "--method", "batch")
    theta, rss, *_ = np.linalg.lstsq(Phi, y, rcond=None)
    np.testing.assert_allclose(out["theta"], theta, rtol=1e-10)
    s2 = rss[0] / (len(y) - 3)
    se = np.sqrt(s2 * np.diag(np.linalg.inv(Phi.T @ Phi)))
    np.testing.assert_allclose(out["stderr"], se, rtol=1e-8)


def test_fit_parquet_and_npz_equal_csv(regression, tmp_path):
    path, Phi, y, df = regression
    ref = run_json("fit", path, "--y", "y", "--phi", "a,b,c", "--forgetting", "0.99")
    df.to_parquet(tmp_path / "d.parquet")
    np.savez(tmp_path / "d.npz", Phi=Phi, y=y)
    pq = run_json("fit", tmp_path / "d.parquet", "--y", "y", "--phi", "a,b,c", "--forgetting", "0.99")
    nz = run_json("fit", tmp_path / "d.npz", "--y", "y", "--phi", "Phi", "--forgetting", "0.99")
    assert pq["theta"] == ref["theta"]
    assert nz["theta"] == ref["theta"]
    assert nz["names"] == ["Phi[0]", "Phi[1]", "Phi[2]"]


def test_fit_arx_batch_against_numpy(rng, tmp_path):
    N = 800
    u = rng.standard_normal(N)
    y = np.zeros(N)
    for k in range(2, N):  # y[k] = 1.5 y[k-1] - 0.7 y[k-2] + 0.5 u[k-1] + 0.25 u[k-2] + e
        y[k] = 1.5 * y[k - 1] - 0.7 * y[k - 2] + 0.5 * u[k - 1] + 0.25 * u[k - 2] \
            + 0.01 * rng.standard_normal()
    path = tmp_path / "arx.csv"
    pd.DataFrame({"u": u, "y": y}).to_csv(path, index=False, float_format="%.17g")
    out = run_json("fit", path, "--arx", "2,2,1", "--u", "u", "--y", "y", "--method", "batch")
    k = np.arange(2, N)
    X = np.column_stack([y[k - 1], y[k - 2], u[k - 1], u[k - 2]])
    th, *_ = np.linalg.lstsq(X, y[k], rcond=None)
    # issue 13 point 4 changed the convention: the CLI reports A(q) = 1 + a1 q^-1 + a2 q^-2
    # (models.ARX's), so a_j is minus the coefficient of y[k-j] fitted by numpy here
    np.testing.assert_allclose(out["theta"], [-th[0], -th[1], th[2], th[3]], rtol=1e-9)
    assert out["names"] == ["a1", "a2", "b0", "b1"]  # the model objects' names (issue 33)


@pytest.mark.parametrize("method", [["--method", "rls", "--forgetting", "0.99"],
                                    ["--method", "window", "--window", "40"],
                                    ["--method", "kalman", "--process-cov", "1e-4"]])
def test_save_resume_two_halves_equals_one_run(regression, tmp_path, method):
    path, Phi, y, df = regression
    whole = run_json("fit", path, "--y", "y", "--phi", "a,b,c", *method)
    first, second = tmp_path / "h1.csv", tmp_path / "h2.csv"
    df.iloc[:250].to_csv(first, index=False, float_format="%.17g")
    df.iloc[250:].to_csv(second, index=False, float_format="%.17g")
    state = tmp_path / "state.npz"
    run_json("fit", first, "--y", "y", "--phi", "a,b,c", *method, "--save-state", state)
    assert state.is_file()
    resumed = run_json("fit", second, "--y", "y", "--phi", "a,b,c", "--resume", state)
    assert resumed["theta"] == whole["theta"]  # bit for bit
    assert resumed["n_updates"] == len(y)


def test_fit_report(regression, tmp_path):
    path, *_ = regression
    out = tmp_path / "rep"
    data = run_json("fit", path, "--y", "y", "--phi", "a,b,c", "--forgetting", "0.99", "--out", out)
    for name in ("index.html", "tracks.png", "errors.png", "cusum.png", "estimates.csv"):
        assert (out / name).is_file(), name
    with open(out / "estimates.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["name"] for r in rows] == ["a", "b", "c"]
    assert [float(r["estimate"]) for r in rows] == data["theta"]


def test_fit_table_output(regression):
    path, *_ = regression
    res = invoke("fit", path, "--y", "y", "--phi", "a,b,c")
    assert res.exit_code == 0, res.output
    for text in ("parameter", "estimate", "stderr", "a", "600 samples", "0 skipped"):
        assert text in res.stdout
    quiet = invoke("fit", path, "--y", "y", "--phi", "a,b,c", "--quiet")
    assert quiet.exit_code == 0 and quiet.stdout == ""


def test_fit_dc_motor(tmp_path):
    data, truth = adaptid.datasets.dc_motor(seed=1, duration=10.0)
    path = tmp_path / "motor.csv"
    data.to_csv(path, index=False, float_format="%.17g")
    out = run_json("fit", path, "--dc-motor", "--method", "window", "--window", "4000", "--P0", "1e6")
    assert set(out["physical"]) >= {"R", "L", "Ke", "Kt", "J", "B", "tau_c", "tau_0"}
    # oracle: the simulator's truth at the last sample (load coupled at 5 s; the window
    # holds the last 4 s)
    for p in ("R", "Ke", "J"):
        assert abs(out["physical"][p]["estimate"] / truth[p].iloc[-1] - 1) < 0.02, p
    assert len(out["theta"]) == 7


# ------------------------------------------------------------- nan rows
def test_nan_skip_counts_and_equals_run_without_rows(regression, tmp_path):
    path, Phi, y, df = regression
    bad = [10, 11, 200, 451]
    df = df.copy()
    df.loc[bad[:2], "a"] = np.nan
    df.loc[bad[2], "y"] = np.nan
    df.loc[bad[3], "c"] = np.nan
    p = tmp_path / "nan.csv"
    df.to_csv(p, index=False, float_format="%.17g")
    out = run_json("fit", p, "--y", "y", "--phi", "a,b,c", "--nan", "skip", "--P0", "1e6")
    assert out["n_skipped"] == 4
    keep = np.setdiff1d(np.arange(len(y)), bad)
    est = adaptid.RLS(3, P0=1e6)
    est.run(Phi[keep], y[keep])
    np.testing.assert_allclose(out["theta"], est.theta, rtol=0, atol=1e-12)
    table = invoke("fit", p, "--y", "y", "--phi", "a,b,c", "--nan", "skip")
    assert "4 skipped" in table.stdout
    err = invoke("fit", p, "--y", "y", "--phi", "a,b,c")
    assert_one_line_error(err, "4 row(s)", "rows 11, 12, 201, 452", "'a'", "--nan skip")


# -------------------------------------------------------------- errors
def _write(tmp_path, name, content: bytes):
    p = tmp_path / name
    p.write_bytes(content)
    return p


MALFORMED = [
    ("empty.csv", b"", "empty"),
    ("header.csv", b"a,b,y\n", "no data rows"),
    ("ragged.csv", b"a,b,y\n1,2,3\n4,5\n", "row 2"),
    ("junk.csv", bytes(range(256)) * 8, "binary"),
    ("latin1.csv", b"a,b,y\n1,2,3\n\xe9\xff,2,3\n", "UTF-8"),
    ("huge.csv", b"a,b,y\n1,2,3\n4,1e400,6\n", "'b', row 2"),
    ("text.csv", b"a,b,y\n1,2,3\n4,five,6\n", "'b', row 2"),
    ("junk.parquet", b"PAR1 not really parquet", "Parquet"),
    ("junk.npz", b"not a zip", ".npz"),
]


@pytest.mark.parametrize("name, content, needle", MALFORMED, ids=[m[0] for m in MALFORMED])
def test_malformed_inputs(tmp_path, name, content, needle):
    p = _write(tmp_path, name, content)
    res = invoke("fit", p, "--y", "y", "--phi", "a,b")
    assert_one_line_error(res, str(p), needle)


@pytest.mark.parametrize("args, needles", [
    (["--y", "y", "--phi", "a,zz"], ["'zz'", "--phi"]),
    (["--y", "nope", "--phi", "a"], ["'nope'", "--y"]),
    (["--y", "y", "--phi", "a", "--arx", "1,1,1", "--u", "a"], ["--phi", "--arx"]),
    (["--y", "y", "--phi", "a", "--window", "10"], ["--window"]),
    (["--y", "y", "--phi", "a", "--method", "window"], ["--window"]),
    (["--y", "y", "--phi", "a", "--method", "kalman"], ["--process-cov"]),
    (["--y", "y", "--phi", "a", "--method", "rls", "--process-cov", "1"], ["--process-cov"]),
    (["--y", "y", "--phi", "a", "--method", "batch", "--forgetting", "0.9"], ["--forgetting"]),
    (["--y", "y", "--phi", "a", "--forgetting", "1.5"], ["--forgetting", "1.5"]),
    (["--y", "y", "--phi", "a", "--method", "lasso"], ["--method", "lasso"]),
    (["--y", "y", "--phi", "a", "--method", "batch", "--save-state", "s.npz"], ["--save-state"]),
    (["--y", "y"], ["--phi"]),
    (["--phi", "a"], ["--y"]),
    (["--arx", "2,2", "--u", "a", "--y", "y"], ["--arx", "na,nb,nk"]),
    (["--fir", "x,1", "--u", "a", "--y", "y"], ["--fir"]),
    (["--y", "y", "--phi", "a", "--nan", "maybe"], ["--nan"]),
    (["--y", "y", "--phi", "a,b,c", "--method", "window", "--window", "2"], ["--window", "3"]),
])
def test_inconsistent_options(regression, args, needles):
    path, *_ = regression
    assert_one_line_error(invoke("fit", path, *args), *needles)


def test_method_option_rules_are_the_factory_table():
    # --method M with an option: refused ("applies to") exactly when adaptid.estimator(M)
    # does not take it, and "needs" exactly for the options the factory requires.
    from adaptid.cli._engine import OPTIONS, MethodSpec
    from adaptid.cli._errors import CLIError
    from adaptid.estimators._factory import METHODS, method_options
    from adaptid.estimators._factory import required_options

    value = {"window": 50, "forgetting": 0.99, "process_cov": 1e-4, "noise_var": 0.1,
             "step": 0.1, "eps": 1e-3}
    assert sorted(k for k, _ in OPTIONS.values()) == sorted(value)
    for m in METHODS:
        base = {k: value[k] for k in required_options(m)}
        MethodSpec(m, **base).check()
        for flag, (key, _) in OPTIONS.items():
            spec = MethodSpec(m, **{**base, key: value[key]})
            if key in method_options(m):
                spec.check()
            else:
                refused = f"^{flag} applies to --method .*, not --method {m}$"
                with pytest.raises(CLIError, match=refused):
                    spec.check()
        for flag, (key, _) in OPTIONS.items():
            if key in required_options(m):
                with pytest.raises(CLIError, match=f"^--method {m} needs {flag} "):
                    MethodSpec(m, **{k: v for k, v in base.items() if k != key}).check()


def test_file_errors(tmp_path, regression):
    missing = tmp_path / "missing.csv"
    assert_one_line_error(invoke("fit", missing, "--y", "y", "--phi", "a"), str(missing), "no such file")
    odd = _write(tmp_path, "data.xlsx", b"PK")
    assert_one_line_error(invoke("fit", odd, "--y", "y", "--phi", "a"), "data.xlsx", "unknown file type")
    bad_state = _write(tmp_path, "state.npz", b"garbage")
    path, *_ = regression
    assert_one_line_error(invoke("fit", path, "--y", "y", "--phi", "a,b,c", "--resume", bad_state),
                          "--resume", "state.npz")


def test_resume_mismatch(regression, tmp_path):
    path, *_ = regression
    state = tmp_path / "s.npz"
    run_json("fit", path, "--y", "y", "--phi", "a,b,c", "--forgetting", "0.99", "--save-state", state)
    assert_one_line_error(invoke("fit", path, "--y", "y", "--phi", "a,b", "--resume", state),
                          "--resume", "3 parameters")
    assert_one_line_error(invoke("fit", path, "--y", "y", "--phi", "a,b,c", "--resume", state,
                                 "--method", "kalman"), "--method kalman")
    assert_one_line_error(invoke("fit", path, "--y", "y", "--phi", "a,b,c", "--resume", state,
                                 "--forgetting", "0.9"), "--forgetting")


def test_debug_shows_traceback(tmp_path):
    p = _write(tmp_path, "empty.csv", b"")
    res = invoke("--debug", "fit", p, "--y", "y", "--phi", "a")
    assert res.exit_code == 2
    assert "Traceback" in res.stderr
    assert res.stderr.strip().splitlines()[-1].startswith("adaptid: error: ")


def test_usage_error_exit_2():
    assert invoke("fit").exit_code == 2
    assert invoke("nonsense").exit_code == 2


# ----------------------------------------------------------- info / entry
def test_info_json():
    data = run_json("info")
    assert data["adaptid"] == adaptid.__version__
    assert data["numba_threading_layer"] in ("omp", "tbb", "workqueue")
    assert data["extras"]["cli"]["installed"] is True
    import numba
    assert data["numba"] == numba.__version__
    # the CPU numba's own code generator compiles for (kernel tuning and cache keys follow it)
    from numba.core.registry import cpu_target
    assert data["numba_target_cpu"] == cpu_target.target_context.codegen()._get_host_cpu_name()


def test_console_script_info():
    exe = shutil.which("adaptid")
    assert exe is not None, "the adaptid console script is not installed (pip install -e .)"
    proc = subprocess.run([exe, "info"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    for text in ("adaptid", "numba", "threading layer", "extras"):
        assert text in proc.stdout


def test_python_m_adaptid_help():
    proc = subprocess.run([sys.executable, "-m", "adaptid", "--help"], capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    for cmd in ("demo", "fit", "info"):
        assert cmd in proc.stdout
