"""``adaptid fit --method fastrls`` with --detrend, --validate, --summary and --out (issue 38).

Oracles, none of them the CLI's code: the split and the detrending done here
with :func:`scipy.signal.detrend` on each part; ``FastRLS(...).run_fir`` and
``RLS(n, forgetting=λ, P0=diag(λ**arange(n))/δ)`` on zero-padded tapped-delay
regressors of the detrended estimation part (the equality issue 38 states);
:func:`adaptid.models.recursive_summary` of that RLS for the summary table;
the validation fit % from ``scipy.signal.lfilter`` and NumPy, and
``models.compare`` / ``models.resid`` of an ``ARX(0, nb, nk)`` carrying the
printed θ; ``--method rls`` on the same CSV for what both paths share (the
split, the offsets, the keys of the summary, the files of the report).
"""

from __future__ import annotations

import re

import numpy as np
import pandas as pd
import pytest
from scipy.signal import detrend, lfilter

import adaptid
from ._helpers import invoke, run_json

N = 1500




def delayed(u, nk):
    return np.concatenate([np.zeros(nk), u[: len(u) - nk]])


def tapped(v, n):
    Phi = np.zeros((len(v), n))
    for i in range(n):
        Phi[i:, i] = v[: len(v) - i]
    return Phi


def nrmse_fit(y, yhat):
    """MATLAB's fit % (NRMSE), written out."""
    return 100.0 * (1.0 - np.linalg.norm(y - yhat) / np.linalg.norm(y - y.mean()))


@pytest.fixture(scope="module")
def record(tmp_path_factory):
    rng = np.random.default_rng(381)
    w = rng.standard_normal(N)
    u = lfilter([1.0], [1.0, -0.6], w) + 3.0 + 0.002 * np.arange(N)   # offset and drift
    h = np.array([0.0, 0.7, -0.4, 0.2, 0.05])
    y = lfilter(h, [1.0], u) - 1.5 - 0.001 * np.arange(N) + 0.05 * rng.standard_normal(N)
    path = tmp_path_factory.mktemp("fastrls_wf") / "rec.csv"
    pd.DataFrame({"t": 0.01 * np.arange(N), "u": u, "y": y}).to_csv(
        path, index=False, float_format="%.17g")
    return path, u, y


def parts(u, y, fraction, kind):
    """The split, then each part detrended on its own; and what was removed."""
    n1 = int(round(fraction * len(y)))
    out = []
    for a, b in ((0, n1), (n1, len(y))):
        ud, yd = detrend(u[a:b], type=kind), detrend(y[a:b], type=kind)
        out.append((ud, yd, u[a:b] - ud, y[a:b] - yd))
    return n1, out


@pytest.mark.parametrize("kind,method,nb,nk,lam,delta", [
    ("constant", "ftf", 5, 0, 0.999, 1e-2),
    ("linear", "lattice", 4, 1, 1.0, 1e-3),
    ("linear", "ftf", 6, 2, 0.995, 1e-1),
])
def test_detrend_validate_equal_python(record, tmp_path, kind, method, nb, nk, lam, delta):
    path, u, y = record
    tracks = tmp_path / "tr.csv"
    opts = ["--u", "u", "--y", "y", "--fir", f"{nb},{nk}", "--detrend", kind, "--validate", 0.7,
            "--time", "t"]
    out = run_json("fit", path, *opts, "--method", "fastrls", "--fastrls-method", method,
                   "--forgetting", lam, "--delta", delta, "--summary", "--tracks", tracks)
    n1, ((ue, ye, tue, tye), (uv, yv, tuv, tyv)) = parts(u, y, 0.7, kind)
    assert out["n_samples"] == n1 and out["n_rows"] == N and out["detrend"] == kind

    # the filter ran on the detrended estimation part: FastRLS and the RLS of issue 38
    v = delayed(ue, nk)
    py = adaptid.FastRLS(nb, forgetting=lam, delta=delta, method=method)
    traj = py.run_fir(v, ye)
    assert np.allclose(out["theta"], py.theta, rtol=0, atol=1e-12)
    tr = pd.read_csv(tracks)
    assert len(tr) == n1 and np.allclose(tr["error"], traj.error, rtol=0, atol=1e-12)
    Phi = tapped(v, nb)
    rls = adaptid.RLS(nb, forgetting=lam, P0=np.diag(lam ** np.arange(nb)) / delta)
    ref = rls.run(Phi, ye)
    assert np.max(np.abs(tr["error"] - ref.error)) <= 1e-8 * np.max(np.abs(ref.error))
    assert np.allclose(out["theta"], rls.theta, rtol=0, atol=1e-8)

    # both parts' offsets: the mean, or the line's values at the part's ends
    offs = out["detrend_offsets"]
    for part, (tu, ty) in (("estimation", (tue, tye)), ("validation", (tuv, tyv))):
        for name, t in (("u", tu), ("y", ty)):
            want = t[0] if kind == "constant" else [t[0], t[-1]]
            assert np.allclose(offs[part][name], want, rtol=0, atol=1e-9), (part, name)

    # validation: the FIR at the printed θ simulated on the held-out part
    theta = np.array(out["theta"])
    val = out["validation"]
    yhat = lfilter(np.concatenate([np.zeros(nk), theta]), [1.0], uv)
    assert val["n_samples"] == N - n1 and val["fraction"] == 0.7
    assert val["fit_kind"] == "simulation"
    assert val["fit_percent"] == pytest.approx(nrmse_fit(yv, yhat), rel=1e-10)
    data_v = adaptid.IDData(yv, uv, y_names="y", u_names="u")
    m = adaptid.models.ARX(0, nb, nk).fit(adaptid.IDData(ye, ue, y_names="y", u_names="u"))
    m.theta = theta.copy()                 # the model object's simulation at the CLI's θ
    assert val["fit_percent"] == pytest.approx(adaptid.models.compare(data_v, m).fit[0],
                                               rel=1e-10)
    res = adaptid.models.resid(data_v, m, max_lag=val["max_lag"], alpha=0.01)
    assert val["ljung_box_p"] == pytest.approx(res.autocorrelation["p_value"], rel=1e-9)
    assert val["cross_correlation_p"]["u"] == pytest.approx(
        res.cross_correlation[0]["p_value"], rel=1e-9)

    # the summary: recursive_summary of the equivalent RLS on the same regressors
    summ = out["summary"][0]
    want = adaptid.models.recursive_summary(rls, Phi, ye, names=out["names"])
    got = np.array([[summ["params"][n][c] for c in ("estimate", "stderr", "t", "p", "lower",
                                                    "upper")] for n in out["names"]])
    assert np.allclose(got, want.params, rtol=1e-6, atol=1e-12)
    assert summ["stats"]["method"] == "FastRLS"
    for key, value in want.stats.items():
        if key != "method":
            assert summ["stats"][key] == pytest.approx(value, rel=1e-6), key
    assert set(summ["stats"]) == set(want.stats)
    assert np.allclose(out["stderr"], want.params[:, 1], rtol=1e-6)

    # what --method rls shares on the same CSV: the split, the offsets, the summary's layout
    rl = run_json("fit", path, *opts, "--method", "rls", "--summary")
    assert rl["n_rows"] == out["n_rows"] and rl["detrend_offsets"] == offs
    assert {k: rl["validation"][k] for k in ("n_samples", "fraction", "max_lag", "fit_kind")} \
        == {k: val[k] for k in ("n_samples", "fraction", "max_lag", "fit_kind")}
    assert set(rl["summary"][0]["stats"]) == set(summ["stats"])
    assert list(rl["summary"][0]["params"]["b0"]) == list(summ["params"]["b0"])


def test_detrend_without_validate_is_the_whole_record(record):
    path, u, y = record
    out = run_json("fit", path, "--u", "u", "--y", "y", "--fir", "5", "--method", "fastrls",
                   "--detrend", "constant")
    py = adaptid.FastRLS(5)
    py.run_fir(u - u.mean(), y - y.mean())
    assert np.allclose(out["theta"], py.theta, rtol=0, atol=1e-12)
    assert out["detrend_offsets"] == {"estimation": pytest.approx({"u": u.mean(),
                                                                    "y": y.mean()})}
    assert "validation" not in out


def test_summary_after_resume_says_why_the_stderr_is_missing(record, tmp_path):
    path, _, _ = record
    s = tmp_path / "s.npz"
    base = ["--u", "u", "--y", "y", "--fir", "4", "--method", "fastrls"]
    run_json("fit", path, *base, "--save-state", s)
    r = invoke("fit", path, *base, "--resume", s, "--summary")
    assert r.exit_code == 0, r.output
    assert "Recursive fit (FastRLS)" in r.stdout and "not available (NaN)" in r.stdout
    assert "--resume" in r.stdout.split("not available (NaN)")[1]
    out = run_json("fit", path, *base, "--resume", s, "--summary")
    p = out["summary"][0]["params"]
    assert all(p[n]["stderr"] is None and p[n]["t"] is None for n in out["names"])
    assert out["summary"][0]["stats"]["sigma^2"] == pytest.approx(out["sigma2"], rel=1e-12)


def _image_size(html, name):
    m = re.search(rf'<img src="{re.escape(name)}" width="(\d+)" height="(\d+)"', html)
    assert m, name
    return int(m.group(1)), int(m.group(2))


def test_report_folder_as_the_rls_path(record, tmp_path):
    path, _, _ = record
    opts = ["--u", "u", "--y", "y", "--fir", "5,1", "--time", "t", "--validate", "0.8"]
    out = run_json("fit", path, *opts, "--method", "fastrls", "--out", tmp_path / "f")
    run_json("fit", path, *opts, "--method", "rls", "--out", tmp_path / "r")
    files = sorted(p.name for p in (tmp_path / "f").iterdir())
    assert files == sorted(p.name for p in (tmp_path / "r").iterdir())
    assert {"index.html", "estimates.csv", "tracks.png", "errors.png", "cusum.png",
            "compare.png", "resid.png"} <= set(files)
    assert out["report"] == str(tmp_path / "f" / "index.html")
    est = pd.read_csv(tmp_path / "f" / "estimates.csv")
    assert list(est["name"]) == out["names"] and set(est["method"]) == {"fastrls"}
    assert np.allclose(est["estimate"], out["theta"], rtol=1e-15, atol=0)
    assert np.allclose(est["stderr"], out["stderr"], rtol=1e-15, atol=0)
    html = (tmp_path / "f" / "index.html").read_text()
    assert "no ±2σ band" in html and "Validation" in html
    assert _image_size(html, "tracks.png")[1] < 1000      # 5 panels in 3 rows


def test_report_of_a_long_filter_stays_readable(tmp_path, monkeypatch):
    import adaptid.cli._fastrls as fast
    import adaptid.cli._fastrls_workflow as flow

    rng = np.random.default_rng(7)
    n, M = 120, 3000
    u = rng.standard_normal(M)
    h = np.exp(-np.arange(n) / 20.0) * np.cos(np.arange(n) / 4.0)
    y = lfilter(h, [1.0], u) + 0.01 * rng.standard_normal(M)
    f = tmp_path / "long.csv"
    pd.DataFrame({"u": u, "y": y}).to_csv(f, index=False, float_format="%.17g")
    # θ read at chunk ends (a long record) and the constancy tests beyond their bound
    monkeypatch.setattr(fast, "FULL_TRACK_VALUES", 1000.0)
    monkeypatch.setattr(flow, "CONSTANCY_MAX_WORK", 10.0)
    out = run_json("fit", f, "--u", "u", "--y", "y", "--fir", n, "--method", "fastrls",
                   "--out", tmp_path / "rep")
    py = adaptid.FastRLS(n)
    py.run_fir(u, y)                       # chunked runs equal one pass
    assert np.array_equal(out["theta"], py.theta)
    html = (tmp_path / "rep" / "index.html").read_text()
    w, hgt = _image_size(html, "tracks.png")
    assert w <= 1200 and hgt <= 800       # one panel per tap would be 60 rows of panels
    assert f"{n} taps" in html and "heat map" in html and "8 taps largest" in html
    assert "θ read at 2000 evenly spaced samples" in html
    assert "constancy tests" in html and not (tmp_path / "rep" / "cusum.png").exists()
    big = np.sort(np.argsort(-np.abs(py.theta))[:8])
    assert ", ".join(f"b{j}" for j in big) in html
    assert len(pd.read_csv(tmp_path / "rep" / "estimates.csv")) == n


def test_theta_read_at_chunk_ends_is_the_one_pass_track():
    import adaptid.cli._fastrls as fast

    rng = np.random.default_rng(8)
    u, y = rng.standard_normal(5003), rng.standard_normal(5003)
    ref = adaptid.FastRLS(7, forgetting=0.99).run_fir(u, y)
    e, th, at, rescues = fast._filter(adaptid.FastRLS(7, forgetting=0.99), u, y, store="ends")
    assert len(at) == fast.REPORT_TRACK_POINTS and at[-1] == len(y) - 1
    assert np.array_equal(e, ref.error) and np.array_equal(th, ref.theta[at]) and rescues == 0


def test_nan_skip_report_and_refusals(record, tmp_path):
    path, u, y = record
    u2 = u.copy()
    u2[[50, 51, 900]] = np.nan
    f = tmp_path / "gaps.csv"
    pd.DataFrame({"u": u2, "y": y}).to_csv(f, index=False, float_format="%.17g")
    base = ["fit", f, "--u", "u", "--y", "y", "--fir", "3", "--method", "fastrls", "--nan", "skip"]
    out = run_json(*base, "--out", tmp_path / "rep", "--summary")
    py = adaptid.FastRLS(3, nan_policy="skip")
    py.run_fir(u2, y)
    assert np.allclose(out["theta"], py.theta, rtol=0, atol=1e-12) and out["n_skipped"] == 3
    assert out["summary"][0]["stats"]["N"] == N
    assert (tmp_path / "rep" / "tracks.png").exists()
    for opt in (["--validate", "0.5"], ["--detrend", "constant"]):
        r = invoke(*base, *opt)
        assert r.exit_code == 2 and "needs a complete record" in r.stderr, r.output
