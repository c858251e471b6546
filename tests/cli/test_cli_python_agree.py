"""The shell agrees with Python on the same CSV (issue 33, point 4).

`adaptid fit` / `adaptid fleet` against the Python calls a user makes on the
same data (models.ARX/ARMAX/OE/BJ/AR, IDData.detrend/split, compare,
fit_recursive, fleet.identify): parameter names, θ, standard errors and
fit %. Oracles adaptid did not write: statsmodels OLS on regressors built
here by hand, the cost minimiser of tests/naive.py (numpy lstsq) for RLS,
MATLAB's NRMSE formula on a scipy.signal.lfilter simulation, pandas'
own frequency of the time column, numpy means for the detrend offsets.
"""


import numpy as np
import pandas as pd
import pytest
from scipy import signal

import adaptid
from adaptid import IDData, models
from ._helpers import run, run_json
from adaptid.datasets import load_daisy
from naive import rls_cost_minimiser

STAMP0 = np.datetime64("2024-01-01T00:00:00", "ns")
DT = 0.08   # the dryer's sample time (DaISy: 0.08 s)




@pytest.fixture(scope="module")
def dryer(tmp_path_factory):
    """The raw dryer record with an ISO time column 80 ms apart, and the same without time."""
    d = load_daisy("dryer")
    u, y = np.asarray(d.u, float), np.asarray(d.y, float)
    t = STAMP0 + np.arange(len(y)) * np.timedelta64(80, "ms")
    folder = tmp_path_factory.mktemp("dryer")
    path, bare = folder / "dryer.csv", folder / "bare.csv"
    pd.DataFrame({"time": pd.Series(t).dt.strftime("%Y-%m-%dT%H:%M:%S.%f"), "pump": u,
                  "temp": y}).to_csv(path, index=False, float_format="%.17g")
    pd.DataFrame({"pump": u, "temp": y}).to_csv(bare, index=False, float_format="%.17g")
    return path, bare, u, y


def python_parts(y, u, frac=0.5, kind="constant"):
    """What a user writes: split, then detrend each part (MATLAB practice)."""
    est, val = IDData(y, u, DT, y_names="temp", u_names="pump").split(frac)
    return est.detrend(kind), val.detrend(kind)


def nrmse(y, yh):
    """MATLAB's compare fit: 100 (1 - ||y - yh|| / ||y - mean(y)||)."""
    return 100.0 * (1.0 - np.linalg.norm(y - yh) / np.linalg.norm(y - y.mean()))


# -------------------------------------------------------------- batch model fits
CASES = [("arx", "2,2,3", lambda: models.ARX(2, 2, 3)),
         ("armax", "2,2,1,3", lambda: models.ARMAX(2, 2, 1, 3)),
         ("oe", "2,2,3", lambda: models.OE(2, 2, 3)),
         ("bj", "2,1,1,2,3", lambda: models.BJ(2, 1, 1, 2, 3))]


@pytest.mark.parametrize("kind,orders,make", CASES, ids=[c[0] for c in CASES])
def test_batch_model_equals_python(dryer, kind, orders, make):
    path, _, u, y = dryer
    out = run_json("fit", path, "--y", "temp", "--u", "pump", f"--{kind}", orders, "--time", "time",
                   "--detrend", "constant", "--validate", "0.5")
    est, val = python_parts(y, u)
    m = make().fit(est)
    assert out["method"] == "batch"                 # no --method: MATLAB's arx/armax/oe/bj
    assert out["names"] == list(m.names)
    # the same calls on the same numbers: ARX is QR least squares, the PEM fits are
    # deterministic iterations from the same start; only the CSV round trip (%.17g) differs
    np.testing.assert_allclose(out["theta"], m.theta, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(out["stderr"], m.stderr, rtol=1e-7)
    assert out["validation"]["fit_percent"] == pytest.approx(models.compare(val, m).fit[0],
                                                             rel=1e-9)
    assert out["dt"] == pytest.approx(DT, rel=1e-12) and m.dt == pytest.approx(DT, rel=1e-12)


def test_batch_arx_against_statsmodels_and_lfilter(dryer):
    """Independent of adaptid: OLS on hand-built regressors, fit % of an lfilter simulation."""
    import statsmodels.api as sm

    path, _, u, y = dryer
    out = run_json("fit", path, "--y", "temp", "--u", "pump", "--arx", "2,2,3",
                   "--detrend", "constant", "--validate", "0.5")
    ye, ue = y[:500] - y[:500].mean(), u[:500] - u[:500].mean()
    rows = np.arange(4, 500)
    Phi = np.column_stack([-ye[rows - 1], -ye[rows - 2], ue[rows - 3], ue[rows - 4]])
    ols = sm.OLS(ye[rows], Phi).fit()
    np.testing.assert_allclose(out["theta"], ols.params, rtol=1e-9)
    np.testing.assert_allclose(out["stderr"], ols.bse, rtol=1e-9)
    a, b = ols.params[:2], ols.params[2:]
    yv, uv = y[500:] - y[500:].mean(), u[500:] - u[500:].mean()
    ysim = signal.lfilter(np.r_[0, 0, 0, b], np.r_[1, a], uv)
    assert out["validation"]["fit_percent"] == pytest.approx(nrmse(yv, ysim), rel=1e-9)


def test_batch_ar_equals_python(dryer):
    path, _, u, y = dryer
    out = run_json("fit", path, "--y", "temp", "--ar", "2", "--time", "time",
                   "--detrend", "constant", "--validate", "0.5")
    est, val = IDData(y, None, DT, y_names="temp").split(0.5)
    est, val = est.detrend("constant"), val.detrend("constant")
    m = models.AR(2).fit(est)
    assert out["names"] == list(m.names) == ["a1", "a2"]
    np.testing.assert_allclose(out["theta"], m.theta, rtol=1e-10)
    np.testing.assert_allclose(out["stderr"], m.stderr, rtol=1e-9)
    assert out["validation"]["fit_percent"] == pytest.approx(
        models.compare(val, m, k=1).fit[0], rel=1e-9)


def test_two_inputs_named_as_the_model(tmp_path, rng):
    N = 400
    u1, u2 = rng.standard_normal(N), rng.standard_normal(N)
    y = (signal.lfilter([0, 0.5], [1, -0.6], u1) + signal.lfilter([0, 0.3], [1, -0.6], u2)
         + 0.05 * rng.standard_normal(N))
    path = tmp_path / "two.csv"
    pd.DataFrame({"u1": u1, "u2": u2, "y": y}).to_csv(path, index=False, float_format="%.17g")
    for opt, orders, m in (("--arx", "1,2,1", models.ARX(1, 2, 1)),
                           ("--oe", "1,1,1", models.OE(1, 1, 1))):
        out = run_json("fit", path, "--y", "y", "--u", "u1,u2", opt, orders)
        m.fit(IDData(y, np.column_stack([u1, u2]), u_names=["u1", "u2"]))
        assert out["names"] == list(m.names)
        assert any("_" in n for n in out["names"])      # b0_0 ...: the model's several-input names
        np.testing.assert_allclose(out["theta"], m.theta, rtol=1e-9, atol=1e-12)


# ------------------------------------------------------------------ recursive
def test_recursive_arx_equals_fit_recursive_and_naive(dryer):
    path, _, u, y = dryer
    out = run_json("fit", path, "--y", "temp", "--u", "pump", "--arx", "2,2,3", "--method", "rls",
                   "--forgetting", "0.99")
    m = models.ARX(2, 2, 3)
    m.fit_recursive(IDData(y, u), estimator=adaptid.RLS(4, forgetting=0.99))
    assert out["method"] == "rls" and out["names"] == list(m.names)
    np.testing.assert_allclose(out["theta"], m.theta, rtol=1e-9)
    np.testing.assert_allclose(out["stderr"], m.stderr, rtol=1e-8)
    # the cost RLS minimises, solved directly (tests/naive.py: numpy lstsq)
    rows = np.arange(4, len(y))
    Phi = np.column_stack([-y[rows - 1], -y[rows - 2], u[rows - 3], u[rows - 4]])
    n = len(rows)
    ref = rls_cost_minimiser(Phi, y[rows], np.full(n, 0.99), np.ones(n), np.zeros(4),
                             1e4 * np.eye(4))
    np.testing.assert_allclose(out["theta"], ref, rtol=1e-6)


def test_recursive_oe_equals_fit_recursive(dryer):
    path, _, u, y = dryer
    out = run_json("fit", path, "--y", "temp", "--u", "pump", "--oe", "2,2,3", "--method", "rls",
                   "--detrend", "constant")
    m = models.OE(2, 2, 3)
    m.fit_recursive(IDData(y, u).detrend("constant"), estimator=adaptid.RLS(4))
    assert out["names"] == list(m.names)
    np.testing.assert_allclose(out["theta"], m.theta, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(out["stderr"], m.stderr, rtol=1e-8)


def test_recursive_armax_equals_fit_recursive(dryer):
    path, _, u, y = dryer
    out = run_json("fit", path, "--y", "temp", "--u", "pump", "--armax", "2,2,1,3", "--method",
                   "rls", "--forgetting", "0.999", "--detrend", "constant")
    m = models.ARMAX(2, 2, 1, 3)
    m.fit_recursive(IDData(y, u).detrend("constant"),
                    estimator=adaptid.RLS(5, forgetting=0.999))
    assert out["names"] == list(m.names) == ["a1", "a2", "b0", "b1", "c1"]
    np.testing.assert_allclose(out["theta"], m.theta, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(out["stderr"], m.stderr, rtol=1e-8)


def test_recursive_option_without_method_selects_rls(dryer):
    path, _, u, y = dryer
    out = run_json("fit", path, "--y", "temp", "--u", "pump", "--arx", "2,2,3", "--P0", "100")
    assert out["method"] == "rls"
    m = models.ARX(2, 2, 3)
    m.fit_recursive(IDData(y, u), estimator=adaptid.RLS(4, P0=100.0))
    np.testing.assert_allclose(out["theta"], m.theta, rtol=1e-9)


# ---------------------------------------------------------- detrend per part
def test_detrend_each_part_gives_pythons_fit(dryer):
    path, _, u, y = dryer
    out = run_json("fit", path, "--y", "temp", "--u", "pump", "--arx", "2,2,3",
                   "--detrend", "constant", "--validate", "0.5")
    v = out["validation"]["fit_percent"]
    assert round(v, 2) == 89.55                       # Python's number in the issue
    est, val = python_parts(y, u)
    assert v == pytest.approx(models.compare(val, models.ARX(2, 2, 3).fit(est)).fit[0], rel=1e-10)
    # the old way (detrend the whole record, then split) gave the 87.95
    e2, v2 = IDData(y, u).detrend("constant").split(0.5)
    assert round(models.compare(v2, models.ARX(2, 2, 3).fit(e2)).fit[0], 2) == 87.95
    off = out["detrend_offsets"]
    assert off["estimation"]["temp"] == pytest.approx(np.mean(y[:500]), rel=1e-13)
    assert off["estimation"]["pump"] == pytest.approx(np.mean(u[:500]), rel=1e-13)
    assert off["validation"]["temp"] == pytest.approx(np.mean(y[500:]), rel=1e-13)
    assert off["validation"]["pump"] == pytest.approx(np.mean(u[500:]), rel=1e-13)


def test_detrend_linear_offsets_are_each_parts_line(dryer):
    path, _, u, y = dryer
    out = run_json("fit", path, "--y", "temp", "--u", "pump", "--arx", "2,2,3",
                   "--detrend", "linear", "--validate", "0.7")
    for part, sl in (("estimation", slice(0, 700)), ("validation", slice(700, None))):
        ys = y[sl]
        line = ys - signal.detrend(ys, type="linear")
        np.testing.assert_allclose(out["detrend_offsets"][part]["temp"], [line[0], line[-1]],
                                   rtol=1e-9)


# ------------------------------------------------------------------------ dt
def test_dt_from_time_column_and_given(dryer):
    path, bare, u, y = dryer
    stamps = pd.to_datetime(pd.read_csv(path)["time"])
    with pd.option_context("future.infer_freq_returns_offset", True):
        freq = pd.tseries.frequencies.to_offset(pd.infer_freq(stamps))   # pandas' own frequency
    out = run_json("fit", path, "--y", "temp", "--u", "pump", "--arx", "2,2,3", "--time", "time")
    assert out["dt"] == pytest.approx(freq.nanos * 1e-9, rel=1e-12) and out["dt_source"] == "time column"
    out = run_json("fit", bare, "--y", "temp", "--u", "pump", "--arx", "2,2,3")
    assert out["dt"] == 1.0
    out = run_json("fit", bare, "--y", "temp", "--u", "pump", "--arx", "2,2,3", "--dt", "0.08",
                   "--summary")
    assert out["dt"] == 0.08 and out["dt_source"] == "--dt"
    m = models.ARX(2, 2, 3, dt=0.08).fit(IDData(y, u, 0.08, y_names="temp", u_names="pump"))
    assert out["summary"][0]["title"] == m.summary().title          # "..., dt=0.08"
    # agreeing with the time column is accepted; contradicting it is a one-line error
    assert run_json("fit", path, "--y", "temp", "--u", "pump", "--arx", "2,2,3", "--time", "time",
                    "--dt", "0.08")["dt"] == 0.08
    r = run("fit", path, "--y", "temp", "--u", "pump", "--arx", "2,2,3", "--time", "time",
            "--dt", "0.1")
    assert r.exit_code == 2 and "--dt" in r.stderr and "contradicts" in r.stderr
    r = run("fit", bare, "--y", "temp", "--u", "pump", "--arx", "2,2,3", "--dt", "-1")
    assert r.exit_code == 2 and "--dt" in r.stderr


# ------------------------------------------------------------------------ nan
def test_nan_words_of_nan_policy(tmp_path, rng):
    N = 200
    u = rng.standard_normal(N)
    y = signal.lfilter([0, 0.5], [1, -0.6], u) + 0.05 * rng.standard_normal(N)
    y[50] = np.nan
    path = tmp_path / "gap.csv"
    pd.DataFrame({"u": u, "y": y}).to_csv(path, index=False)
    base = ("fit", path, "--y", "y", "--u", "u", "--arx", "1,1,1")
    for word in ("raise", "error", "RAISE"):
        r = run(*base, "--nan", word)
        assert r.exit_code == 2 and "--nan skip" in r.stderr, word
    out = run_json("fit", path, "--y", "y", "--phi", "u", "--nan", "skip")
    assert out["nan_policy"] == "skip" and out["n_skipped"] == 1
    r = run(*base, "--nan", "maybe")
    assert r.exit_code == 2 and "--nan" in r.stderr and "raise" in r.stderr


# ---------------------------------------------------------------------- fleet
@pytest.fixture(scope="module")
def fleet_csv(tmp_path_factory):
    rng = np.random.default_rng(7)
    frames = []
    for g in range(4):
        u = rng.standard_normal(300)
        y = signal.lfilter([0, 0.4 + 0.1 * g], [1, -0.7], u) + 0.05 * rng.standard_normal(300)
        frames.append(pd.DataFrame({"device": f"d{g}", "k": np.arange(300), "u": u, "y": y}))
    df = pd.concat(frames).sample(frac=1.0, random_state=1)      # shuffled: --time orders
    path = tmp_path_factory.mktemp("fleet") / "fleet.csv"
    df.to_csv(path, index=False, float_format="%.17g")
    return path, df


def test_fleet_arx_batch_per_device_equals_python(fleet_csv, tmp_path):
    path, df = fleet_csv
    table = tmp_path / "t.csv"
    out = run_json("fleet", path, "-g", "device", "--y", "y", "--u", "u", "--arx", "1,1,1",
                   "--time", "k", "-o", table)
    assert out["method"] == "batch" and out["n_devices"] == 4
    back = pd.read_csv(table, index_col=0)
    for dev in out["devices"]:
        part = df[df.device == dev["device"]].sort_values("k")
        m = models.ARX(1, 1, 1).fit(IDData(part.y.to_numpy(), part.u.to_numpy()))
        np.testing.assert_allclose([dev[n] for n in m.names], m.theta, rtol=1e-9)
        np.testing.assert_allclose([dev[f"stderr_{n}"] for n in m.names], m.stderr, rtol=1e-9)
        np.testing.assert_allclose(back.loc[dev["device"], list(m.names)], m.theta, rtol=1e-12)


def test_fleet_oe_batch_equals_python(fleet_csv):
    path, df = fleet_csv
    out = run_json("fleet", path, "-g", "device", "--y", "y", "--u", "u", "--oe", "1,1,1",
                   "--time", "k")
    assert out["method"] == "batch" and out["n_flagged"] is None
    for dev in out["devices"]:
        part = df[df.device == dev["device"]].sort_values("k")
        m = models.OE(1, 1, 1).fit(IDData(part.y.to_numpy(), part.u.to_numpy()))
        np.testing.assert_allclose([dev[n] for n in m.names], m.theta, rtol=1e-8)
        assert dev["sigma2"] == pytest.approx(m.noise_variance, rel=1e-8)


def test_fleet_arx_recursive_equals_fit_recursive(fleet_csv):
    path, df = fleet_csv
    out = run_json("fleet", path, "-g", "device", "--y", "y", "--u", "u", "--arx", "1,1,1",
                   "--time", "k", "--method", "rls", "--forgetting", "0.995")
    assert out["method"] == "rls" and "change" in out["devices"][0]
    for dev in out["devices"]:
        part = df[df.device == dev["device"]].sort_values("k")
        m = models.ARX(1, 1, 1)
        m.fit_recursive(IDData(part.y.to_numpy(), part.u.to_numpy()),
                        estimator=adaptid.RLS(2, forgetting=0.995))
        np.testing.assert_allclose([dev[n] for n in m.names], m.theta, rtol=1e-9)


def test_fleet_model_option_errors(fleet_csv, tmp_path):
    path, _ = fleet_csv
    base = ("fleet", path, "-g", "device", "--y", "y", "--u", "u")
    # a recursive --oe runs the streaming object per device since fleetb (tests/cli/
    # test_cli_fleet_models.py); what it still refuses is a record with gaps
    cases = [(("--oe", "1,1,1", "--method", "rls", "--nan", "skip"), "--nan skip"),
             (("--arx", "1,1,1", "--phi", "u"), "--phi"),
             (("--arx", "1,1"), "--arx"),
             (("--arx", "1,1,1", "--method", "batch", "--forgetting", "0.9"), "--forgetting"),
             (("--arx", "1,1,1", "--tracks", tmp_path / "tr", "--method", "batch"), "--tracks")]
    for extra, word in cases:
        r = run(*base, *extra)
        assert r.exit_code == 2 and word in r.stderr, (extra, r.output)
    r = run("fleet", path, "-g", "device", "--y", "y", "--phi", "u", "--method", "batch")
    assert r.exit_code == 2 and "--method" in r.stderr


def test_out_is_the_same_option_in_every_command(fleet_csv, tmp_path):
    """-o, --out (and the former --output) write fleet's table; fit's and export-c's --out too."""
    path, _ = fleet_csv
    for flag in ("-o", "--out", "--output"):
        target = tmp_path / f"t{flag.strip('-')}.csv"
        r = run("fleet", path, "-g", "device", "--y", "y", "--u", "u", "--arx", "1,1,1", flag, target,
                "-q")
        assert r.exit_code == 0 and target.exists(), (flag, r.output)
    for cmd in ("fit", "export-c", "demo", "fleet"):
        r = run(cmd, "--help")
        assert "--out" in r.stdout and "-o" in r.stdout, cmd
