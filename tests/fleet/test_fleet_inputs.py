"""Fleet inputs (issue 14): any numeric dtype mix, pandas nullable dtypes and read-only
arrays give the same result as the same data in float64; time columns numeric, datetime64
(naive and tz-aware) and timedelta; NaT is NaN under the NaN policy; string times refused.

The oracle of every case is fleet.identify on the same values cast to float64 by numpy
(int → float64 and float32 → float64 are exact, so the results must be equal bit for bit).
"""

import numpy as np
import pandas as pd
import pytest

from adaptid import fleet

PHI = ["i", "di_dt", "omega", "sign_i"]

import dask.dataframe  # noqa: E402,F401 - the test extra installs it (missing: a failure)


@pytest.fixture(scope="module")
def base():
    """Three devices, values exactly representable in int64 and float32 (small integers
    and halves), time in integer seconds, rows in sorted order."""
    rng = np.random.default_rng(3)
    G, N = 3, 120
    rows = []
    for g in range(G):
        X = rng.integers(-8, 9, size=(N, 4)).astype(float)
        X[:, 3] = np.sign(X[:, 3]) + (X[:, 3] == 0)
        theta = np.array([2.0, 0.5, 1.5, -1.0]) + g
        v = X @ theta + rng.integers(-2, 3, size=N) * 0.5
        rows.append(pd.DataFrame({"device": g, "time": np.arange(N), **dict(zip(PHI, X.T)),
                                  "v": v}))
    return pd.concat(rows, ignore_index=True)


def ident(df, **kw):
    kw.setdefault("time", "time")
    return fleet.identify(df, group="device", y="v", phi=PHI, **kw)


@pytest.fixture(scope="module")
def ref(base):
    return ident(base)


def same(res, ref):
    cols = PHI + [f"stderr_{p}" for p in PHI] + ["sigma2", "n_samples", "change_stat"]
    pd.testing.assert_frame_equal(res[cols], ref[cols], check_exact=True, check_index_type=False)


@pytest.mark.parametrize("dtypes", [
    {"i": "int64"}, {"di_dt": "float32"}, {"i": "int32", "omega": "float32", "sign_i": "int8"},
    {"v": "float32"}, {"i": "int16", "di_dt": "float32"},
])
def test_numeric_dtype_mix(base, ref, dtypes):
    df = base.copy()
    for c, dt in dtypes.items():
        df[c] = df[c].astype(dt)
        assert (df[c].astype(float) == base[c]).all()   # exact values in the new dtype
    same(ident(df), ref)


@pytest.mark.parametrize("dtype", ["Int64", "Float64", "boolean"])
def test_pandas_nullable_dtypes(base, ref, dtype):
    df = base.copy()
    if dtype == "boolean":  # a 0/1 regressor: compare with the same column as float64
        df["sign_i"] = df["sign_i"] > 0
        want = base.copy()
        want["sign_i"] = (base["sign_i"] > 0).astype(float)
        expect = ident(want)
        df["sign_i"] = df["sign_i"].astype("boolean")
    else:
        expect = ref
        df["i"] = df["i"].astype(dtype)
        df["v"] = df["v"].astype("Float64")
    same(ident(df), expect)


def test_nullable_na_is_nan(base):
    """pd.NA in a nullable column is a missing value: skipped as NaN is, under nan_policy."""
    df = base.copy()
    df["i"] = df["i"].astype("Int64")
    df.loc[5, "i"] = pd.NA
    with pytest.raises(ValueError, match="group 0"):
        ident(df)
    want = base.copy()
    want.loc[5, "i"] = np.nan
    same(ident(df, nan_policy="skip"), ident(want, nan_policy="skip"))


def test_read_only_arrays(base, ref):
    cols = {}
    for c in base.columns:
        a = base[c].to_numpy().copy()
        a.flags.writeable = False
        cols[c] = a
    df = pd.DataFrame(cols, copy=False)
    same(ident(df), ref)


@pytest.mark.parametrize("kind", ["float", "datetime", "datetime-tz", "timedelta", "int32"])
def test_time_column_kinds(base, ref, kind):
    df = base.copy()
    t = base["time"]
    if kind == "float":
        df["time"] = t.astype(float) * 0.001
    elif kind == "datetime":
        df["time"] = pd.Timestamp("2024-01-01") + pd.to_timedelta(t, unit="s")
    elif kind == "datetime-tz":
        df["time"] = pd.Timestamp("2024-03-31 00:59", tz="Europe/Berlin") + pd.to_timedelta(t, unit="min")
    elif kind == "timedelta":
        df["time"] = pd.to_timedelta(t, unit="ms")
    else:
        df["time"] = t.astype("int32")
    shuffled = df.sample(frac=1.0, random_state=1)  # identify must sort by the time column
    same(ident(shuffled), ref)


def test_nat_is_nan_under_the_policy(base):
    df = base.copy()
    df["time"] = pd.Timestamp("2024-01-01") + pd.to_timedelta(df["time"], unit="s")
    df.loc[7, "time"] = pd.NaT
    with pytest.raises(ValueError, match="time"):
        ident(df)
    # with nan_policy="skip" the row with the missing time is skipped, like a NaN time
    res = ident(df, nan_policy="skip")
    want = ident(base.drop(index=7), nan_policy="skip")
    same(res, want)
    ft = base.copy()
    ft["time"] = ft["time"].astype(float)
    ft.loc[7, "time"] = np.nan
    same(ident(ft, nan_policy="skip"), want)


def test_string_time_refused(base):
    df = base.copy()
    df["time"] = df["time"].astype(str)
    with pytest.raises(ValueError, match="time.*'time'"):
        ident(df)


@pytest.mark.parametrize("suffix", [".csv", ".npz"])
def test_cli_fleet_reads_through_adaptid_io(base, ref, tmp_path, suffix):
    """`adaptid fleet` on a file of integer regressors (and ISO times in the CSV) equals
    identify on the float64 frame: the file goes through adaptid.io like `adaptid fit`'s."""
    import json

    from typer.testing import CliRunner

    from adaptid.cli._app import app
    df = base.copy()
    df["i"] = df["i"].astype("int64")
    path = tmp_path / f"f{suffix}"
    if suffix == ".csv":
        df["time"] = (pd.Timestamp("2024-01-01") + pd.to_timedelta(df["time"], unit="s")
                      ).dt.strftime("%Y-%m-%dT%H:%M:%S")
        df.to_csv(path, index=False, float_format="%.17g")
    else:
        np.savez(path, **{c: df[c].to_numpy() for c in df.columns})
    r = CliRunner().invoke(app, ["fleet", str(path), "--group", "device", "--time", "time",
                                 "--y", "v", "--phi", ",".join(PHI), "--json"])
    assert r.exit_code == 0, r.output
    got = pd.DataFrame(json.loads(r.stdout)["devices"]).set_index("device")
    np.testing.assert_array_equal(got[PHI].to_numpy(), ref[PHI].to_numpy())
    se = [f"stderr_{p}" for p in PHI]
    np.testing.assert_array_equal(got[se].to_numpy(), ref[se].to_numpy())
