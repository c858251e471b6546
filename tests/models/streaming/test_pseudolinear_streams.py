"""Streaming pseudo-linear models (issue 33): RecursiveARMAX / ARMA / OE / BJ.

The references: the extended-least-squares / pseudo-linear-regression
recursion of Ljung (1999), sec. 11.3, with MATLAB's recursive estimator
updates (``recursiveARMAX`` documentation: forgetting factor, Kalman
filter, normalised gradient, gradient) and zero-initialised lag buffers,
written out in plain NumPy below (covariance form of P; the signals of the
regressor formed from each model's definition, Ljung (1999), eq. 4.44);
and the batch models' ``fit_recursive`` on the same data.
"""

import pickle

import numpy as np
import pytest
from scipy.signal import lfilter

import adaptid
from adaptid.models import (ARMA, ARMAX, BJ, OE, IDData, RecursiveARMA, RecursiveARMAX,
                            RecursiveBJ, RecursiveOE, StreamResult)

N = 300


@pytest.fixture(scope="module")
def data():
    rng = np.random.default_rng(3)
    u = rng.standard_normal(N)
    e = 0.1 * rng.standard_normal(N)
    y = lfilter([0, 1.0, 0.5], [1, -1.2, 0.5], u) + lfilter([1, 0.4], [1, -0.6], e)
    return y, u


#: kind -> (stream class, batch class, orders, number of parameters)
MODELS = {
    "armax": (RecursiveARMAX, ARMAX, (2, 2, 1, 1), 5),
    "arma": (RecursiveARMA, ARMA, (2, 1), 3),
    "oe": (RecursiveOE, OE, (2, 2, 1), 4),
    "bj": (RecursiveBJ, BJ, (2, 1, 1, 2, 1), 6),
}


def _lag(x, j):
    return x[-j] if len(x) >= j else 0.0


def _phi(kind, orders, yp, up, uk, sig):
    """MATLAB's regressor from the past samples (zero before the first) and the signals."""
    if kind in ("armax", "arma"):
        na, nc = orders[0], orders[2] if kind == "armax" else orders[1]
        nb, nk = (orders[1], orders[3]) if kind == "armax" else (0, 1)
        ulags = [uk if j == 0 else _lag(up, j) for j in range(nk, nk + nb)]
        return np.r_[[-_lag(yp, j) for j in range(1, na + 1)], ulags,
                     [_lag(sig["eps"], j) for j in range(1, nc + 1)]]
    nb, nk = orders[0], orders[-1]
    ulags = [uk if j == 0 else _lag(up, j) for j in range(nk, nk + nb)]
    if kind == "oe":
        return np.r_[ulags, [-_lag(sig["w"], j) for j in range(1, orders[1] + 1)]]
    nc, nd, nf = orders[1:4]
    return np.r_[ulags, [_lag(sig["eps"], j) for j in range(1, nc + 1)],
                 [-_lag(sig["v"], j) for j in range(1, nd + 1)],
                 [-_lag(sig["w"], j) for j in range(1, nf + 1)]]


def _signals(kind, orders, phi, th, yk, sig):
    """The a-posteriori signals of sample k from the estimate after it."""
    sig["eps"].append(yk - phi @ th)
    if kind in ("oe", "bj"):
        nb = orders[0]
        plant = np.r_[np.ones(nb), np.zeros(phi.size - nb)]
        plant[phi.size - orders[-2]:] = 1.0               # the f columns (last nf)
        w = (phi * plant) @ th
        sig["w"].append(w)
        sig["v"].append(yk - w)


def reference(kind, orders, y, u, method, *, lam=1.0, R1=None, R2=1.0, mu=1.0,
              bias=np.finfo(float).eps, P0=1e4):
    """θ after each sample and ŷ before it, by the textbook recursion."""
    n = MODELS[kind][3]
    th, P = np.zeros(n), P0 * np.eye(n)
    sig = {"eps": [], "w": [], "v": []}
    T, Yh = [], []
    for k in range(len(y)):
        phi = _phi(kind, orders, list(y[:k]), list(u[:k]), u[k], sig)
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
        else:
            th = th + mu * phi * e
        _signals(kind, orders, phi, th, y[k], sig)
        T.append(th.copy())
        Yh.append(yh)
    return np.array(T), np.array(Yh)


def make(kind, **opts):
    cls, _, orders, _ = MODELS[kind]
    return cls(*orders, **opts)


def steps(obj, y, u, kind):
    out = [obj.step(y[k]) if kind == "arma" else obj.step(y[k], u[k]) for k in range(len(y))]
    return np.array([t for t, _ in out]), np.array([h for _, h in out])


def record(kind, y, u):
    return (y,) if kind == "arma" else (y, u)


def close(a, b, rtol):
    scale = np.maximum(np.abs(b), 1.0)
    assert np.all(np.abs(a - b) <= rtol * scale), np.max(np.abs(a - b) / scale)


CASES = [
    ("forgetting", dict(forgetting=0.98), dict(lam=0.98)),
    ("forgetting", dict(), dict()),
    ("kalman", dict(noise_cov=0.01, noise_var=0.5), dict(R2=0.5)),
    ("ngradient", dict(step=0.3, bias=0.1), dict(mu=0.3, bias=0.1)),
    ("ngradient", dict(step=0.3), dict(mu=0.3)),
    ("gradient", dict(step=0.01), dict(mu=0.01)),
]


@pytest.mark.parametrize("kind", list(MODELS))
@pytest.mark.parametrize("method, opts, ref", CASES)
def test_step_matches_the_textbook_recursion(data, kind, method, opts, ref):
    y, u = data
    n = MODELS[kind][3]
    if method == "kalman":
        ref = dict(ref, R1=0.01 * np.eye(n))
    T, Yh = steps(make(kind, method=method, **opts), y, u, kind)
    Tr, Yr = reference(kind, MODELS[kind][2], y, u, method, **ref)
    # U-D (Bierman) against the covariance form: rounding of order 1e-13, carried by the
    # signals fed back into the regressor; 1e-8 leaves a wide margin and still fails on
    # any wrong lag, sign or a-priori/a-posteriori mix-up (those are O(1e-2) here)
    rtol = 1e-11 if method in ("gradient", "ngradient") else 1e-8
    close(T, Tr, rtol)
    close(Yh, Yr, rtol)


@pytest.mark.parametrize("kind", list(MODELS))
@pytest.mark.parametrize("est", ["rls", "window", "kalman", "diffuse"])
def test_filled_run_equals_fit_recursive(data, kind, est):
    y, u = data
    cls, model, orders, n = MODELS[kind]
    kw, core = {"rls": (dict(forgetting=0.99), ("rls", dict(forgetting=0.99))),
                "window": (dict(window=60), ("window", dict(window=60))),
                "kalman": (dict(method="kalman", noise_cov=0.01),
                           ("kalman", dict(process_cov=0.01 * np.eye(n)))),
                "diffuse": (dict(P0="diffuse", forgetting=0.995),
                            ("rls", dict(P0="diffuse", forgetting=0.995)))}[est]
    obj = cls(*orders, start="filled", **kw)
    res = obj.run(*record(kind, y, u))
    traj = model(*orders).fit_recursive(*record(kind, y, u),
                                        adaptid.estimator(core[0], n, **core[1]))
    s = N - traj.theta.shape[0]                       # the batch model's first row
    assert s == obj._s and s == {"armax": 2, "arma": 2, "oe": 2, "bj": 2}[kind]
    assert np.all(np.isnan(res.yhat[:s])) and not np.any(np.isnan(res.yhat[s:]))
    np.testing.assert_array_equal(res.theta[:s], np.zeros((s, n)))
    np.testing.assert_array_equal(res.theta[s:], traj.theta)
    assert obj.n_updates == N - s


def test_several_inputs_filled_equals_fit_recursive(data):
    y, u = data
    U = np.column_stack([u, np.cos(0.3 * np.arange(N))])
    y = y + lfilter([0, 0.5], [1, -0.5], U[:, 1])
    for obj, model in [(RecursiveOE([2, 1], [1, 1], [1, 0], start="filled"),
                        OE([2, 1], [1, 1], [1, 0])),
                       (RecursiveBJ([2, 1], 1, 1, [1, 1], [1, 0], start="filled"),
                        BJ([2, 1], 1, 1, [1, 1], [1, 0]))]:
        res = obj.run(y, U)
        traj = model.fit_recursive(y, U)
        np.testing.assert_array_equal(res.theta[N - traj.theta.shape[0]:], traj.theta)
        assert obj.names == model.names


RUN_OPTS = [dict(), dict(method="kalman"), dict(method="ngradient"),
            dict(method="gradient", step=0.01), dict(window=40), dict(start="filled"),
            dict(window=40, start="filled", P0="diffuse"), dict(forgetting=0.98)]


@pytest.mark.parametrize("kind", list(MODELS))
@pytest.mark.parametrize("opts", RUN_OPTS)
def test_run_equals_steps_bit_for_bit(data, kind, opts):
    y, u = data
    T, Yh = steps(make(kind, **opts), y, u, kind)
    res = make(kind, **opts).run(*record(kind, y, u))
    assert isinstance(res, StreamResult) and res.names == make(kind).names
    np.testing.assert_array_equal(res.theta, T)
    np.testing.assert_array_equal(res.yhat, Yh)
    # continuing: one step, then a run split in two (the second an IDData)
    c = make(kind, **opts)
    c.step(y[0]) if kind == "arma" else c.step(y[0], u[0])
    r1 = c.run(*record(kind, y[1:100], u[1:100]))
    r2 = c.run(IDData(y[100:]) if kind == "arma" else IDData(y[100:], u[100:]))
    np.testing.assert_array_equal(np.vstack([r1.theta, r2.theta]), T[1:])
    np.testing.assert_array_equal(np.concatenate([r1.yhat, r2.yhat]), Yh[1:])


def test_window_is_least_squares_over_the_rows_formed(data):
    y, u = data
    M = 40
    obj = RecursiveARMAX(2, 2, 1, 1, window=M, P0="diffuse")
    T, _ = steps(obj, y, u, "armax")
    # the rows the recursion formed: ε̄ₖ = yₖ − φₖᵀθₖ from its own track
    sig = {"eps": [], "w": [], "v": []}
    rows = []
    for k in range(N):
        phi = _phi("armax", (2, 2, 1, 1), list(y[:k]), list(u[:k]), u[k], sig)
        _signals("armax", (2, 2, 1, 1), phi, T[k], y[k], sig)
        rows.append(phi)
    rows = np.array(rows)
    for k in range(M, N, 37):
        ls = np.linalg.lstsq(rows[k - M + 1:k + 1], y[k - M + 1:k + 1], rcond=None)[0]
        close(T[k], ls, 1e-8)                # U-D downdates against one QR solve


@pytest.mark.parametrize("kind", list(MODELS))
@pytest.mark.parametrize("opts", [dict(), dict(method="kalman"), dict(method="ngradient"),
                                  dict(window=25, start="filled"), dict(P0="diffuse")])
def test_state_saved_midstream_continues_bit_for_bit(data, tmp_path, kind, opts):
    y, u = data
    T, Yh = steps(make(kind, **opts), y, u, kind)
    obj = make(kind, **opts)
    obj.run(*record(kind, y[:1], u[:1]))     # mid-fill for start="filled"
    obj.run(*record(kind, y[1:3], u[1:3]))
    path = tmp_path / "s.npz"
    obj.save_state(path)
    cls = MODELS[kind][0]
    back = cls.load_state(path)
    res = back.run(*record(kind, y[3:], u[3:]))
    np.testing.assert_array_equal(res.theta, T[3:])
    np.testing.assert_array_equal(res.yhat, Yh[3:])
    again = cls.from_state(obj.get_state())
    np.testing.assert_array_equal(steps(again, y[3:], u[3:], kind)[0], T[3:])
    assert type(adaptid.load_state(path)) is cls
    clone = pickle.loads(pickle.dumps(obj))
    np.testing.assert_array_equal(clone.run(*record(kind, y[3:], u[3:])).theta, T[3:])
    other = RecursiveOE if cls is not RecursiveOE else RecursiveBJ
    with pytest.raises(ValueError):
        other.load_state(path)


def test_state_dicts_refused(data):
    y, u = data
    obj = RecursiveARMAX(1, 1, 1, 1)
    obj.run(y[:20], u[:20])
    st = obj.get_state()
    with pytest.raises(ValueError, match="state"):
        RecursiveOE.from_state(st)
    with pytest.raises(ValueError, match="missing key"):
        RecursiveARMAX.from_state({k: v for k, v in st.items() if k != "vh"})
    bad = dict(st, D=-np.abs(st["D"]))
    with pytest.raises(ValueError, match="U-D"):
        RecursiveARMAX.from_state(bad)
    bad = dict(st, vh=np.full((1, 3), np.nan))
    with pytest.raises(ValueError, match="vh"):
        RecursiveARMAX.from_state(bad)
    bad = dict(st, options=dict(st["options"], method="kalman"))
    with pytest.raises(ValueError, match="inner"):
        RecursiveARMAX.from_state(bad)
    with pytest.raises(TypeError):
        RecursiveARMAX.from_state([1])


@pytest.mark.parametrize("kind", list(MODELS))
def test_reset_and_to_model(data, kind):
    y, u = data
    cls, model, orders, n = MODELS[kind]
    obj = cls(*orders, dt=0.1, forgetting=0.99)
    first = obj.run(*record(kind, y, u)).theta
    obj.reset()
    np.testing.assert_array_equal(obj.theta, np.zeros(n))
    assert obj.n_updates == 0
    np.testing.assert_array_equal(obj.run(*record(kind, y, u)).theta, first)
    m = obj.to_model()
    assert type(m) is model and m.dt == 0.1 and m.names == obj.names
    np.testing.assert_array_equal(m.theta, first[-1])
    # the model predicts with that θ as a batch model with the same θ does
    ref = model(*orders).fit(*record(kind, y, u))
    ref.theta = first[-1].copy()
    np.testing.assert_array_equal(m.predict(*record(kind, y, u)), ref.predict(*record(kind, y, u)))
    P = obj.P
    np.testing.assert_array_equal(P, P.T)
    assert np.all(np.linalg.eigvalsh(P) > 0)
    assert make(kind, method="gradient").P is None


def test_pandas_record_sets_dt(data):
    pd = pytest.importorskip("pandas")
    y, u = data
    idx = pd.date_range("2024-01-01", periods=N, freq="80ms")
    obj = RecursiveOE(2, 2, 1)
    res = obj.run(pd.DataFrame({"y": y, "u": u}, index=idx))
    np.testing.assert_array_equal(res.theta, RecursiveOE(2, 2, 1).run(y, u).theta)
    assert obj.dt == pytest.approx(0.08) and obj.to_model().dt == pytest.approx(0.08)
    assert list(res.to_frame().columns) == ["b0", "b1", "f1", "f2", "yhat"]


def test_bad_input():
    with pytest.raises(ValueError, match="method"):
        RecursiveARMAX(1, 1, 1, 1, method="rpem")
    with pytest.raises(ValueError, match="window"):
        RecursiveOE(1, 1, 1, method="kalman", window=10)
    with pytest.raises(ValueError, match="start"):
        RecursiveBJ(1, 1, 1, 1, 1, start="full")
    with pytest.raises(ValueError, match="nb"):
        RecursiveOE(0, 1, 1)
    with pytest.raises(ValueError, match="forgetting"):
        RecursiveARMA(1, 1, forgetting=1.5)
    with pytest.raises(TypeError, match="u"):
        RecursiveARMAX(1, 1, 1, 1).step(1.0)
    with pytest.raises(ValueError, match="y"):
        RecursiveBJ(1, 1, 1, 1, 1).step([1.0, 2.0], 1.0)
    with pytest.raises(TypeError, match="u"):
        RecursiveARMA(1, 1).run((np.ones(5), np.ones(5)))
    with pytest.raises(ValueError, match="u"):
        RecursiveOE(1, 1, 1).run(np.ones(5), np.ones(4))
    with pytest.raises(ValueError, match="y"):
        RecursiveARMAX(1, 1, 1, 1).run(np.r_[1.0, np.nan], np.ones(2))
    with pytest.raises(TypeError, match="unexpected"):
        RecursiveOE(1, 1, 1, forgeting=0.9)
    # a refused call leaves the state as it was
    obj = RecursiveARMAX(1, 1, 1, 1)
    obj.run(np.ones(5), np.ones(5))
    before = obj.get_state()
    with pytest.raises(ValueError):
        obj.run(np.ones(3), np.ones(2))
    after = obj.get_state()
    for key in ("theta", "U", "D", "vh", "ybuf", "ubuf"):
        np.testing.assert_array_equal(after[key], before[key])
    assert after["options"] == before["options"]


def test_long_window_state_file(tmp_path):
    # the window buffer (M, n) is longer than a state file's side bound (2048): stored packed
    rng = np.random.default_rng(1)
    y, u = rng.standard_normal(3000), rng.standard_normal(3000)
    obj = RecursiveARMAX(1, 1, 1, 1, window=2500)
    obj.run(y[:2600], u[:2600])
    obj.save_state(tmp_path / "w.npz")
    back = RecursiveARMAX.load_state(tmp_path / "w.npz")
    np.testing.assert_array_equal(back.run(y[2600:], u[2600:]).theta,
                                  obj.run(y[2600:], u[2600:]).theta)
    # beyond what a file holds: refused at save, naming the limit
    with pytest.raises(ValueError, match="2048"):
        RecursiveARMAX(1, 1, 1, 1, window=2_000_000).save_state(tmp_path / "x.npz")


def test_result_summary_and_plot(data):
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    y, u = data
    res = RecursiveBJ(2, 1, 1, 2, 1, start="filled").run(y, u)
    text = res.summary()
    assert f"{N} samples, {N - 2} one-step predictions" in text
    assert all(name in text for name in res.names)
    assert f"{res.theta[-1, 0]: .6g}" in text
    fig = res.plot()
    assert isinstance(fig, Figure)
    assert [a.get_ylabel() for a in fig.axes] == list(res.names)   # one panel per parameter


@pytest.mark.parametrize("strategy", [adaptid.forgetting.Directional(0.98),
                                      adaptid.forgetting.Variable(0.95, 0.1, 200.0)])
def test_forgetting_strategy_equals_fit_recursive(data, strategy):
    y, u = data
    obj = RecursiveARMAX(2, 2, 1, 1, forgetting=strategy, start="filled")
    res = obj.run(y, u)
    traj = ARMAX(2, 2, 1, 1).fit_recursive(y, u, adaptid.RLS(5, forgetting=strategy))
    np.testing.assert_array_equal(res.theta[2:], traj.theta)
    # and piecewise, through a state file's dict
    a = RecursiveARMAX(2, 2, 1, 1, forgetting=strategy, start="filled")
    a.run(y[:150], u[:150])
    b = RecursiveARMAX.from_state(a.get_state())
    np.testing.assert_array_equal(b.run(y[150:], u[150:]).theta, res.theta[150:])
