"""RecursiveIV (issue 37, point 1): the recursion against the IV normal equations
solved in NumPy, step against run, Monte Carlo consistency, state files, errors."""

import pickle
import warnings

import numpy as np
import pytest
from scipy.signal import lfilter

import adaptid
from adaptid import DefinitenessLossWarning, StateFileError
from adaptid.models import ARX, IDData, RecursiveARX, RecursiveIV, RecursiveIVResult

N = 400
# ARX(2, 2, 1) with coloured equation noise: A y = B u + C e, C = 1 + 0.9 q⁻¹
A, B, C = [1, -1.5, 0.7], [0, 1.0, 0.5], [1, 0.9]
TRUE = np.array([-1.5, 0.7, 1.0, 0.5])


def _record(n, seed, sigma=0.5):
    rng = np.random.default_rng(seed)
    u, e = rng.standard_normal(n), rng.standard_normal(n)
    return lfilter(B, A, u) + sigma * lfilter(C, A, e), u


def _lags(s, na_or_lags, sign=1.0):
    """Columns sign·s(k − j) for the lags j given, zero before the first sample."""
    return np.column_stack([sign * np.r_[np.zeros(j), s[: s.size - j]] for j in na_or_lags])


def _rows(y, x, U, na, nb, nk):
    """φ rows and auxiliary instrument rows written out (zero initial conditions)."""
    ucols = [_lags(U[:, i], range(nk[i], nk[i] + nb[i])) for i in range(U.shape[1])]
    Phi = np.column_stack([_lags(y, range(1, na + 1), -1.0)] * (na > 0) + ucols)
    Zx = np.column_stack([_lags(x, range(1, na + 1), -1.0)] * (na > 0) + ucols)
    return Phi, Zx


def _batch(Phi, Z, y, k, P0, theta0, lam):
    """θ after samples 0 … k−1 from the IV normal equations with the prior (np.linalg.solve):
    (λᵏP0⁻¹ + Σ λ^(k−1−j) ζⱼφⱼᵀ) θ = λᵏP0⁻¹θ0 + Σ λ^(k−1−j) ζⱼ yⱼ."""
    w = lam ** np.arange(k - 1, -1, -1)
    Pi = np.linalg.inv(P0)  # the prior's information (P0 is small and well conditioned)
    R = lam ** k * Pi + (Z[:k] * w[:, None]).T @ Phi[:k]
    r = lam ** k * Pi @ theta0 + (Z[:k] * w[:, None]).T @ y[:k]
    return np.linalg.solve(R, r), R


CASES = [
    dict(na=2, nb=[2], nk=[1], lam=1.0, warmup=0, P0=100.0),
    dict(na=2, nb=[2], nk=[1], lam=0.98, warmup=None, P0=10.0),
    dict(na=1, nb=[2, 1], nk=[0, 2], lam=0.995, warmup=7, P0="matrix"),
]


@pytest.mark.parametrize("case", CASES)
def test_recursion_equals_batch_iv_on_the_rows_it_used(case):
    """After k samples θ_k solves the (forgetting-weighted) IV normal equations with the
    prior, on the instrument rows the recursion used; those rows are rebuilt here from
    the auxiliary output x, which itself must be the simulation x_k = ζ_kᵀθ_k."""
    na, nb, nk, lam = case["na"], case["nb"], case["nk"], case["lam"]
    y, u = _record(N, 1)
    U = np.column_stack([u, np.cos(0.3 * np.arange(N)) + u ** 2][: len(nb)])
    n = na + sum(nb)
    rng = np.random.default_rng(2)
    if case["P0"] == "matrix":
        M = rng.standard_normal((n, n))
        P0 = 5.0 * np.eye(n) + M @ M.T
    else:
        P0 = case["P0"] * np.eye(n)
    theta0 = 0.1 * rng.standard_normal(n)
    single = len(nb) == 1
    obj = RecursiveIV(na, nb[0] if single else nb, nk[0] if single else nk,
                      P0=P0 if case["P0"] == "matrix" else case["P0"], theta0=theta0,
                      forgetting=lam, warmup=case["warmup"])
    warm = 10 * n if case["warmup"] is None else case["warmup"]
    with warnings.catch_warnings():
        # without a warm-up the first instruments (from θ0) flip the sign of det R a few
        # times (status 1); the updates are made and the identity below still holds
        warnings.simplefilter("ignore", DefinitenessLossWarning)
        res = obj.run(y, U[:, 0] if single else U)
    Phi, Zx = _rows(y, res.x, U, na, nb, nk)
    np.testing.assert_allclose(res.x, np.sum(Zx * res.theta, axis=1), rtol=0, atol=1e-12)
    Z = Zx.copy()
    Z[:warm] = Phi[:warm]                                   # the warm-up: ζ = φ (RLS)
    np.testing.assert_array_equal(res.instruments, Z)
    assert not (res.status == 2).any()
    assert warm == 0 or not res.status.any()
    for k in (1, 3, n, 2 * n + 1, 50, N // 2, N):
        th, R = _batch(Phi, Z, y, k, P0, theta0, lam)
        np.testing.assert_allclose(res.theta[k - 1], th, rtol=1e-8, atol=1e-9)
    # P is the inverse of the (unsymmetric) IV matrix, not symmetrised
    np.testing.assert_allclose(obj.P @ R, np.eye(n), atol=1e-8)
    assert not np.allclose(obj.P, obj.P.T, rtol=1e-6, atol=0)


def test_iv_covariance_estimate_against_numpy():
    """to_model().cov = σ̂² R⁻¹ (Σ λ^(k−j) ζζᵀ) R⁻ᵀ with σ̂² the weighted sum of squared
    residuals of the final θ over (Σ weights − n); λ = 1 and a vanishing prior give ivx's
    σ̂²(ZᵀΦ)⁻¹ZᵀZ(ΦᵀZ)⁻¹ on the same rows."""
    y, u = _record(1500, 3)
    for lam, P0 in ((1.0, 1e6), (0.99, 50.0)):
        obj = RecursiveIV(2, 2, 1, P0=P0, forgetting=lam)
        res = obj.run(y, u)
        m = obj.to_model()
        Phi, _ = _rows(y, res.x, u[:, None], 2, [2], [1])
        Z = res.instruments
        k = y.size
        th, R = _batch(Phi, Z, y, k, P0 * np.eye(4), np.zeros(4), lam)
        w = lam ** np.arange(k - 1, -1, -1)
        eps = y - Phi @ th
        s2 = (w * eps ** 2).sum() / (w.sum() - 4)
        Ri = np.linalg.inv(R)
        cov = s2 * Ri @ ((Z * w[:, None]).T @ Z) @ Ri.T
        assert isinstance(m, ARX) and m.method == "riv"
        np.testing.assert_allclose(m.theta, th, rtol=1e-9)
        assert m.noise_variance == pytest.approx(s2, rel=1e-7)
        np.testing.assert_allclose(m.cov, cov, rtol=1e-6)
        if lam == 1.0:
            S = np.linalg.solve(Z.T @ Phi, Z.T @ Z)
            ivx_cov = s2 * np.linalg.solve(Z.T @ Phi, S.T).T
            np.testing.assert_allclose(m.cov, ivx_cov, rtol=1e-5)


def _steps(obj, y, U):
    out = [obj.step(y[k], U[k]) for k in range(y.size)]
    return np.array([t for t, _ in out]), np.array([h for _, h in out])


@pytest.mark.parametrize("opts", [dict(), dict(forgetting=0.97, warmup=0),
                                  dict(warmup=3, theta0=[0.1, 0, 0.2, 0, 0.3])])
def test_run_equals_steps_bit_for_bit(opts):
    y, u = _record(300, 4)
    U = np.column_stack([u, np.sin(np.arange(300))])
    whole = RecursiveIV(2, [2, 1], [1, 0], **opts)
    res = whole.run(y, U)
    T, Yh = _steps(RecursiveIV(2, [2, 1], [1, 0], **opts), y, U)
    np.testing.assert_array_equal(res.theta, T)
    np.testing.assert_array_equal(res.yhat, Yh)
    # chunks: run, steps, run
    obj = RecursiveIV(2, [2, 1], [1, 0], **opts)
    a = obj.run(y[:2], U[:2]).theta
    b, _ = _steps(obj, y[2:40], U[2:40])
    c = obj.run(y[40:], U[40:]).theta
    np.testing.assert_array_equal(np.vstack([a, b, c]), res.theta)
    np.testing.assert_array_equal(obj.P, whole.P)
    assert obj.n_updates == whole.n_updates == 300


def test_monte_carlo_consistent_where_least_squares_is_biased():
    """50 records of 20000 samples: the RIV means lie within 3 standard errors of the
    true θ, least-squares ARX (numpy.linalg.lstsq) is outside for the A coefficients;
    the standard errors of to_model() match the spread over the records."""
    R, n_samples = 50, 20000
    riv, ls, se = [], [], []
    for r in range(R):
        y, u = _record(n_samples, 1000 + r)
        obj = RecursiveIV(2, 2, 1)
        riv.append(obj.run((y, u)).theta[-1])
        se.append(obj.to_model().stderr)
        Phi, _ = _rows(y, y, u[:, None], 2, [2], [1])
        ls.append(np.linalg.lstsq(Phi, y, rcond=None)[0])
    riv, ls = np.array(riv), np.array(ls)
    z_riv = (riv.mean(0) - TRUE) / (riv.std(0, ddof=1) / np.sqrt(R))
    z_ls = (ls.mean(0) - TRUE) / (ls.std(0, ddof=1) / np.sqrt(R))
    assert np.all(np.abs(z_riv) < 3), z_riv
    assert np.all(np.abs(z_ls[:2]) > 3), z_ls
    # asymptotic standard errors vs the Monte Carlo spread (50 runs: ±30 %)
    np.testing.assert_allclose(np.mean(se, 0), riv.std(0, ddof=1), rtol=0.3)


def test_state_file_midstream_continues_bit_for_bit(tmp_path):
    y, u = _record(300, 5)
    whole = RecursiveIV(2, 2, 1, forgetting=0.99, warmup=25)
    ref = whole.run(y, u)
    obj = RecursiveIV(2, 2, 1, forgetting=0.99, warmup=25)
    obj.run(y[:20], u[:20])                  # still inside the warm-up
    path = tmp_path / "riv.npz"
    obj.save_state(path)
    back = RecursiveIV.load_state(path)
    assert type(adaptid.load_state(path)) is RecursiveIV
    res = back.run(y[20:], u[20:])
    np.testing.assert_array_equal(res.theta, ref.theta[20:])
    np.testing.assert_array_equal(res.x, ref.x[20:])
    np.testing.assert_array_equal(back.P, whole.P)
    again = RecursiveIV.from_state(obj.get_state())
    np.testing.assert_array_equal(again.run(y[20:], u[20:]).theta, ref.theta[20:])
    clone = pickle.loads(pickle.dumps(obj))
    np.testing.assert_array_equal(clone.run(y[20:], u[20:]).theta, ref.theta[20:])
    np.testing.assert_array_equal(back.to_model().cov, whole.to_model().cov)
    # a file of another class is refused by this one, and a damaged dict is named
    RecursiveARX(2, 2, 1).save_state(tmp_path / "arx.npz")
    with pytest.raises(StateFileError):
        RecursiveIV.load_state(tmp_path / "arx.npz")
    with pytest.raises(StateFileError):
        RecursiveARX.load_state(path)
    st = obj.get_state()
    st["P"] = np.full((3, 3), np.nan)
    with pytest.raises(ValueError, match=r"state\['P'\]"):
        RecursiveIV.from_state(st)
    with pytest.raises(ValueError, match="state"):
        RecursiveIV.from_state({k: v for k, v in obj.get_state().items() if k != "S"})


@pytest.mark.parametrize("orders", [(1, 1, 1), (0, 1, 0), (3, [1, 2], [4, 0])])
def test_state_file_of_small_and_wide_structures(tmp_path, orders):
    """The file container bounds the own arrays by the outer n_params: the smallest
    structure (n = 1) and long input lags must still round-trip."""
    y, u = _record(60, 10)
    U = u if np.ndim(orders[1]) == 0 else np.column_stack([u, np.roll(u, 3)])
    obj = RecursiveIV(*orders, warmup=5)
    ref = RecursiveIV(*orders, warmup=5).run(y, U).theta
    obj.run(y[:30], U[:30])
    obj.save_state(tmp_path / "s.npz")
    back = RecursiveIV.load_state(tmp_path / "s.npz")
    np.testing.assert_array_equal(back.run(y[30:], U[30:]).theta, ref[30:])


def _hand_case(b0):
    """na = nb = nk = 1, P0 = I, θ0 = [0, b0], u = [1, 0, 0], y = [0, 1, 0.5], no warm-up.
    Sample 0: φ = ζ = 0, nothing moves. Sample 1: φ = [0, 1], ζ = [0, 1], ε = 1 − b0,
    θ = [0, (b0 + 1)/2], P = [[1, 0], [0, 1/2]], x₁ = (b0 + 1)/2. Sample 2: φ = [−1, 0],
    ζ = [−x₁, 0]: λ + φᵀPζ = 1 + x₁ = (b0 + 3)/2 — zero for b0 = −3, −1 for b0 = −5."""
    obj = RecursiveIV(1, 1, 1, theta0=[0.0, b0], P0=1.0, warmup=0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = obj.run(([0.0, 1.0, 0.5], [1.0, 0.0, 0.0]))
    return obj, res, [w for w in caught if issubclass(w.category, DefinitenessLossWarning)]


def test_singular_update_is_skipped_and_reported():
    obj, res, caught = _hand_case(-3.0)
    np.testing.assert_array_equal(res.status, [0, 0, 2])
    np.testing.assert_array_equal(res.theta[2], [0.0, -1.0])     # the update was not made
    np.testing.assert_array_equal(obj.P, np.diag([1.0, 0.5]))
    assert len(caught) == 1 and "[2]" in str(caught[0].message)
    assert obj.n_updates == 2 and obj.regular


def test_sign_flip_of_det_r_is_reported():
    obj, res, caught = _hand_case(-5.0)
    np.testing.assert_array_equal(res.status, [0, 0, 1])
    assert len(caught) == 1 and "opposite sign" in str(caught[0].message)
    assert not obj.regular and obj.to_model().cov is None
    # det R = 1 / det P: negative now (det P0⁻¹ = 1 > 0)
    assert np.linalg.det(obj.P) < 0


def test_input_conventions_and_results():
    pd = pytest.importorskip("pandas")
    y, u = _record(200, 6)
    ref = RecursiveIV(2, 2, 1).run(y, u)
    assert isinstance(ref, RecursiveIVResult)
    idx = pd.date_range("2024-01-01", periods=200, freq="50ms")
    for rec in ((y, u), IDData(y, u, dt=0.05), pd.DataFrame({"y": y, "u": u}, index=idx)):
        obj = RecursiveIV(2, 2, 1)
        np.testing.assert_array_equal(obj.run(rec).theta, ref.theta)
    assert obj.dt == pytest.approx(0.05) and obj.to_model().dt == pytest.approx(0.05)
    frame = ref.to_frame()
    assert list(frame.columns) == ["a1", "a2", "b0", "b1", "yhat", "x", "status"]
    assert "Recursive IV: 200 samples" in ref.summary()
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib.figure import Figure
    assert isinstance(ref.plot(), Figure)


def test_reset_returns_to_the_prior():
    y, u = _record(100, 7)
    obj = RecursiveIV(1, 1, 1, theta0=[0.5, 0.5])
    first = obj.run(y, u).theta
    obj.reset()
    np.testing.assert_array_equal(obj.theta, [0.5, 0.5])
    np.testing.assert_array_equal(obj.run(y, u).theta, first)


def test_bad_input_names_the_argument_and_leaves_the_state():
    for kwargs, name in ((dict(forgetting=0.0), "forgetting"), (dict(forgetting=1.2), "forgetting"),
                         (dict(warmup=-1), "warmup"), (dict(P0=-1.0), "P0"),
                         (dict(P0=np.ones((2, 2))), "P0"), (dict(theta0=[1.0]), "theta0")):
        with pytest.raises(ValueError, match=name):
            RecursiveIV(1, 1, 1, **kwargs)
    with pytest.raises(ValueError, match="nb"):
        RecursiveIV(2, 0, 1)
    y, u = _record(50, 8)
    obj = RecursiveIV(1, 1, 1)
    obj.run(y[:10], u[:10])
    before = obj.get_state()
    bad = y[10:].copy()
    bad[3] = np.nan
    with pytest.raises(ValueError, match="y"):
        obj.run(bad, u[10:])
    with pytest.raises(ValueError, match="u"):
        obj.run(y[10:], u[11:])
    with pytest.raises(ValueError, match="y"):
        obj.step([1.0, 2.0], 1.0)
    with pytest.raises(TypeError, match="u"):
        obj.step(1.0)
    after = obj.get_state()
    for key in ("P", "S", "acc", "ybuf", "xbuf", "ubuf"):
        np.testing.assert_array_equal(after[key], before[key])
    np.testing.assert_array_equal(after["inner"]["state"], before["inner"]["state"])
    assert after["options"]["count"] == 10


_INTERPRETED = r"""
import numpy as np
from scipy.signal import lfilter
from adaptid.models import RecursiveIV
rng = np.random.default_rng(9)
u, e = rng.standard_normal(300), rng.standard_normal(300)
y = lfilter([0, 1.0, 0.5], [1, -1.5, 0.7], u) + 0.5 * lfilter([1, 0.9], [1, -1.5, 0.7], e)
res = RecursiveIV(2, 2, 1, forgetting=0.99, warmup=5).run((y, u))
print(np.hstack([res.theta, res.x[:, None]]).tobytes().hex())
"""


def test_compiled_kernel_equals_the_interpreted_source():
    """The kernel's Python source run by the interpreter (NUMBA_DISABLE_JIT=1, in a
    subprocess) gives the same tracks; tolerance 1e-9 relative, because the compiled
    kernel may contract a·b + c into fused multiply-adds (fastmath "contract")."""
    import os
    import subprocess
    import sys

    out = subprocess.run([sys.executable, "-c", _INTERPRETED], capture_output=True, text=True,
                         env={**os.environ, "NUMBA_DISABLE_JIT": "1"}, check=True, timeout=300)
    ref = np.frombuffer(bytes.fromhex(out.stdout.strip()), dtype=float).reshape(300, 5)
    rng = np.random.default_rng(9)
    u, e = rng.standard_normal(300), rng.standard_normal(300)
    y = lfilter(B, A, u) + 0.5 * lfilter(C, A, e)
    res = RecursiveIV(2, 2, 1, forgetting=0.99, warmup=5).run((y, u))
    np.testing.assert_allclose(np.hstack([res.theta, res.x[:, None]]), ref, rtol=1e-9,
                               atol=1e-12)


def test_run_refuses_a_merged_record_naming_it():
    """The auxiliary simulation and the lag buffers would run across the boundary."""
    from adaptid.models import IDData, RecursiveIV
    rng = np.random.default_rng(5)
    parts = [IDData(rng.standard_normal(80), rng.standard_normal(80)) for _ in range(2)]
    est = RecursiveIV(1, 1, 1)
    before = est.theta.copy()
    with pytest.raises(ValueError, match="y must be one experiment.*merged record of 2"):
        est.run(parts[0].merge(parts[1]))
    np.testing.assert_array_equal(est.theta, before)
