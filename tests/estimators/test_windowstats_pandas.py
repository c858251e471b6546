"""WindowStats: per-window p-values, intervals and ``to_pandas`` (issue 33, point 6).

Oracle: statsmodels' ``RollingOLS(...).fit(use_t=True)`` on the same
DataFrame (p-values, confidence intervals, index, names).
"""

import numpy as np
import pandas as pd
import pytest
from statsmodels.regression.rolling import RollingOLS

import adaptid


@pytest.fixture
def frame():
    rng = np.random.default_rng(0)
    idx = pd.date_range("2024-01-01", periods=120, freq="80ms")
    X = pd.DataFrame({"const": np.ones(120), "x": rng.standard_normal(120)}, index=idx)
    y = pd.Series(X.to_numpy() @ [1.0, 0.3] + 0.5 * rng.standard_normal(120), index=idx)
    return X, y


def test_pvalues_and_intervals_equal_rolling_ols(frame):
    X, y = frame
    st = adaptid.SlidingWindowRLS(2, 25, P0="diffuse").run(X, y, stats=True).stats
    ref = RollingOLS(y, X, window=25).fit(use_t=True)
    rows = slice(24, None)
    np.testing.assert_allclose(st.pvalues[rows], np.asarray(ref.pvalues)[rows], rtol=1e-7,
                               atol=1e-14)
    lo, hi = st.conf_int(0.1)
    ci = ref.conf_int(alpha=0.1)  # columns (name, lower/upper)
    for j, name in enumerate(X.columns):
        np.testing.assert_allclose(lo[rows, j], ci[(name, "lower")].to_numpy()[rows], rtol=1e-9)
        np.testing.assert_allclose(hi[rows, j], ci[(name, "upper")].to_numpy()[rows], rtol=1e-9)


def test_to_pandas_has_names_and_time(frame):
    X, y = frame
    st = adaptid.SlidingWindowRLS(2, 25, P0="diffuse").run(X, y, stats=True).stats
    df = st.to_pandas()
    assert isinstance(df.index, pd.DatetimeIndex) and (df.index == X.index).all()
    assert {"pvalues[x]", "stderr[const]", "tvalues[x]", "sigma2", "df_resid"} <= set(df)
    np.testing.assert_array_equal(df["pvalues[x]"].to_numpy(), st.pvalues[:, 1])
    plain = adaptid.SlidingWindowRLS(2, 25).run(X.to_numpy(), y.to_numpy(), stats=True).stats
    assert list(plain.to_pandas().columns)[-1] == "pvalues[theta[1]]"


def test_to_pandas_refuses_batched(frame):
    X, y = frame
    st = adaptid.SlidingWindowRLS(2, 25).run_batched(np.stack([X.to_numpy()] * 2),
                                                      np.stack([y.to_numpy()] * 2),
                                                      stats=True).stats
    assert st.pvalues.shape == (2, 120, 2)
    with pytest.raises(ValueError, match="one stream"):
        st.to_pandas()
