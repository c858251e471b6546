"""Repr, summary() and to_frame() of every result of adaptid.diagnostics.

The printed statistics and p-values are checked against what R prints:
``format.pval`` (``< 2.2e-16`` below ``.Machine$double.eps``, 4
significant digits in ``print.htest``) and ``format`` (5 significant
digits for the statistic), and against strucchange's documented output for
the Nile data (``sctest(efp(Nile ~ 1, type = "OLS-CUSUM"))`` prints
``S0 = 2.9518, p-value = 5.409e-08``).
"""

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from adaptid.diagnostics import (
    Monitor,
    autocorrelation_test,
    breakpoints,
    change_tests,
    chow,
    cross_correlation_test,
    cusum,
    cusum_squares,
    efp,
    fstats,
    nyblom_hansen,
    recursive_residuals,
)
from adaptid.diagnostics._format import format_num, format_pval, htest_text

REF_DIR = Path(__file__).resolve().parents[1] / "reference" / "strucchange"
REF = json.loads((REF_DIR / "reference.json").read_text())


def _nile():
    y = np.loadtxt(REF_DIR / "Nile.csv", delimiter=",", skiprows=1)[:, 1]
    return np.ones((y.size, 1)), y


@pytest.mark.parametrize("p, text", [
    (1e-20, "< 2.2e-16"),          # below .Machine$double.eps
    (0.0, "< 2.2e-16"),
    (2.220446049250313e-16, "2.22e-16"),   # not below eps: R prints 2.22e-16
    (0.0123441, "0.01234"),        # format.pval(0.0123441, digits = 4)
    (0.5, "0.5"),
    (1.0, "1"),
    (0.0001234, "0.0001234"),      # fixed is no wider than 1.234e-04
    (1.2345e-05, "1.234e-05"),     # scientific is narrower (R's scipen = 0)
    (5.4085534606507224e-08, "5.409e-08"),
    (float("nan"), "NA"),
])
def test_format_pval_as_r(p, text):
    assert format_pval(p) == text


@pytest.mark.parametrize("x, text", [
    (2.9517661026633726, "2.9518"), (75.92976942748543, "75.93"), (1234567.8, "1234568"),
    (100000.0, "1e+05"), (0.0, "0"), (-3.14159, "-3.1416"),
])
def test_format_num_as_r(x, text):
    assert format_num(x) == text


def test_htest_layout_is_print_htest():
    assert htest_text("Chow test", "X, y", [("F", 17.14297)], 7.3483e-05) == \
        "\n\tChow test\n\ndata:  X, y\nF = 17.143, p-value = 7.348e-05\n"
    assert "p-value < 2.2e-16" in htest_text("t", None, [], 1e-300)


def test_nile_ols_cusum_prints_as_strucchange():
    X, y = _nile()
    text = efp(X, y, kind="ols-cusum").summary()
    assert "\tOLS-based CUSUM test\n" in text
    assert "S0 = 2.9518, p-value = 5.409e-08" in text
    # the other statistics of the reference, printed as print.htest would
    chow_text = chow(X, y, 49).summary()
    stat, p = REF["nile.chow50.statistic"][0], REF["nile.chow50.pvalue"][0]
    assert f"F = {format_num(stat)}, p-value = {format_pval(p)}" in chow_text
    assert "F = 17.143, p-value = 7.348e-05" in chow_text
    # strucchange's sctest(Fstats(Nile ~ 1)) prints "sup.F = 75.93, p-value = 2.22e-16":
    # R's 1 - pchisq(...) rounds the tail up to eps; adaptid's tail (1.9e-16) is below it
    assert "\tsupF test\n\ndata:  X, y\nsup.F = 75.93, p-value " in fstats(X, y).summary()
    assert "L = 3.08, p-value = 0.005" in nyblom_hansen(X, y).summary()


def _results():
    rng = np.random.default_rng(0)
    N = 400
    X = np.c_[np.ones(N), rng.standard_normal(N)]
    y = X @ [1.0, 2.0] + np.r_[np.zeros(200), 3 * np.ones(200)] + rng.standard_normal(N)
    w = recursive_residuals(X, y)
    mon = Monitor(X[:200], y[:200])
    mon.run(X[200:], y[200:])
    ct = change_tests(X, y)
    return {
        "efp": efp(X, y, kind="re"), "fstats": fstats(X, y), "ftest": fstats(X, y).test("expF"),
        "chow": chow(X, y, 199), "nyblom": nyblom_hansen(X, y), "breakpoints": breakpoints(X, y),
        "cusum": cusum(w), "cusum_squares": cusum_squares(w), "change_tests": ct,
        "change_test": ct["supF"], "monitor": mon,
        "acf": autocorrelation_test(w, 20), "ccf": cross_correlation_test(X[2:, 1], w, 10),
    }


RESULTS = _results()


@pytest.mark.parametrize("name", sorted(RESULTS))
def test_repr_is_short(name):
    res = RESULTS[name]
    text = repr(res)
    lines = text.splitlines()
    assert len(lines) < 10
    assert max(len(ln) for ln in lines) <= 100
    assert "[[" not in text and "array(" not in text


@pytest.mark.parametrize("name", sorted(RESULTS))
def test_summary_is_text_without_arrays(name):
    text = RESULTS[name].summary()
    assert isinstance(text, str)
    assert "array(" not in text and "[[" not in text
    assert len(text.splitlines()) < 40


@pytest.mark.parametrize("name", sorted(RESULTS))
def test_to_frame_is_a_dataframe(name):
    df = RESULTS[name].to_frame()
    assert isinstance(df, pd.DataFrame)
    assert len(df) >= 1


def test_pvalue_below_eps_prints_as_r():
    ct = RESULTS["change_tests"]
    assert ct["cusum"].pvalue < 2.220446e-16
    assert "p-value < 2.2e-16" in ct["cusum"].summary()
    assert "< 2.2e-16" in ct.summary()
    assert "pvalue<2.2e-16" in repr(ct["cusum"])


def test_to_frame_columns():
    assert list(RESULTS["fstats"].to_frame()["test"]) == ["supF", "aveF", "expF"]
    ct = RESULTS["change_tests"].to_frame()
    assert list(ct.columns) == ["statistic", "pvalue", "reject", "break_index"]
    assert list(ct.index) == list(RESULTS["change_tests"].tests)
    bp = RESULTS["breakpoints"].to_frame()
    assert list(bp.index) == ["break 1"] and bp.loc["break 1", "breakpoint"] == 199
    assert list(RESULTS["efp"].to_frame().columns) == ["test", "statistic", "pvalue", "break_index"]
    f = RESULTS["chow"].to_frame()
    assert f.loc[0, "statistic"] == RESULTS["chow"].statistic


def test_breakpoints_summary_names_the_partition():
    text = RESULTS["breakpoints"].summary()
    assert "Optimal 2-segment partition" in text and "\n199\n" in text


def test_confint_is_a_labelled_table_and_still_the_array():
    X, y = _nile()
    bp = breakpoints(X, y)
    ci = bp.confint()
    # the numbers are unchanged: the same (m, 3) float array strucchange gives minus one
    np.testing.assert_array_equal(np.asarray(ci) + 1,
                                  np.array(REF["nile.breakpoints.confint95"]).reshape(1, 3))
    lo, date, hi = ci[0]
    assert (lo, date, hi) == (24.0, 27.0, 31.0)
    np.testing.assert_array_equal(ci.lower, [24.0])
    np.testing.assert_array_equal(ci.estimate, [27.0])
    np.testing.assert_array_equal(ci.upper, [31.0])
    df = ci.to_frame()
    assert list(df.index) == ["break 1"] and list(df.columns) == ["lower", "estimate", "upper"]
    assert df.loc["break 1", "estimate"] == 27
    assert repr(ci).splitlines() == ["         lower  estimate  upper",
                                     "break 1     24        27     31"]


def test_confint_carries_the_time_axis():
    X, y = _nile()
    years = pd.Index(np.arange(1871, 1971), name="year")
    ci = breakpoints(X, pd.Series(y, index=years)).confint()
    df = ci.to_frame()
    # strucchange: confint(breakpoints(Nile ~ 1)) gives 1895 (1898) 1902
    assert df.loc["break 1"].tolist() == [1895, 1898, 1902]
    np.testing.assert_array_equal(np.asarray(ci), np.asarray(breakpoints(X, y).confint()))
