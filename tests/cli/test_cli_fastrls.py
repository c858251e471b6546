"""``adaptid fit --fir NB[,NK] --method fastrls`` (issue 38, point 4).

Oracles, none of them the CLI's code: the Python ``FastRLS(...).run_fir`` on the
same columns (delayed by nk in the test), ``RLS(n, forgetting=λ,
P0=diag(λ**arange(n))/δ)`` on zero-padded tapped-delay regressors built here
(the equality the issue states), :func:`adaptid.recursive_fit_stats` of that
RLS for σ̂² and the standard errors, and the generated C compiled with gcc and
run against FastRLS continued in Python.
"""

from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pandas as pd
import pytest

import adaptid
from ._helpers import invoke, run_json

N = 2000




def one_line_error(res, *needles):
    assert res.exit_code == 2, (res.exit_code, res.output)
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, res.stderr
    assert lines[0].startswith("adaptid: error: "), lines[0]
    for n in needles:
        assert n in lines[0], lines[0]


def delayed(u, nk):
    """v_k = u_(k-nk), zero before the record (the prewindowed delay)."""
    return np.concatenate([np.zeros(nk), u[: len(u) - nk]])


def tapped(v, n):
    """Zero-padded tapped-delay regressors: row k = [v_k, ..., v_(k-n+1)]."""
    Phi = np.zeros((len(v), n))
    for i in range(n):
        Phi[i:, i] = v[: len(v) - i]
    return Phi


@pytest.fixture(scope="module")
def record(tmp_path_factory):
    rng = np.random.default_rng(38)
    w = rng.standard_normal(N)
    u = np.zeros(N)
    for k in range(N):  # coloured input: AR(1), pole 0.7
        u[k] = w[k] + (0.7 * u[k - 1] if k else 0.0)
    h = np.array([0.0, 0.0, 0.8, -0.5, 0.3, 0.1])   # two samples of dead time
    y = np.convolve(u, h)[:N] + 0.05 * rng.standard_normal(N)
    folder = tmp_path_factory.mktemp("fastrls")
    path = folder / "rec.csv"
    pd.DataFrame({"t": 0.01 * np.arange(N), "u": u, "y": y}).to_csv(
        path, index=False, float_format="%.17g")
    return path, u, y


@pytest.mark.parametrize("method,nk,lam,delta", [("ftf", 0, 0.999, 1e-2), ("ftf", 2, 1.0, 1e-3),
                                                 ("lattice", 2, 0.98, 1e-1)])
def test_equals_the_python_fastrls_and_rls(record, tmp_path, method, nk, lam, delta):
    path, u, y = record
    nb = 6
    tracks = tmp_path / "tr.csv"
    out = run_json("fit", path, "--u", "u", "--y", "y", "--fir", f"{nb},{nk}", "--method",
                   "fastrls", "--fastrls-method", method, "--forgetting", lam, "--delta", delta,
                   "--tracks", tracks, "--time", "t")
    v = delayed(u, nk)
    py = adaptid.FastRLS(nb, forgetting=lam, delta=delta, method=method)
    traj = py.run_fir(v, y)
    rng = np.random.default_rng(0)  # the FIR model's own names (issue 33: one naming)
    model = adaptid.models.ARX(0, nb, 0).fit(rng.standard_normal(50), rng.standard_normal(50))
    assert out["names"] == list(model.names)
    assert out["method"] == "fastrls" and out["options"]["method"] == method
    assert np.allclose(out["theta"], py.theta, rtol=0, atol=1e-12)
    tr = pd.read_csv(tracks)
    assert list(tr.columns) == ["sample", "t", *out["names"], "error"]
    assert np.allclose(tr["error"], traj.error, rtol=0, atol=1e-12)
    assert np.allclose(tr[out["names"]].to_numpy(), traj.theta, rtol=0, atol=1e-12)
    assert out["n_rescues"] == 0 and out["n_samples"] == N

    # the RLS of the issue on regressors built here, from the first sample
    Phi = tapped(v, nb)
    rls = adaptid.RLS(nb, forgetting=lam, P0=np.diag(lam ** np.arange(nb)) / delta)
    ref = rls.run(Phi, y)
    scale = np.max(np.abs(ref.error))
    assert np.max(np.abs(tr["error"].to_numpy() - ref.error)) <= 1e-8 * scale
    assert np.allclose(out["theta"], rls.theta, rtol=0, atol=1e-8)
    warm = min(10 * nb, N // 2)   # the warm-up of every recursive fit's RMS (cli/_engine.py)
    assert out["rms_error"] == pytest.approx(np.sqrt(np.mean(ref.error[warm:] ** 2)), rel=1e-8)
    st = adaptid.recursive_fit_stats(rls, Phi, y)
    assert out["sigma2"] == pytest.approx(st.sigma2, rel=1e-8)
    assert np.allclose(out["stderr"], st.stderr, rtol=1e-6, atol=0)


def test_fir_n_alone_is_n_taps_without_delay(record):
    path, u, y = record
    out = run_json("fit", path, "--u", "u", "--y", "y", "--fir", "4", "--method", "fastrls")
    py = adaptid.FastRLS(4)   # the library's defaults: λ = 1, δ = 1e-4, ftf
    py.run_fir(u, y)
    assert np.allclose(out["theta"], py.theta, rtol=0, atol=1e-12)
    assert out["options"] == {"forgetting": 1.0, "delta": 1e-4, "method": "ftf"}
    one_line_error(invoke("fit", path, "--u", "u", "--y", "y", "--fir", "4"), "--fir", "nb,nk")


def test_nan_skip_is_the_library_skip(record, tmp_path):
    path, u, y = record
    u2, y2 = u.copy(), y.copy()
    u2[100], y2[700], u2[701] = np.nan, np.nan, np.nan
    f = tmp_path / "gaps.csv"
    pd.DataFrame({"u": u2, "y": y2}).to_csv(f, index=False, float_format="%.17g")
    one_line_error(invoke("fit", f, "--u", "u", "--y", "y", "--fir", "5", "--method",
                          "fastrls"), "missing values", "--nan skip")
    tracks = tmp_path / "tr.csv"
    out = run_json("fit", f, "--u", "u", "--y", "y", "--fir", "5", "--method", "fastrls",
                   "--forgetting", 0.995, "--nan", "skip", "--tracks", tracks)
    py = adaptid.FastRLS(5, forgetting=0.995, nan_policy="skip")
    traj = py.run_fir(u2, y2)
    assert out["n_skipped"] == 3 and out["n_samples"] == N
    assert np.allclose(out["theta"], py.theta, rtol=0, atol=1e-12)
    tr = pd.read_csv(tracks)
    assert np.array_equal(np.isnan(tr["error"]), traj.skipped)
    ok = ~traj.skipped
    assert np.allclose(tr["error"][ok], traj.error[ok], rtol=0, atol=1e-12)
    # a skipped row keeps the estimate of the row before (θ untouched)
    assert np.array_equal(tr.iloc[700, 1:6].to_numpy(), tr.iloc[699, 1:6].to_numpy())


@pytest.mark.parametrize("method,nk", [("ftf", 2), ("lattice", 0)])
def test_save_resume_equals_one_run(record, tmp_path, method, nk):
    path, u, y = record
    full = pd.read_csv(path)
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    full.iloc[:777].to_csv(a, index=False, float_format="%.17g")
    full.iloc[777:].to_csv(b, index=False, float_format="%.17g")
    opts = ["--u", "u", "--y", "y", "--fir", f"5,{nk}", "--method", "fastrls",
            "--forgetting", 0.99, "--delta", 0.5, "--fastrls-method", method]
    one = run_json("fit", path, *opts, "--tracks", tmp_path / "one.csv")
    s = tmp_path / "s.npz"
    run_json("fit", a, *opts, "--save-state", s)
    # without --method: the state file says FastRLS; options given must agree with it
    two = run_json("fit", b, "--u", "u", "--y", "y", "--fir", f"5,{nk}", "--forgetting", 0.99,
                   "--resume", s, "--save-state", s, "--tracks", tmp_path / "two.csv")
    assert two["method"] == "fastrls" and two["n_updates"] == N
    assert np.array_equal(one["theta"], two["theta"])
    e1 = pd.read_csv(tmp_path / "one.csv")["error"].to_numpy()[777:]
    e2 = pd.read_csv(tmp_path / "two.csv")["error"].to_numpy()
    assert np.array_equal(e1, e2)
    # NaN stderr is null in JSON (as for the gradient methods)
    assert all(se is None for se in two["stderr"]) and any("--resume" in w for w in two["warnings"])
    # σ̂² after --resume: the rule's sums over this run's samples, regressors continuing
    # the record (recursive_fit_stats' convention for a resumed estimator)
    Phi2, y2 = tapped(delayed(u, nk), 5)[777:], y[777:]
    r, c = y2 - Phi2 @ np.array(two["theta"]), 0.99 ** np.arange(len(y2) - 1, -1, -1)
    assert two["sigma2"] == pytest.approx(np.sum(c * r * r) / (c.sum() - 5), rel=1e-10)
    est = adaptid.FastRLS.load_state(s)
    py = adaptid.FastRLS(5, forgetting=0.99, delta=0.5, method=method)
    py.run_fir(delayed(u, nk), y)
    assert np.array_equal(est.theta, py.theta) and est.n_updates == N


def test_resume_refusals(record, tmp_path):
    path, _, _ = record
    s = tmp_path / "s.npz"
    base = ["--u", "u", "--y", "y", "--method", "fastrls"]
    run_json("fit", path, *base, "--fir", "4,1", "--forgetting", 0.99, "--save-state", s)
    one_line_error(invoke("fit", path, *base, "--fir", "4,1", "--forgetting", 0.98,
                          "--resume", s), "--forgetting", "differs")
    one_line_error(invoke("fit", path, *base, "--fir", "4,1", "--delta", 1, "--resume", s),
                   "--delta", "differs")
    one_line_error(invoke("fit", path, *base, "--fir", "4,1", "--fastrls-method", "lattice",
                          "--resume", s), "--fastrls-method", "differs")
    one_line_error(invoke("fit", path, *base, "--fir", "5,1", "--resume", s), "4 taps")
    one_line_error(invoke("fit", path, *base, "--fir", "4,2", "--resume", s), "nk = 1")
    one_line_error(invoke("fit", path, "--u", "u", "--y", "y", "--fir", "4,1", "--method", "rls",
                          "--resume", s))
    r = tmp_path / "rls.npz"
    run_json("fit", path, "--u", "u", "--y", "y", "--fir", "4,1", "--save-state", r)
    one_line_error(invoke("fit", path, *base, "--fir", "4,1", "--resume", r),
                   "differs from the state file", "a RLS")
    # a FastRLS saved from Python has no labels: nk = 0 resumes, nk > 0 is refused
    p = tmp_path / "py.npz"
    adaptid.FastRLS(4, forgetting=0.99).save_state(p)
    run_json("fit", path, *base, "--fir", "4,0", "--resume", p)
    one_line_error(invoke("fit", path, *base, "--fir", "4,1", "--resume", p), "nk = 0")


DRIVER = r"""
#include <stdio.h>
#include "fir.h"
int main(void)
{
    fir_t s;
    double u, y;
    fir_init(&s);
    while (scanf("%lf %lf", &u, &y) == 2)
        printf("%.17g\n", (double)fir_update(&s, (@real@)u, (@real@)y));
    return 0;
}
"""


@pytest.mark.parametrize("dtype", ["float64", "float32"])
def test_export_c_compiles_and_continues_the_fit(record, tmp_path, dtype):
    assert shutil.which("gcc"), "gcc is required (as for tests/codegen/test_codegen_fastrls.py)"
    path, u, y = record
    full = pd.read_csv(path)
    a = tmp_path / "a.csv"
    full.iloc[:1500].to_csv(a, index=False, float_format="%.17g")
    s, cdir = tmp_path / "s.npz", tmp_path / "c"
    out = run_json("fit", a, "--u", "u", "--y", "y", "--fir", "6,0", "--method", "fastrls",
                   "--forgetting", 0.995, "--export-c", cdir, "--c-name", "fir",
                   "--save-state", s, *(["--float32"] if dtype == "float32" else []))
    assert sorted(out["export_c"]) == sorted([str(cdir / "fir.c"), str(cdir / "fir.h")])
    py = adaptid.FastRLS(6, forgetting=0.995)   # the exported state is the fit's
    py.run_fir(u[:1500], y[:1500])
    assert np.array_equal(adaptid.FastRLS.load_state(s).theta, py.theta)
    (tmp_path / "drv.c").write_text(DRIVER.replace("@real@", "double" if dtype == "float64"
                                                   else "float"))
    exe = tmp_path / "run"
    subprocess.run(["gcc", "-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O2",
                    "-ffp-contract=off", "-I", str(cdir), str(cdir / "fir.c"),
                    str(tmp_path / "drv.c"), "-lm", "-o", str(exe)],
                   check=True, capture_output=True, text=True)
    feed = "\n".join(f"{float(a)!r} {float(b)!r}" for a, b in zip(u[1500:], y[1500:]))
    res = subprocess.run([str(exe)], input=feed, check=True, capture_output=True, text=True)
    e_c = np.array(res.stdout.split(), dtype=float)
    ref = adaptid.FastRLS.load_state(s).run_fir(u[1500:], y[1500:]).error
    scale = np.max(np.abs(ref))
    # float64: the C rounds each product where the kernel may fuse a*b + c
    # (tests/codegen/test_codegen_fastrls.py); float32: its own precision over
    # 500 samples, the loose bound of that file
    tol = 1e-10 if dtype == "float64" else 1e-3
    assert np.max(np.abs(e_c - ref)) <= tol * scale


@pytest.mark.parametrize("args,needles", [
    (["--arx", "1,2,1", "--u", "u"], ["--method fastrls needs --fir"]),
    (["--fir", "3", "--u", "u,t"], ["one --u column"]),
    (["--fir", "0,1", "--u", "u"], ["nb must be >= 1"]),
    (["--fir", "3", "--u", "u", "--detrend", "constant", "--export-c", "cdir"],
     ["--export-c with --detrend"]),
    (["--fir", "3", "--u", "u", "--intercept"], ["--intercept does not apply"]),
    (["--fir", "3", "--u", "u", "--P0", "10"], ["--P0 does not apply", "--delta"]),
    (["--fir", "3", "--u", "u", "--window", "10"], ["--window does not apply"]),
    (["--fir", "3", "--u", "u", "--step", "0.1"], ["--step does not apply"]),
    (["--fir", "3", "--u", "u", "--delta", "-1"], ["--delta must be"]),
    (["--fir", "3", "--u", "u", "--forgetting", "1.5"], ["--forgetting must be"]),
    (["--fir", "3", "--u", "u", "--fastrls-method", "qr"], ["--fastrls-method must be"]),
    (["--fir", "3", "--u", "u", "--float32"], ["--float32 applies with --export-c"]),
    (["--fir", "3", "--u", "u", "--tracks", "x.txt"], ["--tracks"]),
])
def test_refusals(record, tmp_path, args, needles):
    path, _, _ = record
    res = invoke("fit", path, "--y", "y", "--method", "fastrls",
                 *[str(tmp_path / a) if a in ("rep", "cdir", "x.txt") else a for a in args])
    one_line_error(res, *needles)
    assert not (tmp_path / "cdir").exists() and not (tmp_path / "rep").exists()


@pytest.mark.parametrize("flag,value", [("--delta", "0.1"), ("--fastrls-method", "ftf")])
def test_fastrls_options_refused_by_other_methods(record, flag, value):
    path, _, _ = record
    one_line_error(invoke("fit", path, "--y", "y", "--u", "u", "--fir", "3,0", flag, value),
                   flag, "--method fastrls only")


def test_rescues_are_reported(record):
    path, u, y = record
    # λ = 0.6 is far below the FTF's stable range 1 - 1/(2n): rescues happen
    out = run_json("fit", path, "--u", "u", "--y", "y", "--fir", "16", "--method", "fastrls",
                   "--forgetting", 0.6)
    py = adaptid.FastRLS(16, forgetting=0.6)
    py.run_fir(u, y)
    assert py.n_rescues > 0 and out["n_rescues"] == py.n_rescues
    assert any("rescue" in w for w in out["warnings"])
    assert np.allclose(out["theta"], py.theta, rtol=0, atol=1e-12)


def test_stderr_beyond_the_work_bound_is_nan(record, monkeypatch):
    import adaptid.cli._fastrls as fast

    path, _, _ = record
    monkeypatch.setattr(fast, "STDERR_MAX_WORK", 10.0)
    out = run_json("fit", path, "--u", "u", "--y", "y", "--fir", "3", "--method", "fastrls")
    assert all(se is None for se in out["stderr"]) and out["sigma2"] > 0
    assert any("stderr not computed" in w for w in out["warnings"])
