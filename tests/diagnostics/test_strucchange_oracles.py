"""Structural-change tests against independent oracles.

* statsmodels: ``breaks_cusumolsresid`` (OLS-CUSUM statistic, Kolmogorov
  p-value) and ``breaks_hansen`` (Nyblom-Hansen L_c);
* ruptures ``Dynp(model="linear", jump=1)``: the exact least-squares
  segmentation for a given number of breaks;
* brute force over every admissible set of break dates (small N) with
  ``numpy.linalg.lstsq`` per segment;
* textbook re-computations with ``lstsq`` (Chow F per candidate, recursive
  and moving estimates with ``scipy.linalg.sqrtm``);
* closed forms of the limit laws (scipy's Kolmogorov distribution; chi²
  at Hansen's tau = 0.5).
"""

import itertools

import numpy as np
import pytest
import scipy.linalg
from scipy.stats import chi2, f as f_dist, kstwobign

from adaptid.diagnostics import (
    BreakConfidenceWarning,
    Monitor,
    breakpoints,
    change_tests,
    chow,
    efp,
    fstats,
    nyblom_hansen,
)
from adaptid.diagnostics._pvalues import pvalue_efp, pvalue_fstats


def _regression(N, seed, *, shift=None):
    rng = np.random.default_rng(seed)
    x = rng.standard_normal(N)
    X = np.column_stack([np.ones(N), x])
    y = 0.5 + 1.0 * x + 0.7 * rng.standard_normal(N)
    if shift is not None:
        at, d = shift
        y[at:] += d[0] + d[1] * x[at:]
    return X, y


def _rss(X, y):
    r = y - X @ np.linalg.lstsq(X, y, rcond=None)[0]
    return float(r @ r)


# ---------------------------------------------------------------- statsmodels
def test_ols_cusum_equals_statsmodels_breaks_cusumolsresid():
    import statsmodels.api as sm
    from statsmodels.stats.diagnostic import breaks_cusumolsresid

    X, y = _regression(150, 1, shift=(90, (0.6, 0.0)))
    e = sm.OLS(y, X).fit().resid
    stat, pval, _ = breaks_cusumolsresid(e, ddof=X.shape[1])
    p = efp(X, y, kind="ols-cusum")
    # same statistic (residuals have mean zero with an intercept: sd == RSS/(N-n))
    assert p.statistic == pytest.approx(stat, rel=1e-12)
    # strucchange's 100-term Kolmogorov series == scipy's kstwobign
    assert p.pvalue == pytest.approx(pval, rel=1e-9, abs=1e-15)


def test_nyblom_hansen_equals_statsmodels_breaks_hansen():
    import statsmodels.api as sm
    from statsmodels.stats.diagnostic import breaks_hansen

    for seed, shift in ((2, None), (3, (60, (0.0, 0.8)))):
        X, y = _regression(120, seed, shift=shift)
        h, _ = breaks_hansen(sm.OLS(y, X).fit())
        assert nyblom_hansen(X, y).statistic == pytest.approx(h, rel=1e-10)


# ---------------------------------------------------------------- ruptures
@pytest.mark.parametrize("m", [1, 2, 3])
def test_breakpoints_equal_ruptures_dynp_linear(m):
    import ruptures as rpt

    X, y = _regression(120, 4, shift=(50, (1.0, 0.5)))
    y[85:] -= 1.2
    h = 15
    bp = breakpoints(X, y, h=h)
    ends = rpt.Dynp(model="linear", min_size=h, jump=1).fit(np.column_stack([y, X])).predict(n_bkps=m)
    np.testing.assert_array_equal(bp.breakpoints_for(m), np.array(ends[:-1]) - 1)
    edges = [0] + list(ends)
    rss = sum(_rss(X[a:b], y[a:b]) for a, b in zip(edges[:-1], edges[1:]))
    assert bp.rss[m] == pytest.approx(rss, rel=1e-10)


# ---------------------------------------------------------------- brute force
@pytest.mark.parametrize("seed", [5, 6])
def test_breakpoints_equal_brute_force_over_all_dates(seed):
    N, h = 36, 5
    X, y = _regression(N, seed, shift=(14, (0.8, -0.6)))
    bp = breakpoints(X, y, h=h)
    assert bp.max_breaks == int(np.ceil(N / h)) - 2
    assert bp.rss[0] == pytest.approx(_rss(X, y), rel=1e-12)
    for m in range(1, 4):
        best, arg = np.inf, None
        for cut in itertools.combinations(range(h - 1, N - h), m):   # last index of each segment
            edges = (0,) + tuple(c + 1 for c in cut) + (N,)
            if min(np.diff(edges)) < h:
                continue
            s = sum(_rss(X[a:b], y[a:b]) for a, b in zip(edges[:-1], edges[1:]))
            if s < best:
                best, arg = s, cut
        assert bp.rss[m] == pytest.approx(best, rel=1e-10)
        np.testing.assert_array_equal(bp.breakpoints_for(m), arg)
    # criteria from the RSS (strucchange's BIC; LWZ of Bai & Perron 2003, sec. 5.1)
    m = np.arange(bp.rss.size)
    np.testing.assert_allclose(bp.bic, N * (np.log(bp.rss) + 1 - np.log(N) + np.log(2 * np.pi))
                               + np.log(N) * 3 * (m + 1), rtol=1e-14)
    p = (m + 1) * 2 + m
    np.testing.assert_allclose(bp.lwz, np.log(bp.rss / (N - p)) + p * 0.299 / N * np.log(N) ** 2.1,
                               rtol=1e-14)
    assert bp.n_breaks == int(np.argmin(bp.bic))


def test_segment_coefficients_are_segment_lstsq():
    X, y = _regression(100, 7, shift=(40, (2.0, 1.0)))
    bp = breakpoints(X, y)
    assert bp.n_breaks >= 1
    edges = np.r_[0, bp.breakpoints + 1, 100]
    for row, (a, b) in zip(bp.coef(), zip(edges[:-1], edges[1:])):
        np.testing.assert_allclose(row, np.linalg.lstsq(X[a:b], y[a:b], rcond=None)[0], rtol=1e-12)


# ---------------------------------------------------------------- textbook forms
def test_fstats_equal_chow_f_by_lstsq_at_every_candidate():
    X, y = _regression(80, 8, shift=(50, (0.0, 1.0)))
    N, n = X.shape
    fs = fstats(X, y, trim=0.2)
    assert fs.candidates[0] == 16 - 1 and fs.candidates[-1] == 80 - 16 - 1
    S = _rss(X, y)
    for j, c in enumerate(fs.candidates):
        u = _rss(X[:c + 1], y[:c + 1]) + _rss(X[c + 1:], y[c + 1:])
        assert fs.F[j] == pytest.approx((S - u) / (u / (N - 2 * n)), rel=1e-10)
        if j % 10 == 0:
            ch = chow(X, y, int(c))
            assert ch.statistic == pytest.approx(fs.F[j] / n, rel=1e-10)
            assert ch.pvalue == pytest.approx(f_dist.sf(fs.F[j] / n, n, N - 2 * n), rel=1e-9)
    # expF: log mean exp(F/2), overflow-free
    assert fs.test("expF").statistic == pytest.approx(np.log(np.mean(np.exp(fs.F / 2))), rel=1e-12)
    assert fs.test("aveF").statistic == pytest.approx(np.mean(fs.F), rel=1e-14)


def test_re_and_me_processes_equal_lstsq_and_sqrtm():
    X, y = _regression(60, 9)
    N, n = X.shape
    theta = np.linalg.lstsq(X, y, rcond=None)[0]
    e = y - X @ theta
    sigma = np.sqrt(e @ e / (N - n))
    re = efp(X, y, kind="re")
    for i in (n, 10, 37, N - 1):                  # prefix length i
        th = np.linalg.lstsq(X[:i], y[:i], rcond=None)[0]
        Q = np.real(scipy.linalg.sqrtm(X[:i].T @ X[:i])) / (sigma * np.sqrt(i))
        np.testing.assert_allclose(re.process[i - n + 1], i / np.sqrt(N) * Q @ (th - theta),
                                   rtol=1e-8, atol=1e-12)
    me = efp(X, y, kind="me", h=0.25)
    nh = 15
    for i in (0, 20, N - nh):
        th = np.linalg.lstsq(X[i:i + nh], y[i:i + nh], rcond=None)[0]
        Q = np.real(scipy.linalg.sqrtm(X[i:i + nh].T @ X[i:i + nh])) / (sigma * np.sqrt(nh))
        np.testing.assert_allclose(me.process[i], nh / np.sqrt(N) * Q @ (th - theta),
                                   rtol=1e-8, atol=1e-12)


def test_limit_law_p_values_against_closed_forms():
    for x in (0.5, 1.0, 1.36, 2.0):
        assert pvalue_efp(x, "Brownian bridge", k=1) == pytest.approx(kstwobign.sf(x), rel=1e-10)
        # k independent bridges: 1 - (1 - p)^k
        p1 = kstwobign.sf(x)
        assert pvalue_efp(x, "Brownian bridge", k=3) == pytest.approx(1 - (1 - p1) ** 3, rel=1e-10)
    # Brown-Durbin-Evans: a = 0.948 is the 5 % critical value of the rec-CUSUM lines
    assert pvalue_efp(0.948, "Brownian motion", k=1) == pytest.approx(0.05, abs=2e-4)
    # Hansen (1997): at tau = 0.5 (lambda = 1) the supF law is chi2(k)
    assert pvalue_fstats(7.0, "supF", 2, 1.0) == pytest.approx(chi2.sf(7.0, 2), rel=1e-14)
    # between tabulated trimmings the p-value is interpolated: it lies between its neighbours'
    lam = lambda tau: ((1 - tau) / tau) ** 2          # noqa: E731 - tau = 1 / (1 + sqrt(lam))
    p = [pvalue_fstats(9.0, "supF", 2, lam(t)) for t in (0.14, 0.145, 0.15)]
    assert p[0] > p[1] > p[2]


# ---------------------------------------------------------------- Monitor
@pytest.mark.parametrize("kind", ["ols-cusum", "me"])
def test_monitor_update_equals_run_and_detects_a_change(kind):
    X, y = _regression(400, 10, shift=(250, (1.0, 0.0)))
    a = Monitor(X[:100], y[:100], kind=kind, horizon=4)
    alarm = a.run(X[100:], y[100:])
    b = Monitor(X[:100], y[:100], kind=kind, horizon=4)
    for k in range(100, 400):
        b.update(X[k], y[k])
    assert alarm == b.alarm and alarm is not None and 250 <= alarm < 330
    np.testing.assert_allclose(b.process, a.process, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(b.boundary, a.boundary_at(np.arange(101, 401)), rtol=1e-15)
    c = Monitor(X[:100], y[:100], kind=kind, horizon=4)
    c.run(X[100:180], y[100:180])
    assert c.run(X[180:], y[180:]) == alarm              # chunked == one call


def test_monitor_no_alarm_without_change_and_cusum_boundary_formula():
    X, y = _regression(300, 11)
    mon = Monitor(X[:100], y[:100])
    assert mon.run(X[100:], y[100:]) is None and mon.n_seen == 300
    # Chu, Stinchcombe & White (1996): c solves 2 - 2(Phi(c) - c phi(c)) = alpha
    from scipy.stats import norm

    c = mon.critical_value
    assert 2 - 2 * (norm.cdf(c) - c * norm.pdf(c)) == pytest.approx(0.05, rel=1e-10)
    t = np.arange(101, 301) / 100
    np.testing.assert_allclose(mon.boundary, np.sqrt(t * (t - 1) * (c * c + np.log(t / (t - 1)))))


# ---------------------------------------------------------------- API
def test_change_tests_verdict_and_dict():
    X, y = _regression(200, 12)
    ct = change_tests(X, y)
    assert set(ct.tests) == {"cusum", "cusum2", "supF", "re", "nyblom"}
    assert ct.no_change == (not any(t.reject for t in ct.tests.values()))
    d = ct.to_dict()
    assert d["no_change"] == ct.no_change and d["tests"]["supF"]["pvalue"] == ct["supF"].pvalue
    assert ct["supF"].pvalue == fstats(X, y).test("supF").pvalue


def test_confint_widens_with_level_and_warns_when_undefined():
    X, y = _regression(60, 13, shift=(30, (3.0, 0.0)))
    bp = breakpoints(X, y, h=10)
    ci = bp.confint(m=1)
    assert ci[0, 0] <= ci[0, 1] <= ci[0, 2]
    wide = bp.confint(0.9999, m=1)
    assert wide[0, 0] <= ci[0, 0] and wide[0, 2] >= ci[0, 2]
    # strucchange refuses (and warns) when P(argmax V <= 0) is outside
    # [(1 - level)/2, (1 + level)/2]: with heterogeneous segments this
    # probability is not exactly 1/2, so a 0.1 % "interval" is refused
    with pytest.warns(BreakConfidenceWarning, match="cannot be computed"):
        tiny = bp.confint(0.001, m=1)
    assert np.isnan(tiny[0, 0]) and np.isnan(tiny[0, 2]) and tiny[0, 1] == ci[0, 1]


@pytest.mark.parametrize("call, exc, match", [
    (lambda: efp(np.ones(20), np.ones(20), kind="cusum"), ValueError, "kind must be one of"),
    (lambda: efp(np.ones(20), np.arange(20.0), kind="me", h=1.5), ValueError, r"h must be in \(0.0, 1.0\)"),
    (lambda: efp(np.ones((20, 2)), np.arange(20.0), kind="re"), ValueError, "X must be of full column rank 2"),
    (lambda: efp(np.ones(20), np.arange(19.0), kind="re"), ValueError, r"y must be of shape \(20,\)"),
    (lambda: fstats(np.ones(20), np.arange(20.0), trim=0.6), ValueError, r"trim must be in \(0.0, 0.5\)"),
    (lambda: chow(np.ones(20), np.arange(20.0), 19), ValueError, "at must be an integer <= 17"),
    (lambda: breakpoints(np.ones(20), np.arange(20.0), h=1), ValueError, "h must be a minimal segment of more than n"),
    (lambda: breakpoints(np.ones(20), np.arange(20.0), h=11), ValueError, "at most N/2"),
    (lambda: breakpoints(np.ones(20), np.arange(20.0), h=5, max_breaks=9), ValueError, "max_breaks must be an integer <= 2"),
    (lambda: Monitor(np.ones(20), np.arange(20.0), kind="re"), ValueError, "kind must be one of 'ols-cusum', 'me'"),
    (lambda: Monitor(np.ones(20), np.arange(20.0), kind="me", horizon=5), ValueError, "horizon must be one of 2, 4"),
    (lambda: Monitor(np.ones(20), np.arange(20.0), kind="me", h=0.3), ValueError, "h must be one of 0.25"),
    (lambda: Monitor(np.ones(20), np.arange(20.0)).run(np.ones((3, 2)), np.ones(3)), ValueError, r"X must be of shape \(m, 1\)"),
])
def test_argument_errors(call, exc, match):
    with pytest.raises(exc, match=match):
        call()


def test_plots(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    X, y = _regression(120, 14, shift=(70, (1.0, 0.0)))
    from matplotlib.figure import Figure

    def labelled(fig):
        """Every line labelled; the legend outside the data area (issue 33, point 5)."""
        assert isinstance(fig, Figure)
        for ax in fig.axes:
            assert all(not ln.get_label().startswith("_") for ln in ax.lines), ax.lines
        legends = [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
        assert len(legends) == 1
        fig.canvas.draw()
        box, area = legends[0].get_window_extent(), fig.axes[0].get_window_extent()
        assert box.x0 >= area.x1  # right of the plot: never over the data
        return fig.axes[0]

    for kind in ("rec-cusum", "ols-cusum", "re", "me"):
        assert labelled(efp(X, y, kind=kind).plot()).lines
    assert len(labelled(fstats(X, y).plot()).lines) == 3
    labelled(breakpoints(X, y).plot())
    mon = Monitor(X[:40], y[:40])
    mon.run(X[40:], y[40:])
    labelled(mon.plot()).figure.savefig(tmp_path / "m.png")
    _, ax = plt.subplots()
    assert efp(X, y, kind="ols-cusum").plot(ax=ax) is ax.figure  # drawing into given Axes
    plt.close("all")


def test_monitor_reset_example_detects_the_jump_once():
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[2] / "examples" / "monitor_reset.py"
    spec = importlib.util.spec_from_file_location("monitor_reset_example", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    alarms = mod.main(["--no-plot"])
    # the slope of a zero-mean regressor jumps at sample 3000: one alarm, soon after
    assert len(alarms) == 1 and 3000 <= alarms[0] < 3150


def test_structural_change_page_code_runs():
    # docs/structural_change.md: its python blocks run in order as one script
    # (the same rule as tests/test_docs.py for the other pages)
    import re
    from pathlib import Path

    import matplotlib

    matplotlib.use("Agg")
    page = Path(__file__).resolve().parents[2] / "docs" / "structural_change.md"
    blocks = re.findall(r"^```python\n(.*?)^```", page.read_text(encoding="utf-8"), re.S | re.M)
    assert blocks
    ns = {"__name__": "docs_structural_change"}
    for i, code in enumerate(blocks):
        exec(compile(code, f"structural_change.md[block {i}]", "exec"), ns)


def test_cusum_squares_asymptotic_p_value_agrees_with_edgerton_wells_band():
    # the Edgerton-Wells band's leading term is the Kolmogorov quantile: crossing the
    # 5 % band <=> asymptotic p-value below 0.05, away from the edge; at m = 398 EW's
    # finite-sample terms put the band at an asymptotic p of 0.066, hence the margin
    # (0.05 - 0.02, 0.05 + 0.02) where the two may disagree
    from adaptid.diagnostics import cusum_squares, recursive_residuals

    rng = np.random.default_rng(20)
    agree = 0
    for _ in range(60):
        X, y = _regression(400, int(rng.integers(1 << 30)))
        y[200:] += rng.uniform(0, 0.3) * rng.standard_normal(200)   # variance change of random size
        ct = change_tests(X, y)
        cs = cusum_squares(recursive_residuals(X, y))
        assert ct["cusum2"].reject == cs.crossed
        p = ct["cusum2"].pvalue
        if abs(p - 0.05) > 0.02:
            agree += (p < 0.05) == cs.crossed
        else:
            agree += 1
    assert agree == 60


def test_breakpoints_benchmark_runs_and_agrees_with_ruptures(tmp_path):
    # smoke run of benchmarks/bench_breakpoints.py (speed is never asserted):
    # it must find ruptures' segmentation, which it checks itself
    import json
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    out = tmp_path / "bp.json"
    env = dict(os.environ, PYTHONPATH=str(root / "src"))
    proc = subprocess.run([sys.executable, str(root / "benchmarks" / "bench_breakpoints.py"),
                           "--n", "200", "--repeat", "1", "--json", str(out)],
                          capture_output=True, text=True, timeout=300, env=env)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    res = json.loads(out.read_text())
    assert res["same"] is True and res["N"] == 200 and res["m"] >= 1
