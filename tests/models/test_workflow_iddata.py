"""adaptid.IDData (issue 15, point 1): detrend against scipy.signal.detrend,
split / slicing / to_frame / plot, and the data sets that return it."""

import numpy as np
import pandas as pd
import pytest
from scipy import signal

import adaptid
from adaptid import IDData
from adaptid.datasets import load_daisy, load_emps


@pytest.fixture
def record(rng):
    N = 200
    k = np.arange(N)
    y = np.column_stack([3.0 + 0.02 * k + rng.standard_normal(N), -1.0 + rng.standard_normal(N)])
    u = 5.0 - 0.01 * k + rng.standard_normal(N)
    return IDData(y, u, dt=0.1, y_names=["temp", "flow"], u_names="power")


def test_public_names():
    assert adaptid.IDData is adaptid.models.IDData is IDData
    assert "IDData" in adaptid.__all__


def test_shapes_names_and_time(record):
    assert len(record) == 200 and record.n_outputs == 2 and record.n_inputs == 1
    assert record.y.shape == (200, 2) and record.u.shape == (200,)
    assert record.y_names == ("temp", "flow") and record.u_names == ("power",)
    assert record.time is None
    np.testing.assert_allclose(record.t, 0.1 * np.arange(200))
    d = IDData(np.ones(5))
    assert d.u is None and d.n_inputs == 0 and d.y_names == ("y",) and d.dt == 1.0
    d2 = IDData(np.ones((5, 2)), np.ones((5, 3)))
    assert d2.y_names == ("y1", "y2") and d2.u_names == ("u1", "u2", "u3")


@pytest.mark.parametrize("kind", ["constant", "linear"])
def test_detrend_equals_scipy(record, kind):
    dd = record.detrend(kind)
    # oracle: scipy.signal.detrend along the samples, column by column
    np.testing.assert_allclose(dd.outputs, signal.detrend(record.outputs, axis=0, type=kind),
                               atol=1e-12)
    np.testing.assert_allclose(dd.u, signal.detrend(record.u, type=kind), atol=1e-12)
    # what was removed is kept: data = detrended + trend, and retrend adds it back
    np.testing.assert_allclose(dd.outputs + dd.y_trend, record.outputs, atol=1e-12)
    np.testing.assert_allclose(dd.u + dd.u_trend[:, 0], record.u, atol=1e-12)
    np.testing.assert_allclose(dd.retrend(dd.y), record.y, atol=1e-12)
    assert "detrended" in repr(dd) and "detrended" not in repr(record)
    # the original is untouched (detrend returns new data)
    assert not record.y_trend.any()


def test_detrend_twice_accumulates_and_slices(record):
    d2 = record.detrend("constant").detrend("linear")
    np.testing.assert_allclose(d2.outputs, signal.detrend(record.outputs, axis=0), atol=1e-12)
    np.testing.assert_allclose(d2.outputs + d2.y_trend, record.outputs, atol=1e-12)
    part = d2[50:80]
    np.testing.assert_array_equal(part.y_trend, d2.y_trend[50:80])


def test_split_and_slicing(record):
    est, val = record.split(0.3)
    assert len(est) == 60 and len(val) == 140
    np.testing.assert_array_equal(val.y, record.y[60:])
    np.testing.assert_allclose(val.t, record.t[60:])          # the time goes on
    assert val.dt == 0.1 and val.y_names == record.y_names
    s = record[10:20:2]
    np.testing.assert_array_equal(s.u, record.u[10:20:2])
    assert s.dt == pytest.approx(0.2)
    np.testing.assert_allclose(s.t, record.t[10:20:2])
    with pytest.raises(ValueError, match="fraction must be in"):
        record.split(1.0)
    with pytest.raises(ValueError, match="fraction must be leaving samples in both parts"):
        record.split(0.001)
    with pytest.raises(TypeError, match="key must be a slice"):
        record[3]


def test_to_frame_and_pandas_input(rng):
    idx = pd.date_range("2026-01-01", periods=50, freq="s")
    df = pd.DataFrame({"speed": rng.standard_normal(50), "volt": rng.standard_normal(50)}, index=idx)
    d = IDData(df["speed"], df[["volt"]], dt=1.0)
    assert d.y_names == ("speed",) and d.u_names == ("volt",)
    assert d.t.dtype.kind == "M"                        # the index became the time axis
    out = d.to_frame()
    assert list(out.columns) == ["speed", "volt"] and out.index.name == "time"
    pd.testing.assert_frame_equal(out, df.rename_axis("time"), check_freq=False)
    # a default RangeIndex is not a time axis
    d2 = IDData(pd.Series(np.arange(4.0), name="a"))
    assert d2.time is None and d2.y_names == ("a",)


def test_errors():
    with pytest.raises(ValueError, match="u must be with N=3 rows"):
        IDData(np.ones(3), np.ones(4))
    with pytest.raises(ValueError, match="y_names must be 1 name"):
        IDData(np.ones(3), y_names=["a", "b"])
    with pytest.raises(ValueError, match="kind must be one of 'constant', 'linear'"):
        IDData(np.ones(3)).detrend("quadratic")
    with pytest.raises(ValueError, match="dt must be"):
        IDData(np.ones(3), dt=0.0)
    with pytest.raises(ValueError, match="time must be of shape"):
        IDData(np.ones(3), time=np.arange(4.0))


def test_plot_writes_a_png_with_the_names(record, tmp_path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = record.plot()
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert labels == ["temp", "flow", "power"]
    path = tmp_path / "record.png"
    fig.savefig(path)
    plt.close(fig)
    assert path.stat().st_size > 5000
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_datasets_return_iddata():
    d = load_daisy("dryer")
    assert isinstance(d, IDData)
    # SOURCE.md: Ts = 0.08 s (MATLAB dryer2); column 1 u (heater voltage), column 2 y
    assert d.dt == 0.08 and d.y_names == ("y",) and d.u_names == ("u",)
    np.testing.assert_allclose(d.t[:3], [0.0, 0.08, 0.16])
    ex = load_daisy("exchanger")
    assert ex.dt == 1.0 and ex.u_names == ("q",) and ex.y_names == ("th",)
    np.testing.assert_array_equal(ex.t, np.arange(1.0, 4001.0))   # the file's time column
    cd = load_daisy("CD_player_arm")
    assert cd.n_inputs == 2 and cd.n_outputs == 2 and cd.y_names == ("y1", "y2")
    e = load_emps()
    assert isinstance(e, IDData) and e.dt == 1e-3
    assert e.y_names == ("qm",) and e.u_names == ("vir",)
    np.testing.assert_array_equal(e.y, e.qm)
    np.testing.assert_array_equal(e.t, e.time)
