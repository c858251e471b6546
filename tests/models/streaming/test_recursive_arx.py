"""Streaming model objects (issue 33): RecursiveARX / RecursiveAR.

The references are MATLAB's recursive estimator equations (``recursiveARX``
documentation; Ljung (1999), sec. 11.2) written out in plain NumPy here,
with MATLAB's regressor and zero-initialised lag buffers.
"""

import pickle

import numpy as np
import pytest
from scipy.signal import lfilter

from adaptid.models import AR, ARX, IDData, RecursiveAR, RecursiveARX, StreamResult

N = 300


@pytest.fixture(scope="module")
def data():
    rng = np.random.default_rng(7)
    u = rng.standard_normal(N)
    e = 0.05 * rng.standard_normal(N)
    y = lfilter([0, 0, 1.0, 0.5], [1, -1.5, 0.7], u) + lfilter([1], [1, -1.5, 0.7], e)
    return y, u


def regressors(y, u, na, nb, nk):
    """MATLAB's φ(k) with zero lag buffers, one row per sample."""
    rows = []
    for k in range(len(y)):
        phi = [-(y[k - j] if k - j >= 0 else 0.0) for j in range(1, na + 1)]
        phi += [u[k - j] if k - j >= 0 else 0.0 for j in range(nk, nk + nb)]
        rows.append(phi)
    return np.array(rows)


def reference(Phi, y, method, *, lam=1.0, R1=None, R2=1.0, mu=1.0, bias=np.finfo(float).eps,
              P0=1e4, M=None):
    n = Phi.shape[1]
    th = np.zeros(n)
    P = P0 * np.eye(n)
    T, Yh = [], []
    for k in range(len(y)):
        phi = Phi[k]
        yh = phi @ th
        e = y[k] - yh
        if method == "forgetting":
            K = P @ phi / (lam + phi @ P @ phi)
            th = th + K * e
            P = (P - np.outer(K, phi @ P)) / lam
        elif method == "kalman":
            K = P @ phi / (R2 + phi @ P @ phi)
            th = th + K * e
            P = P - np.outer(K, phi @ P) + R1
        elif method == "ngradient":
            th = th + mu * phi * e / (bias + phi @ phi)
        elif method == "gradient":
            th = th + mu * phi * e
        elif method == "window":
            lo = max(0, k + 1 - M)
            th = np.linalg.lstsq(Phi[lo:k + 1], y[lo:k + 1], rcond=None)[0]
        T.append(th.copy())
        Yh.append(yh)
    return np.array(T), np.array(Yh)


def steps(obj, y, u=None):
    out = [obj.step(y[k]) if u is None else obj.step(y[k], u[k]) for k in range(len(y))]
    return np.array([t for t, _ in out]), np.array([h for _, h in out])


def close(a, b, rtol=1e-10):
    scale = np.maximum(np.abs(b), 1.0)
    assert np.all(np.abs(a - b) <= rtol * scale), np.max(np.abs(a - b) / scale)


CASES = [
    ("forgetting", dict(forgetting=0.98), dict(lam=0.98)),
    ("forgetting", dict(), dict()),
    ("kalman", dict(noise_cov=0.01, noise_var=0.5), dict(R1=0.01 * np.eye(4), R2=0.5)),
    ("ngradient", dict(step=0.3), dict(mu=0.3)),
    ("ngradient", dict(step=0.3, bias=0.1), dict(mu=0.3, bias=0.1)),
    ("gradient", dict(step=0.01), dict(mu=0.01)),
]


@pytest.mark.parametrize("method, opts, ref", CASES)
def test_step_matches_matlab_equations(data, method, opts, ref):
    y, u = data
    obj = RecursiveARX(2, 2, 2, method=method, **opts)
    T, Yh = steps(obj, y, u)
    Tr, Yr = reference(regressors(y, u, 2, 2, 2), y, method, **ref)
    close(T, Tr)
    close(Yh, Yr)


def test_window_is_least_squares_over_last_rows(data):
    y, u = data
    M = 30
    obj = RecursiveARX(2, 2, 2, window=M, P0="diffuse")
    T, Yh = steps(obj, y, u)
    Tr, _ = reference(regressors(y, u, 2, 2, 2), y, "window", M=M)
    close(T[M:], Tr[M:], rtol=1e-8)


def test_ar_matches_equations(data):
    y, _ = data
    T, Yh = steps(RecursiveAR(3, forgetting=0.99), y)
    Tr, Yr = reference(regressors(y, y, 3, 0, 1), y, "forgetting", lam=0.99)
    close(T, Tr)
    close(Yh, Yr)


@pytest.mark.parametrize("opts", [dict(), dict(method="kalman"), dict(method="ngradient"),
                                  dict(method="gradient", step=0.01), dict(window=25),
                                  dict(start="filled"), dict(window=25, start="filled")])
def test_run_equals_steps_bit_for_bit(data, opts):
    y, u = data
    a, b = RecursiveARX(2, 2, 3, **opts), RecursiveARX(2, 2, 3, **opts)
    T, Yh = steps(a, y, u)
    res = b.run((y, u))
    assert isinstance(res, StreamResult)
    np.testing.assert_array_equal(res.theta, T)
    np.testing.assert_array_equal(res.yhat, Yh)
    # and continuing: a run split in two pieces, after some steps
    c = RecursiveARX(2, 2, 3, **opts)
    c.step(y[0], u[0])
    r1 = c.run(y[1:100], u[1:100])
    r2 = c.run(IDData(y[100:], u[100:]))
    np.testing.assert_array_equal(np.vstack([r1.theta, r2.theta]), T[1:])
    np.testing.assert_array_equal(np.concatenate([r1.yhat, r2.yhat]), Yh[1:])


def test_several_inputs(data):
    y, u = data
    u2 = np.cos(np.arange(N) * 0.3)
    U = np.column_stack([u, u2])
    obj = RecursiveARX(2, [2, 1], [1, 0])
    T, Yh = steps(obj, y, U)
    Phi = np.hstack([regressors(y, u, 2, 2, 1), regressors(y, u2, 0, 1, 0)])
    Tr, Yr = reference(Phi, y, "forgetting")
    close(T, Tr)
    close(Yh, Yr)
    res = RecursiveARX(2, [2, 1], [1, 0]).run(y, U)
    np.testing.assert_array_equal(res.theta, T)
    assert obj.names == ("a1", "a2", "b0_0", "b0_1", "b1_0")


@pytest.mark.parametrize("est", ["rls", "window", "kalman"])
def test_filled_run_equals_fit_recursive(data, est):
    import adaptid

    y, u = data
    kw = {"rls": dict(forgetting=0.99), "window": dict(window=40),
          "kalman": dict(method="kalman", noise_cov=0.01)}[est]
    core = {"rls": adaptid.estimator("rls", 4, forgetting=0.99),
            "window": adaptid.estimator("window", 4, window=40),
            "kalman": adaptid.estimator("kalman", 4, process_cov=0.01 * np.eye(4))}[est]
    obj = RecursiveARX(2, 2, 3, start="filled", **kw)
    res = obj.run(y, u)
    traj = ARX(2, 2, 3).fit_recursive(y, u, core)
    s = 4                                     # max(na, nk + nb - 1)
    assert np.all(np.isnan(res.yhat[:s])) and not np.any(np.isnan(res.yhat[s:]))
    np.testing.assert_array_equal(res.theta[:s], np.zeros((s, 4)))
    np.testing.assert_array_equal(res.theta[s:], traj.theta)
    ar = RecursiveAR(2, start="filled").run(y)
    np.testing.assert_array_equal(ar.theta[2:], AR(2).fit_recursive(y).theta)


@pytest.mark.parametrize("opts", [dict(), dict(method="kalman"), dict(method="ngradient"),
                                  dict(window=25, start="filled")])
def test_state_saved_midstream_continues_bit_for_bit(data, tmp_path, opts):
    y, u = data
    whole = RecursiveARX(2, 2, 3, **opts)
    T, Yh = steps(whole, y, u)
    obj = RecursiveARX(2, 2, 3, **opts)
    obj.run(y[:2], u[:2])                     # mid-fill for start="filled"
    path = tmp_path / "s.npz"
    obj.save_state(path)
    back = RecursiveARX.load_state(path)
    res = back.run(y[2:], u[2:])
    np.testing.assert_array_equal(res.theta, T[2:])
    np.testing.assert_array_equal(res.yhat, Yh[2:])
    again = RecursiveARX.from_state(obj.get_state())
    np.testing.assert_array_equal(steps(again, y[2:], u[2:])[0], T[2:])
    import adaptid
    assert type(adaptid.load_state(path)) is RecursiveARX
    with pytest.raises(ValueError):
        RecursiveAR.load_state(path)


def test_ar_state_and_pickle(data, tmp_path):
    y, _ = data
    obj = RecursiveAR(2, forgetting=0.99)
    obj.run(y[:150])
    obj.save_state(tmp_path / "ar.npz")
    rest = RecursiveAR(2, forgetting=0.99)
    ref = rest.run(y).theta[150:]
    np.testing.assert_array_equal(RecursiveAR.load_state(tmp_path / "ar.npz").run(y[150:]).theta,
                                  ref)
    clone = pickle.loads(pickle.dumps(obj))
    np.testing.assert_array_equal(clone.run(y[150:]).theta, ref)


def test_reset_and_to_model(data):
    y, u = data
    obj = RecursiveARX(2, 2, 1, dt=0.1)
    first = obj.run(y, u).theta
    obj.reset()
    np.testing.assert_array_equal(obj.theta, np.zeros(4))
    np.testing.assert_array_equal(obj.run(y, u).theta, first)
    m = obj.to_model()
    assert isinstance(m, ARX) and m.dt == 0.1 and m.names == ("a1", "a2", "b0", "b1")
    np.testing.assert_array_equal(m.A, np.r_[1.0, first[-1, :2]])
    assert isinstance(RecursiveAR(2).to_model(), AR)


def test_pandas_record_and_frame(data):
    pd = pytest.importorskip("pandas")
    y, u = data
    idx = pd.date_range("2024-01-01", periods=N, freq="80ms")
    df = pd.DataFrame({"y": y, "u": u}, index=idx)
    obj = RecursiveARX(2, 2, 1)
    res = obj.run(df)
    np.testing.assert_array_equal(res.theta, RecursiveARX(2, 2, 1).run(y, u).theta)
    assert obj.dt == pytest.approx(0.08)
    frame = res.to_frame()
    assert list(frame.columns) == ["a1", "a2", "b0", "b1", "yhat"]


def test_errors():
    with pytest.raises(ValueError, match="method"):
        RecursiveARX(1, 1, 1, method="rls")
    with pytest.raises(ValueError, match="start"):
        RecursiveARX(1, 1, 1, start="full")
    with pytest.raises(ValueError, match="window"):
        RecursiveARX(1, 1, 1, method="kalman", window=10)
    with pytest.raises(TypeError, match="u"):
        RecursiveARX(1, 1, 1).step(1.0)
    with pytest.raises(ValueError, match="y"):
        RecursiveARX(1, 1, 1).step([1.0, 2.0], 1.0)
    with pytest.raises(TypeError, match="u"):
        RecursiveAR(1).run((np.ones(5), np.ones(5)))
    with pytest.raises(ValueError):
        RecursiveARX(0, 0, 1)


def test_ar_model_predicts_as_a_fitted_ar(data):
    # RecursiveAR.to_model() once lacked AR's internal all-zero input column: predict raised
    y, _ = data
    obj = RecursiveAR(2)
    th = obj.run(y).theta[-1]
    ref = AR(2).fit(y)
    ref.theta = th.copy()
    np.testing.assert_array_equal(obj.to_model().predict(y), ref.predict(y))
