"""adaptid.io (the one table reader/writer of the CLI and the fleet) and adaptid.plot (the
report's figures as public functions), checked against pandas / numpy / the data drawn."""

import numpy as np
import pandas as pd
import pytest

import adaptid
from adaptid import io as aio
from adaptid._exceptions import DataFileError

import pyarrow  # noqa: E402,F401 - the test extra installs it (missing: a failure)


def test_read_frame_equals_pandas(tmp_path):
    rng = np.random.default_rng(0)
    df = pd.DataFrame({"device": np.repeat([1, 2], 5), "x": rng.standard_normal(10),
                       "flag": rng.integers(0, 2, 10).astype(bool)})
    for name, write in (("t.csv", lambda p: df.to_csv(p, index=False, float_format="%.17g")),
                        ("t.parquet", lambda p: df.to_parquet(p, index=False))):
        p = tmp_path / name
        write(p)
        got = aio.read_frame(p)
        # pandas' own reader is the oracle (float text round-trips exactly with %.17g)
        want = pd.read_csv(p) if name.endswith(".csv") else pd.read_parquet(p)
        np.testing.assert_array_equal(got["x"].to_numpy(float), want["x"].to_numpy(float))
        np.testing.assert_array_equal(got["device"].to_numpy(), want["device"].to_numpy())
    p = tmp_path / "t.npz"
    np.savez(p, x=df["x"].to_numpy(), X=np.ones((10, 2)))
    got = aio.read_frame(p)
    assert list(got.columns) == ["x", "X[0]", "X[1]"]
    np.testing.assert_array_equal(got["x"].to_numpy(), df["x"].to_numpy())


def test_write_table_is_atomic_and_typed(tmp_path):
    df = pd.DataFrame({"a": [1.0, 2.0]}, index=pd.Index([7, 8], name="device"))
    out = tmp_path / "r.csv"
    out.write_text("old")
    aio.write_table(df, out)
    pd.testing.assert_frame_equal(pd.read_csv(out, index_col=0), df)
    assert not list(tmp_path.glob(".*.tmp"))                 # no temporary left behind
    with pytest.raises(DataFileError, match="r.xlsx"):
        aio.write_table(df, tmp_path / "r.xlsx")
    with pytest.raises(DataFileError, match="does not exist"):
        aio.write_table(df, tmp_path / "no" / "r.csv")


def test_exceptions_live_in_one_module():
    # The library's exceptions in adaptid._exceptions; the command line's CLIError in cli/.
    from adaptid import _exceptions as ex
    from adaptid.cli._errors import CLIError
    from adaptid.constrained import IllConditionedWarning, InfeasibleError
    assert CLIError.__module__ == "adaptid.cli._errors" and not hasattr(ex, "CLIError")
    assert CLIError.exit_code == 2 and str(CLIError("a\n  b")) == "a b"
    assert InfeasibleError is ex.InfeasibleError
    assert IllConditionedWarning is ex.IllConditionedWarning
    assert issubclass(ex.IllConditionedWarning, adaptid.AdaptidWarning)
    assert issubclass(ex.DataFileError, ValueError)


# -------------------------------------------------------------------------- plot
def test_tracks_band_is_two_sigma():
    import matplotlib  # noqa: F401 - installed by the test extra
    from adaptid import plot
    x = np.arange(1.0, 101.0)
    theta = np.column_stack([np.sin(x / 10), np.cos(x / 10)])
    at = np.array([9, 49, 99])
    band = np.array([[0.1, 0.2], [0.05, 0.1], [0.01, 0.02]])
    fig = plot.tracks(x, theta, ["a", "b"], band=band, band_at=at, label="rls")
    axes = [a for a in fig.axes if a.get_visible()]
    assert [a.get_title(loc="left") for a in axes] == ["a", "b"]
    for j, ax in enumerate(axes):
        line = ax.get_lines()[0]
        np.testing.assert_array_equal(line.get_ydata(), theta[:, j])
        poly = ax.collections[0].get_paths()[0].vertices
        # fill_between's outline holds theta ± 2σ at the band rows (drawn values: exact)
        for k, r in enumerate(at):
            ys = poly[np.isclose(poly[:, 0], x[r]), 1]
            np.testing.assert_allclose(sorted(set(np.round(ys, 12))),
                                       [theta[r, j] - 2 * band[k, j], theta[r, j] + 2 * band[k, j]],
                                       rtol=0, atol=1e-12)


def test_prediction_errors_and_cusum_figures():
    import matplotlib  # noqa: F401 - installed by the test extra
    from adaptid import plot
    from adaptid.diagnostics import cusum
    e = np.random.default_rng(1).standard_normal(300)
    fig = plot.prediction_errors(np.arange(300.0), e, label="rls", title="errors")
    np.testing.assert_array_equal(fig.axes[0].get_lines()[0].get_ydata(), e)
    res = cusum(e)
    fig = plot.cusum(np.arange(300.0), res, title="eq")
    lines = fig.axes[0].get_lines()
    np.testing.assert_array_equal(lines[0].get_ydata(), res.statistic)
    np.testing.assert_array_equal(lines[1].get_ydata(), res.upper)
    assert fig.axes[0].get_title(loc="left").startswith("eq: ")
