"""Regressor builders of adaptid.models, checked against hand-built matrices.

Oracles: explicit Python loops over samples written here (not numpy fancy
indexing as in the library), numpy.polyfit, numpy.linalg.lstsq, pandas.
"""

import numpy as np
import pandas as pd
import pytest

import adaptid
from adaptid.models import (
    Regression,
    arx_regressors,
    exponential_regressors,
    fir_regressors,
    table_regressors,
    trend_regressors,
)


def _arx_by_hand(y, U, na, nbs, nks):
    N = len(y)
    s = max([na] + [k + b - 1 for b, k in zip(nbs, nks) if b > 0])
    rows = []
    for k in range(s, N):
        row = [y[k - j] for j in range(1, na + 1)]
        for i, (b, d) in enumerate(zip(nbs, nks)):
            row += [U[k - d - j, i] for j in range(b)]
        rows.append(row)
    return np.array(rows), np.array(y[s:]), s


def test_arx_single_input_matches_hand_built(rng):
    y, u = rng.standard_normal(40), rng.standard_normal(40)
    reg = arx_regressors(y, u, na=2, nb=3, nk=2)
    Phi, target, s = _arx_by_hand(y, u[:, None], 2, [3], [2])
    assert isinstance(reg, Regression)
    assert s == 4 and reg.meta["start"] == 4
    np.testing.assert_array_equal(reg.Phi, Phi)
    np.testing.assert_array_equal(reg.y, target)
    np.testing.assert_array_equal(reg.index, np.arange(4, 40))
    assert reg.names == ("y[k-1]", "y[k-2]", "u[k-2]", "u[k-3]", "u[k-4]")
    assert reg.n_params == 5 and len(reg) == 36
    assert reg.Phi.flags.c_contiguous and reg.Phi.dtype == np.float64


def test_arx_several_inputs_per_input_orders(rng):
    y, U = rng.standard_normal(30), rng.standard_normal((30, 3))
    reg = arx_regressors(y, U, na=1, nb=[2, 0, 1], nk=[0, 5, 3])
    Phi, target, s = _arx_by_hand(y, U, 1, [2, 0, 1], [0, 5, 3])
    np.testing.assert_array_equal(reg.Phi, Phi)
    np.testing.assert_array_equal(reg.y, target)
    assert reg.index[0] == s == 3
    assert reg.names == ("y[k-1]", "u0[k]", "u0[k-1]", "u2[k-3]")


def test_arx_regression_recovers_noise_free_system(rng):
    # y[k] = 0.5 y[k-1] + 2 u0[k-1] - u1[k-2]: a direct np.linalg.lstsq on the builder's rows
    N = 200
    U = rng.standard_normal((N, 2))
    y = np.zeros(N)
    for k in range(2, N):
        y[k] = 0.5 * y[k - 1] + 2 * U[k - 1, 0] - U[k - 2, 1]
    reg = arx_regressors(y, U, 1, [1, 1], [1, 2])
    theta = np.linalg.lstsq(reg.Phi, reg.y, rcond=None)[0]
    np.testing.assert_allclose(theta, [0.5, 2.0, -1.0], atol=1e-12)


def test_fir_is_arx_without_outputs(rng):
    y, u = rng.standard_normal(25), rng.standard_normal(25)
    reg = fir_regressors(y, u, nb=4, nk=0)
    Phi, target, s = _arx_by_hand(y, u[:, None], 0, [4], [0])
    np.testing.assert_array_equal(reg.Phi, Phi)
    np.testing.assert_array_equal(reg.y, target)
    assert reg.names == ("u[k]", "u[k-1]", "u[k-2]", "u[k-3]")
    assert reg.meta["structure"] == "fir"


def test_trend_fit_equals_polyfit(rng):
    t = np.linspace(1000.0, 2000.0, 300)
    y = 3.0 - 0.002 * t + 1e-6 * t ** 2 + 0.01 * rng.standard_normal(300)
    reg = trend_regressors(t, y, 2)
    assert reg.names == ("1", "tau", "tau^2")
    theta = adaptid.lstsq(reg.Phi, reg.y).theta
    fitted = reg.Phi @ theta
    np.testing.assert_allclose(fitted, np.polyval(np.polyfit(t, y, 2), t), rtol=1e-10)
    # the documented map back to t: tau = (t - c) / h
    c, h = reg.meta["t_center"], reg.meta["t_scale"]
    np.testing.assert_allclose((t - c) / h, reg.Phi[:, 1])
    assert reg.Phi[:, 1].min() == -1.0 and reg.Phi[:, 1].max() == 1.0


def test_trend_unscaled_coefficients_equal_polyfit(rng):
    t = np.linspace(0.0, 2.0, 50)
    y = 1.0 + 2.0 * t - 0.5 * t ** 3 + 0.01 * rng.standard_normal(50)
    reg = trend_regressors(t, y, 3, scale=False)
    assert reg.names == ("1", "t", "t^2", "t^3")
    theta = adaptid.lstsq(reg.Phi, reg.y).theta
    np.testing.assert_allclose(theta, np.polyfit(t, y, 3)[::-1], rtol=1e-8, atol=1e-10)


def test_exponential_against_direct_lstsq(rng):
    t = np.linspace(0.0, 10.0, 400)
    rates = [0.3, 2.0]
    y = 1.5 + 2.0 * np.exp(-0.3 * t) - 0.7 * np.exp(-2.0 * t) + 0.01 * rng.standard_normal(400)
    reg = exponential_regressors(t, y, rates, constant=True)
    assert reg.names == ("1", "exp(-0.3*t)", "exp(-2*t)")
    X = np.column_stack([np.ones_like(t)] + [np.exp(-r * t) for r in rates])
    np.testing.assert_allclose(reg.Phi, X, rtol=1e-15)
    theta = adaptid.lstsq(reg.Phi, reg.y).theta
    np.testing.assert_allclose(theta, np.linalg.lstsq(X, y, rcond=None)[0], rtol=1e-9)
    np.testing.assert_allclose(theta, [1.5, 2.0, -0.7], atol=0.02)


def test_exponential_t0_shift_rescales_amplitudes():
    t = np.linspace(100.0, 110.0, 50)
    y = np.exp(-0.5 * (t - 100.0))
    reg = exponential_regressors(t, y, [0.5], t0=100.0)
    np.testing.assert_allclose(adaptid.lstsq(reg.Phi, reg.y).theta, [1.0], rtol=1e-12)
    with pytest.raises(ValueError, match="rates"):
        exponential_regressors(t, y, [0.5, 0.5])


# ------------------------------------------------------------------ table
def _frame(rng, N=20):
    return pd.DataFrame({"i": rng.standard_normal(N), "w": rng.standard_normal(N),
                         "v": rng.standard_normal(N)}, index=pd.RangeIndex(100, 100 + N))


def test_table_terms_match_hand_built(rng):
    df = _frame(rng)
    terms = ["i", "w[k-2]", "i*w[k-1]", "sign(w)", "abs(v[k-1])", "1", "sign(w[k-1])*v"]
    reg = table_regressors(df, "v", terms)
    i, w, v = (df[c].to_numpy() for c in "iwv")
    rows = []
    for k in range(2, len(df)):
        rows.append([i[k], w[k - 2], i[k] * w[k - 1], np.sign(w[k]), abs(v[k - 1]), 1.0,
                     np.sign(w[k - 1]) * v[k]])
    np.testing.assert_array_equal(reg.Phi, np.array(rows))
    np.testing.assert_array_equal(reg.y, v[2:])
    np.testing.assert_array_equal(reg.index, np.arange(2, len(df)))
    np.testing.assert_array_equal(reg.meta["df_index"], df.index[2:])
    assert reg.names == ("i", "w[k-2]", "i*w[k-1]", "sign(w)", "abs(v[k-1])", "1", "sign(w[k-1])*v")


def test_table_tuple_spec_equals_strings(rng):
    df = _frame(rng)
    a = table_regressors(df, "i", ["w[k-3]", "sign(v[k-1])", "i[k-1]*w"])
    b = table_regressors(df, ("i", 0), [("w", 3), ("v", 1, "sign"), [("i", 1), "w"]])
    np.testing.assert_array_equal(a.Phi, b.Phi)
    np.testing.assert_array_equal(a.y, b.y)
    assert a.names == b.names


def test_table_odd_column_names_and_array_target(rng):
    df = pd.DataFrame({"i*R": [1.0, 2.0, 3.0], "x[k]": [4.0, 5.0, 6.0]})
    reg = table_regressors(df, np.array([7.0, 8.0, 9.0]), ["i*R", ("x[k]", 1)])
    np.testing.assert_array_equal(reg.Phi, [[2.0, 4.0], [3.0, 5.0]])
    np.testing.assert_array_equal(reg.y, [8.0, 9.0])


def test_table_missing_column_names_it(rng):
    df = _frame(rng)
    with pytest.raises(ValueError, match=r"terms\[1\].*no column 'torque'"):
        table_regressors(df, "v", ["i", "torque[k-1]"])
    with pytest.raises(ValueError, match=r"y.*no column 'speed'"):
        table_regressors(df, "speed", ["i"])
    with pytest.raises(ValueError, match=r"terms\[0\].*no column 'q'"):
        table_regressors(df, "v", [("q", 1)])


def test_table_bad_specs(rng):
    df = _frame(rng, N=3)
    with pytest.raises(ValueError, match="df must be longer than 3 rows"):
        table_regressors(df, "v", ["i[k-3]"])
    with pytest.raises(ValueError, match="terms"):
        table_regressors(df, "v", [])
    with pytest.raises(ValueError, match=r"terms\[0\]"):
        table_regressors(df, "v", [("i", -1)])
    df2 = df.copy()
    df2.loc[101, "i"] = np.nan
    with pytest.raises(ValueError, match=r"df\['i'\]"):
        table_regressors(df2, "v", ["i"])


# ------------------------------------------------------------ bad input
def test_negative_orders_name_the_argument(rng):
    y, u = rng.standard_normal(20), rng.standard_normal(20)
    with pytest.raises(ValueError, match="na must be an integer >= 0"):
        arx_regressors(y, u, -1, 2, 1)
    with pytest.raises(ValueError, match="nb must be an integer >= 0"):
        arx_regressors(y, u, 1, -2, 1)
    with pytest.raises(ValueError, match=r"nk\[1\] must be an integer >= 0"):
        arx_regressors(y, np.c_[u, u], 1, 2, [1, -1])
    with pytest.raises(ValueError, match="nb must be an integer or a sequence of 2"):
        arx_regressors(y, np.c_[u, u], 1, [1, 2, 3], 1)
    with pytest.raises(ValueError, match="degree must be an integer >= 0"):
        trend_regressors(np.arange(20.0), y, -1)


def test_too_few_samples_and_length_mismatch(rng):
    y, u = rng.standard_normal(5), rng.standard_normal(5)
    with pytest.raises(ValueError, match="y must be longer than 5 samples"):
        arx_regressors(y, u, 2, 3, 3)
    with pytest.raises(ValueError, match="u must be of length N=5"):
        arx_regressors(y, np.ones(6), 1, 1, 1)
    with pytest.raises(ValueError, match="y must be finite"):
        arx_regressors(np.r_[y[:4], np.nan], u, 1, 1, 1)
