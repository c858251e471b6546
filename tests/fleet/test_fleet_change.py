"""The fleet's change tests (issue 17, point 7): power against coefficient
changes, break dates, and control across devices.

Oracles: adaptid.diagnostics' own tests on each device's data (themselves
checked against R strucchange), statsmodels' ``multipletests(method="fdr_bh")``
for Benjamini–Hochberg, and simulated devices with a known break.
"""

import json

import numpy as np
import pandas as pd
import pytest
from statsmodels.stats.multitest import multipletests

from adaptid import diagnostics, fleet
from adaptid.fleet._changes import _benjamini_hochberg

N = 600
JUMP_AT = 300          # the coefficient of x1 changes from sample 300 on
JUMPING = (2, 5)       # the devices with the change


def _fleet(seed=0, n_devices=8):
    rng = np.random.default_rng(seed)
    frames = []
    for d in range(n_devices):
        X = rng.standard_normal((N, 3))  # zero-mean regressors: rec-CUSUM is blind here
        theta = np.array([2.0, 1.0, -1.0])
        y = X @ theta + 0.2 * rng.standard_normal(N)
        if d in JUMPING:
            y[JUMP_AT:] += 0.5 * X[JUMP_AT:, 0]
        frames.append(pd.DataFrame({"dev": d, "t": np.arange(N) * 0.01, "y": y,
                                    "x1": X[:, 0], "x2": X[:, 1], "x3": X[:, 2]}))
    return pd.concat(frames, ignore_index=True)


@pytest.fixture(scope="module")
def df():
    return _fleet()


def _identify(df, **kw):
    return fleet.identify(df, group="dev", time="t", y="y", phi=["x1", "x2", "x3"], **kw)


def test_default_supF_flags_the_coefficient_changes_and_dates_them(df):
    res = _identify(df)
    assert sorted(res.index[res["change"]]) == list(JUMPING)
    # the break is after sample JUMP_AT - 1 (0-based), reported in time units
    at = res.loc[list(JUMPING), "change_at"].to_numpy()
    assert np.all(np.abs(at / 0.01 - (JUMP_AT - 1)) <= 5)
    assert res.loc[~res["change"], "change_at"].isna().all()


def test_the_bde_cusum_of_the_errors_misses_them(df):
    """The motivation: the old default sees no change in a zero-mean regressor."""
    res = _identify(df, change_test="a-priori")
    assert not res.loc[list(JUMPING), "change"].any()


@pytest.mark.parametrize("kind", ["supF", "re", "cusum", "cusum2"])
def test_per_device_pvalues_are_the_diagnostics_tests(df, kind):
    res = _identify(df, change_test=kind, multiple="none")
    for d in (0, 2):
        g = df[df["dev"] == d]
        t = diagnostics.change_tests(g[["x1", "x2", "x3"]].to_numpy(), g["y"].to_numpy(),
                                     tests=(kind,))[kind]
        assert res.loc[d, "change_stat"] == pytest.approx(t.statistic, rel=1e-12)
        assert res.loc[d, "change_pvalue"] == pytest.approx(t.pvalue, rel=1e-9, abs=1e-300)


def test_benjamini_hochberg_equals_statsmodels():
    rng = np.random.default_rng(4)
    for _ in range(20):
        p = np.concatenate([rng.uniform(size=40), rng.uniform(0, 0.003, size=rng.integers(0, 8))])
        rng.shuffle(p)
        want = multipletests(p, alpha=0.05, method="fdr_bh")[0]
        np.testing.assert_array_equal(_benjamini_hochberg(p, 0.05), want)
    assert not _benjamini_hochberg(np.array([np.nan, 0.5]), 0.05).any()


def test_multiple_testing_modes(df):
    p = _identify(df, multiple="none")["change_pvalue"].to_numpy()
    bonf = _identify(df, multiple="bonferroni")["change"].to_numpy()
    np.testing.assert_array_equal(bonf, p <= 0.05 / len(p))
    bh = _identify(df, multiple="bh")["change"].to_numpy()
    np.testing.assert_array_equal(bh, multipletests(p, 0.05, method="fdr_bh")[0])


def test_size_under_no_change_is_controlled():
    """30 healthy devices: BH at 5 % flags none in this draw (each device's supF
    is at its nominal size; tests/diagnostics/test_strucchange_mc.py checks the size)."""
    healthy = _fleet(seed=7, n_devices=30)
    healthy = healthy[~healthy["dev"].isin(JUMPING)]
    assert not _identify(healthy)["change"].any()


def test_cli_fleet_change_test(tmp_path, df):
    from typer.testing import CliRunner

    from adaptid.cli._app import app
    path = tmp_path / "fleet.csv"
    df.to_csv(path, index=False)
    r = CliRunner().invoke(app, ["fleet", str(path), "--group", "dev", "--time", "t", "--y", "y",
                                 "--phi", "x1,x2,x3", "--change-test", "supF", "--json"])
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    assert out["n_flagged"] == len(JUMPING)
    flagged = {d["dev"]: d["change_at"] for d in out["devices"] if d["change"]}
    assert sorted(flagged) == list(JUMPING)
    bad = CliRunner().invoke(app, ["fleet", str(path), "--group", "dev", "--y", "y",
                                   "--phi", "x1", "--change-test", "nope"])
    assert bad.exit_code == 2 and "--change-test" in bad.output
