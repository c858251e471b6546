"""Several experiments and gaps (issue 34, point 1): IDData.merge, the rows of
every regressor builder and model formed inside each experiment, NaN gaps.

The oracles are NumPy: each experiment's rows written out by hand with
array indexing, stacked, and solved by numpy.linalg.lstsq."""

import numpy as np
import pandas as pd
import pytest
from scipy.signal import lfilter

from adaptid import IDData


def _plant(rng, N, a=(1.0, -1.5, 0.7), b=(0.0, 1.0, 0.5), noise=0.1):
    u = rng.standard_normal(N)
    y = lfilter(b, a, u) + noise * rng.standard_normal(N)
    return y, u


@pytest.fixture
def three(rng):
    recs = []
    for N, dt in ((300, 0.1), (200, 0.1), (250, 0.1)):
        y, u = _plant(rng, N)
        recs.append(IDData(y, u, dt, y_names="out", u_names="in"))
    return recs


# ------------------------------------------------------------------ IDData
def test_merge_keeps_experiments(three):
    a, b, c = three
    m = a.merge(b, c)
    assert m.n_experiments == 3 and len(m) == 750
    assert [len(e) for e in m.experiments] == [300, 200, 250]
    np.testing.assert_array_equal(m.bounds, [0, 300, 500, 750])
    np.testing.assert_array_equal(m.experiment(1).y, b.y)
    np.testing.assert_array_equal(m.outputs[:, 0], np.r_[a.y, b.y, c.y])
    # each experiment keeps its own time axis
    np.testing.assert_allclose(m.t, np.r_[a.t, b.t, c.t])
    assert m.y_names == ("out",) and m.u_names == ("in",) and m.dt == 0.1
    assert "experiments=3" in repr(m)
    # merging merged records flattens them; a single record is one experiment
    assert m.merge(a).n_experiments == 4 and a.n_experiments == 1 and a.experiments == [a]
    with pytest.raises(ValueError, match="k must be"):
        m.experiment(3)


def test_merge_refuses_other_signals_and_dt(three):
    a = three[0]
    with pytest.raises(ValueError, match=r"others\[0\].*dt=0.1"):
        a.merge(IDData(np.ones(10), np.ones(10), 0.2, y_names="out", u_names="in"))
    with pytest.raises(ValueError, match=r"others\[1\].*outputs \['out'\]"):
        a.merge(three[1], IDData(np.ones(10), np.ones(10), 0.1))
    with pytest.raises(TypeError, match=r"others\[0\]"):
        a.merge(np.ones(10))
    with pytest.raises(TypeError, match="merged record"):
        a.merge(three[1])[10:20]


def test_merge_frame_split_detrend(three):
    m = three[0].merge(three[1])
    df = m.to_frame()
    assert df.index.names == ["experiment", "time"]
    pd.testing.assert_frame_equal(df.loc[1], three[1].to_frame())
    est, val = m.split(0.6)
    assert est.n_experiments == val.n_experiments == 2
    assert [len(e) for e in est.experiments] == [180, 120]
    np.testing.assert_array_equal(val.experiment(1).y, three[1].y[120:])
    dd = m.detrend("linear")
    for e in range(2):    # oracle: each experiment's own detrend
        np.testing.assert_allclose(dd.experiment(e).y, three[e].detrend("linear").y, atol=1e-12)
    np.testing.assert_allclose(dd.retrend(dd.y), m.y, atol=1e-12)


def test_nan_samples_are_kept_and_detrended_around(rng):
    y = rng.standard_normal(50) + 3.0
    y[[5, 6, 30]] = np.nan
    d = IDData(y, rng.standard_normal(50))
    assert "3 sample(s) with NaN" in repr(d)
    dd = d.detrend()
    ok = ~np.isnan(y)
    np.testing.assert_allclose(dd.y[ok], y[ok] - y[ok].mean(), atol=1e-12)
    assert np.isnan(dd.y[[5, 6, 30]]).all()
    with pytest.raises(ValueError, match="y must be"):
        IDData(np.r_[1.0, np.inf], np.ones(2))
