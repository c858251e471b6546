"""stlsq and SINDy against pysindy 2.1 (issue 35, point 3)."""

import warnings

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from adaptid import IDData
from adaptid._exceptions import AdaptidWarning
from adaptid.models import SINDy, stlsq
from adaptid.models.nonlinear._sindy import polynomial_library


def lorenz(t, z):
    return [10 * (z[1] - z[0]), z[0] * (28 - z[2]) - z[1], z[0] * z[1] - 8 / 3 * z[2]]


@pytest.fixture(scope="module")
def lorenz_data():
    t = np.arange(0, 5, 0.002)
    X = solve_ivp(lorenz, (0, 5), [-8, 8, 27], t_eval=t, rtol=1e-12, atol=1e-12,
                  method="LSODA").y.T
    return t, X


@pytest.mark.parametrize("threshold, alpha", [(0.1, 0.0), (0.5, 0.05), (0.1, 1.0)])
def test_stlsq_equals_pysindy_on_lorenz(lorenz_data, threshold, alpha):
    """pysindy.optimizers.STLSQ (defaults: unbias=True, no normalisation) on the same Θ, dX.

    Same Θ (degree-2 polynomials, pysindy's order) and the same derivative, so
    the coefficients agree to round-off of the final least-squares refit
    (1e-10 absolute on coefficients of size 1 … 30).
    """
    ps = pytest.importorskip("pysindy")
    t, X = lorenz_data
    dX = np.gradient(X, t, axis=0, edge_order=2)
    Theta, names, _ = polynomial_library(X, 2, ["x0", "x1", "x2"])
    ours = stlsq(Theta, dX, threshold, alpha=alpha)
    opt = ps.STLSQ(threshold=threshold, alpha=alpha).fit(Theta, dX)
    np.testing.assert_allclose(ours.T, opt.coef_, rtol=0, atol=1e-10)
    assert ours.shape == (10, 3)
    # the library's order and names are pysindy's
    lib = ps.PolynomialLibrary(degree=2).fit(X)
    assert lib.get_feature_names() == names
    np.testing.assert_allclose(lib.transform(X), Theta)


def test_sindy_equals_pysindy_and_finds_lorenz(lorenz_data):
    ps = pytest.importorskip("pysindy")
    t, X = lorenz_data
    m = SINDy(degree=2, threshold=0.1).fit(X, t[1] - t[0])
    ref = ps.SINDy(optimizer=ps.STLSQ(threshold=0.1, alpha=0.0)).fit(X, t=t[1] - t[0])
    np.testing.assert_allclose(m.coefficients, ref.coefficients(), rtol=0, atol=1e-10)
    eq = m.equations()
    assert eq[0] == "x0' = -9.999 x0 + 9.999 x1" or eq[0] == "x0' = -10.000 x0 + 10.000 x1"
    assert [np.count_nonzero(r) for r in m.coefficients] == [2, 3, 2]
    # the time stamps give the same as the step
    np.testing.assert_allclose(SINDy(threshold=0.1).fit(X, t).coefficients, m.coefficients,
                               atol=1e-9)


def test_derivatives_are_pysindys(lorenz_data):
    ps = pytest.importorskip("pysindy")
    t, X = lorenz_data
    np.testing.assert_allclose(SINDy().derivative(X, t),
                               ps.FiniteDifference()._differentiate(X, t), rtol=1e-12,
                               atol=1e-9)
    np.testing.assert_allclose(SINDy(differentiation="savgol").derivative(X, t),
                               ps.SmoothedFiniteDifference()._differentiate(X, t),
                               rtol=1e-12, atol=1e-9)


def test_discrete_time_map_with_lags_and_input_recovered_exactly():
    rng = np.random.default_rng(0)
    N = 300
    u = rng.uniform(-0.5, 0.5, N)
    x = np.zeros((N, 2))
    x[:2] = [[0.3, -0.2], [0.1, 0.4]]
    for k in range(1, N - 1):
        x[k + 1, 0] = 0.5 * x[k, 0] - 0.3 * x[k - 1, 1] + u[k]
        x[k + 1, 1] = 0.8 * x[k, 1] - 0.4 * x[k, 0] * x[k - 1, 0]
    assert np.abs(x).max() < 5
    m = SINDy(degree=2, lags=1, discrete_time=True, threshold=0.05).fit(x, 1.0, u=u)
    want0 = {"x0[k]": 0.5, "x1[k-1]": -0.3, "u0": 1.0}
    want1 = {"x1[k]": 0.8, "x0[k] x0[k-1]": -0.4}
    for row, want in zip(m.coefficients, (want0, want1)):
        got = {f: c for f, c in zip(m.feature_names, row) if c != 0}
        assert set(got) == set(want)
        np.testing.assert_allclose([got[f] for f in want], list(want.values()), atol=1e-10)
    np.testing.assert_allclose(m.simulate(x[:2], N, u=u[:, None]), x, atol=1e-9)
    np.testing.assert_allclose(m.predict(x, u=u[:, None])[:-1], x[2:], atol=1e-10)
    assert m.equations()[1].startswith("x1[k+1] = ")


def test_continuous_simulation_and_iddata():
    t = np.linspace(0, 4, 2001)
    X = solve_ivp(lambda _, z: [-2 * z[0], z[0] ** 2 - z[1]], (0, 4), [1.0, 0.5], t_eval=t,
                  rtol=1e-12, atol=1e-12).y.T
    m = SINDy(threshold=0.05).fit(IDData(X, dt=t[1], y_names=["p", "q"]))
    assert m.equations(1) == ["p' = -2.0 p", "q' = -1.0 q + 1.0 p^2"]
    np.testing.assert_allclose(m.simulate(X[0], t=t), X, atol=1e-4)


def test_reports():
    pytest.importorskip("pandas")
    t = np.linspace(0, 4, 801)
    X = solve_ivp(lambda _, z: [-2 * z[0], z[0] ** 2 - z[1]], (0, 4), [1.0, 0.5], t_eval=t,
                  rtol=1e-12, atol=1e-12).y.T
    m = SINDy(threshold=0.05).fit(X, t)
    s = m.summary()
    assert "x0': x0" in str(s) and "<table>" in s._repr_html_()
    f = m.to_frame()
    assert list(f.columns) == ["x0'", "x1'"] and f.index[0] == "1"
    np.testing.assert_allclose(f.to_numpy().T, m.coefficients)
    mpl = pytest.importorskip("matplotlib")
    mpl.use("Agg")
    from matplotlib.figure import Figure
    assert isinstance(m.plot(), Figure)
    import matplotlib.pyplot as plt
    plt.close("all")


def test_stlsq_warnings_and_errors():
    rng = np.random.default_rng(1)
    Theta = rng.standard_normal((50, 4))
    y = Theta @ [1e-3, 2e-3, 0, 0]
    with pytest.warns(AdaptidWarning, match="eliminated all"):
        out = stlsq(Theta, y, 1.0)
    assert not out.any()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        np.testing.assert_allclose(stlsq(Theta, Theta @ [1, 2, 0, 0], 0.1), [1, 2, 0, 0],
                                   atol=1e-12)
    with pytest.raises(ValueError, match="threshold must be"):
        stlsq(Theta, y, -1)
    with pytest.raises(ValueError, match="dX must be with N=50 rows"):
        stlsq(Theta, y[:10], 0.1)
    with pytest.raises(ValueError, match="differentiation must be"):
        SINDy(differentiation="spline")
