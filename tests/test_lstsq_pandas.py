"""lstsq on pandas, labelled as statsmodels labels it (issue 33, points 6 and 9).

Reference: statsmodels' OLS / WLS results on the same DataFrame (statsmodels
solves by pinv; both are exact to a few ulps of the well-conditioned design,
hence rtol 1e-10).
"""

import numpy as np
import pandas as pd
import pytest

import adaptid

sm = pytest.importorskip("statsmodels.api")

RTOL = 1e-10


@pytest.fixture
def frame(rng):
    N = 120
    idx = pd.date_range("2026-01-01", periods=N, freq="80ms", name="time")
    X = pd.DataFrame({"const": np.ones(N), "y(k-1)": rng.standard_normal(N),
                      "u(k-3)": rng.standard_normal(N)}, index=idx)
    y = pd.Series(X.to_numpy() @ [0.5, -0.8, 1.5] + 0.3 * rng.standard_normal(N),
                  index=idx, name="temp")
    w = rng.uniform(0.5, 2.0, N)
    return X, y, w


def _same_series(got, ref):
    assert isinstance(got, pd.Series)
    pd.testing.assert_index_equal(got.index, ref.index)
    np.testing.assert_allclose(got.to_numpy(), ref.to_numpy(), rtol=RTOL, atol=0)


@pytest.mark.parametrize("weighted", [False, True])
def test_against_statsmodels(frame, weighted):
    X, y, w = frame
    res = adaptid.lstsq(X, y, weights=w if weighted else None)
    ref = (sm.WLS(y, X, weights=w) if weighted else sm.OLS(y, X)).fit()
    for name in ("params", "bse", "tvalues", "pvalues"):
        _same_series(getattr(res, name), getattr(ref, name))
    _same_series(res.stderr, ref.bse)
    for alpha in (0.05, 0.1):
        ci, ci_ref = res.conf_int(alpha), ref.conf_int(alpha)
        assert isinstance(ci, pd.DataFrame)
        pd.testing.assert_index_equal(ci.index, ci_ref.index)
        pd.testing.assert_index_equal(ci.columns, ci_ref.columns, exact=True)   # 0 and 1
        np.testing.assert_allclose(ci.to_numpy(), ci_ref.to_numpy(), rtol=RTOL)
    for name in ("resid", "fittedvalues"):
        got, want = getattr(res, name), getattr(ref, name)
        assert isinstance(got, pd.Series)
        pd.testing.assert_index_equal(got.index, want.index)            # the data's time index
        np.testing.assert_allclose(got.to_numpy(), want.to_numpy(), rtol=1e-9, atol=1e-12)
    # the contract's names stay arrays
    assert type(res.theta) is np.ndarray and type(res.residuals) is np.ndarray
    np.testing.assert_array_equal(res.theta, res.params.to_numpy())


def test_array_y_with_frame_phi(frame):
    X, y, _ = frame
    res, ref = adaptid.lstsq(X, y.to_numpy()), sm.OLS(y.to_numpy(), X).fit()
    _same_series(res.params, ref.params)
    _same_series(res.resid, ref.resid)


def test_numpy_inputs_keep_arrays(frame):
    X, y, _ = frame
    res = adaptid.lstsq(X.to_numpy(), y.to_numpy())
    for name in ("params", "bse", "stderr", "tvalues", "pvalues", "resid", "fittedvalues"):
        assert type(getattr(res, name)) is np.ndarray, name
    assert type(res.conf_int()) is np.ndarray and res.conf_int().shape == (3, 2)
    lab = adaptid.lstsq(X, y)
    np.testing.assert_array_equal(res.theta, lab.theta)
    np.testing.assert_array_equal(res.bse, lab.bse.to_numpy())
    np.testing.assert_array_equal(res.conf_int(), lab.conf_int().to_numpy())
    np.testing.assert_allclose(res.fittedvalues, X.to_numpy() @ res.theta, rtol=1e-12)


def test_several_outputs_give_frames(frame):
    X, y, _ = frame
    Y = pd.DataFrame({"a": y, "b": 2.0 * y})
    res = adaptid.lstsq(X, Y)
    assert isinstance(res.params, pd.DataFrame) and list(res.params.columns) == ["a", "b"]
    assert list(res.params.index) == list(X.columns)
    _same_series(res.params["a"], sm.OLS(y, X).fit().params)
    assert res.conf_int().shape == (3, 2, 2)                           # documented: array
    assert isinstance(res.resid, pd.DataFrame) and res.resid.index.equals(X.index)


def test_summary_names_from_the_columns(frame):
    X, y, _ = frame
    assert adaptid.lstsq(X, y).summary().names == ("const", "y(k-1)", "u(k-3)")


# ---------------------------------------------------------------- errors (point 9)
def test_transposed_phi_names_phi_and_the_fix(rng):
    Phi, y = rng.standard_normal((50, 3)), rng.standard_normal(50)
    with pytest.raises(ValueError, match=r"^Phi must be .*transposed: pass Phi\.T, "
                                         r"got shape \(3, 50\)"):
        adaptid.lstsq(Phi.T, y)
    with pytest.raises(ValueError, match=r"Phi\.T"):
        adaptid.lstsq(pd.DataFrame(Phi).T, pd.Series(y))
    # a plain length mismatch still names y
    with pytest.raises(ValueError, match=r"^y must be of length N=50"):
        adaptid.lstsq(Phi, y[:40])


def test_y_as_a_column_is_one_output(rng):
    Phi, y = rng.standard_normal((50, 3)), rng.standard_normal(50)
    flat, col = adaptid.lstsq(Phi, y), adaptid.lstsq(Phi, y[:, None])
    assert col.theta.shape == (3,) and col.residuals.shape == (50,)
    np.testing.assert_array_equal(col.theta, flat.theta)
    np.testing.assert_array_equal(col.stderr, flat.stderr)
    assert col.sigma2 == flat.sigma2 and isinstance(col.sigma2, float)
    assert str(col.summary()) == str(flat.summary())
    # statsmodels treats a one-column endog the same way
    ref = sm.OLS(y[:, None], Phi).fit()
    np.testing.assert_allclose(col.params, ref.params, rtol=RTOL)
    # a one-column DataFrame y as well (IDData squeezes it too)
    X = pd.DataFrame(Phi, columns=list("abc"))
    got = adaptid.lstsq(X, pd.DataFrame({"y": y}))
    assert isinstance(got.params, pd.Series)
    assert adaptid.IDData(pd.DataFrame({"y": y})).y.shape == (50,)
