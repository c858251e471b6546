"""IDData's sample time from the data (issue 33, point 1).

The references are pandas' own: the step of an index is what pandas says its
frequency is (``pd.to_timedelta(index.freq)``, ``Timedelta.total_seconds``),
or the numbers the index was built from; the models' ``to_control()`` is
python-control's ``dt``.
"""

import numpy as np
import pandas as pd
import pytest

from adaptid import IDData
from adaptid.datasets import load_daisy
from adaptid.models import ARX


def _record(index, rng):
    N = len(index)
    u = rng.standard_normal(N)
    y = np.zeros(N)
    for k in range(2, N):
        y[k] = 1.2 * y[k - 1] - 0.5 * y[k - 2] + 0.4 * u[k - 1] + 0.01 * rng.standard_normal()
    return pd.DataFrame({"temp": y, "power": u}, index=index)


def test_dt_by_position_as_matlab_iddata():
    d = IDData(np.ones(8), np.zeros(8), 0.08)       # MATLAB's iddata(y, u, Ts)
    assert d.dt == 0.08
    np.testing.assert_allclose(d.t, 0.08 * np.arange(8))
    assert IDData(np.ones(8), None, 0.5).dt == 0.5


def test_datetimeindex_frequency_of_pandas(rng):
    idx = pd.date_range("2026-01-01", periods=200, freq="80ms")
    df = _record(idx, rng)
    d = IDData(df["temp"], df["power"])
    # pandas' own frequency of the index, in seconds
    assert d.dt == pd.to_timedelta(idx.freq).total_seconds() == 0.08
    assert d.time.dtype.kind == "M" and d.y_names == ("temp",)


def test_datetimeindex_without_freq_uses_the_steps(rng):
    idx = pd.DatetimeIndex(pd.date_range("2026-01-01", periods=50, freq="250ms").to_numpy())
    assert idx.freq is None                          # no frequency attached
    d = IDData(_record(idx, rng)["temp"])
    assert d.dt == pytest.approx(pd.Timedelta(idx[1] - idx[0]).total_seconds(), rel=1e-15)
    assert d.dt == pytest.approx(0.25, rel=1e-15)


def test_aware_datetimeindex(rng):
    idx = pd.date_range("2026-03-29 00:00", periods=40, freq="100ms", tz="Europe/Berlin")
    d = IDData(_record(idx, rng)["temp"])
    assert d.dt == pytest.approx(0.1, rel=1e-15)


def test_timedeltaindex(rng):
    idx = pd.timedelta_range(0, periods=60, freq="20ms")
    d = IDData(_record(idx, rng)["temp"])
    assert d.dt == pd.to_timedelta(idx.freq).total_seconds() == 0.02
    assert d.time.dtype.kind == "m"
    assert list(d.to_frame().index) == list(idx)


def test_numeric_index_step_half(rng):
    idx = pd.Index(np.arange(100) * 0.5)
    df = _record(idx, rng)
    d = IDData(df["temp"], df["power"])
    assert d.dt == 0.5
    np.testing.assert_array_equal(d.t, idx.to_numpy())


def test_time_of_u_when_y_is_an_array(rng):
    idx = pd.date_range("2026-01-01", periods=30, freq="80ms")
    df = _record(idx, rng)
    assert IDData(df["temp"].to_numpy(), df["power"]).dt == 0.08


@pytest.mark.parametrize("time, dt", [
    (np.arange(20) * 0.1, 0.1),
    (10.0 + np.arange(20) * 0.1, 0.1),
    (np.arange(20), 1.0),
    (np.datetime64("2026-01-01T00:00") + np.arange(20) * np.timedelta64(80, "ms"), 0.08),
    (np.arange(20) * np.timedelta64(5, "s"), 5.0),
])
def test_time_argument(time, dt):
    d = IDData(np.ones(20), time=time)
    assert d.dt == pytest.approx(dt, rel=1e-12)
    assert IDData(np.ones(20), time=time, dt=dt).dt == dt   # the same dt given agrees


def test_irregular_axis_without_dt_names_dt_and_the_axis(rng):
    idx = pd.date_range("2026-01-01", periods=50, freq="80ms").delete(20)   # one sample lost
    y = _record(idx, rng)["temp"]
    with pytest.raises(ValueError, match=r"dt must be given .*time axis \(index of y\)"):
        IDData(y)
    with pytest.raises(ValueError, match=r"dt must be given .*irregular.*\btime\b"):
        IDData(np.ones(4), time=[0.0, 1.0, 2.0, 4.0])
    # dt given as the nominal step of the irregular axis: taken, the stamps kept
    d = IDData(y, dt=0.08)
    assert d.dt == 0.08
    np.testing.assert_array_equal(d.time, idx.to_numpy())
    # a dt off the axis' median step contradicts it
    with pytest.raises(ValueError, match=r"dt=0\.1 s contradicts the time axis \(index of y\), "
                                         r"an irregular axis whose median step is 0\.08 s"):
        IDData(y, dt=0.1)


def test_jittered_stamps_with_their_nominal_dt(rng):
    # stamps of a 10 ms logger with up to 0.5 ms of jitter (what the CLI reads from a CSV)
    t = 0.01 * np.arange(200) + rng.uniform(-5e-4, 5e-4, 200)
    with pytest.raises(ValueError, match="dt must be given for an irregular time axis"):
        IDData(np.ones(200), time=t)
    assert IDData(np.ones(200), time=t, dt=0.01).dt == 0.01
    assert IDData(np.ones(200), time=t, dt=float(np.median(np.diff(t)))).dt > 0


def test_contradicting_dt_names_both(rng):
    idx = pd.date_range("2026-01-01", periods=50, freq="80ms")
    df = _record(idx, rng)
    with pytest.raises(ValueError, match=r"dt=0\.1 s contradicts the time axis \(index of y\)"
                                         r", whose step is 0\.08 s"):
        IDData(df["temp"], df["power"], 0.1)
    with pytest.raises(ValueError, match=r"dt=1 s contradicts time"):
        IDData(np.ones(5), time=np.arange(5) * 0.5, dt=1.0)
    # the same dt to a part in 1e9 is no contradiction; a part in 1e4 over 50 samples is
    assert IDData(df["temp"], dt=0.08 * (1 + 1e-9)).dt == pytest.approx(0.08, rel=1e-8)
    with pytest.raises(ValueError, match=r"dt=0\.080008 s contradicts the time axis"):
        IDData(df["temp"], dt=0.08 * (1 + 1e-4))


def test_decreasing_time_is_refused():
    with pytest.raises(ValueError, match="time must be strictly increasing"):
        IDData(np.ones(4), time=[0.0, 1.0, 1.0, 2.0])


def test_no_time_at_all_is_one_second():
    assert IDData(np.ones(5)).dt == 1.0
    assert IDData(pd.Series(np.ones(5), name="y")).dt == 1.0        # default RangeIndex
    assert IDData(pd.DataFrame({"y": np.ones(5), "u": np.ones(5)})[["y"]]).dt == 1.0
    assert IDData(np.ones(1), time=np.array([3.0])).dt == 1.0     # one stamp: no step


def test_y_as_a_column_is_squeezed():
    d = IDData(np.arange(6.0)[:, None], np.ones(6))
    assert d.y.shape == (6,) and d.n_outputs == 1
    np.testing.assert_array_equal(d.y, np.arange(6.0))


def test_models_carry_the_dt_of_pandas_data(rng):
    control = pytest.importorskip("control")
    idx = pd.date_range("2026-01-01", periods=300, freq="80ms")
    df = _record(idx, rng)
    for m in (ARX(2, 1, 1).fit(IDData(df["temp"], df["power"])),
              ARX(2, 1, 1).fit(df["temp"], df["power"]),
              # unnamed Series: the time index alone makes the record
              ARX(2, 1, 1).fit(pd.Series(df["temp"].to_numpy(), index=idx),
                               pd.Series(df["power"].to_numpy(), index=idx))):
        assert m.dt == 0.08
        sys = m.to_control()
        assert isinstance(sys, control.TransferFunction) and sys.dt == 0.08
    # the same fit as from arrays with dt given
    ref = ARX(2, 1, 1, dt=0.08).fit(df["temp"].to_numpy(), df["power"].to_numpy())
    np.testing.assert_array_equal(ARX(2, 1, 1).fit(df["temp"], df["power"]).theta, ref.theta)


def test_dryer_unchanged():
    d = load_daisy("dryer")
    # SOURCE.md: Ts = 0.08 s (MATLAB dryer2)
    assert d.dt == 0.08 and d.time is None
    frame = d.to_frame()
    again = IDData(frame["y"], frame["u"])          # its own time axis gives the same dt
    assert again.dt == pytest.approx(0.08, rel=1e-12)
    np.testing.assert_array_equal(again.y, d.y)


@pytest.mark.parametrize("cls, orders", [("AR", (2,)), ("ARMA", (2, 1))])
def test_time_series_models_carry_the_dt(cls, orders, rng):
    control = pytest.importorskip("control")
    from adaptid import models

    idx = pd.date_range("2026-01-01", periods=300, freq="80ms")
    level = _record(idx, rng)["temp"]
    ref = getattr(models, cls)(*orders).fit(level.to_numpy())
    assert ref.dt == 1.0                                   # arrays: no time at all
    for data in (level, IDData(level)):
        m = getattr(models, cls)(*orders).fit(data)
        assert m.dt == 0.08 and m.to_control().dt == 0.08 and m.y_name == "temp"
        np.testing.assert_array_equal(m.theta, ref.theta)   # the same fit
    traj = getattr(models, cls)(*orders).fit_recursive(level)
    assert traj.time is not None and traj.time.dtype.kind == "M"
    with pytest.raises(ValueError, match="y must be an output record without inputs"):
        getattr(models, cls)(*orders).fit(IDData(level, level))


def test_a_range_index_numbers_rows_and_gives_no_sample_time(rng):
    df = _record(pd.RangeIndex(400), rng).iloc[100:]       # a slice of the default index
    d = IDData(df["temp"], df["power"], 0.08)               # no contradiction with rows 100..399
    assert d.dt == 0.08
    np.testing.assert_array_equal(d.time, np.arange(100, 400))
    assert IDData(df["temp"]).dt == 1.0
    # an unnamed slice fitted with the model's own dt keeps it
    m = ARX(2, 1, 1, dt=0.5).fit(pd.Series(df["temp"].to_numpy(), index=df.index),
                                 pd.Series(df["power"].to_numpy(), index=df.index))
    assert m.dt == 0.5
