"""LMS and NLMS (MATLAB's Gradient / NormalizedGradient, padasip's FilterLMS / FilterNLMS).

Oracles: padasip's ``FilterLMS`` / ``FilterNLMS`` (its own implementation,
installed by the test extra), MATLAB ``recursiveLS``'s update equations for
the two gradient methods written out in NumPy, a plain loop of ``update``
(the engine's contract: run == N updates, bit for bit), separate runs for the
batched / segmented runs, and NumPy for the residual variance.
"""

import json

import numpy as np
import pandas as pd
import pytest

import adaptid
from adaptid.estimators._factory import method_of

import padasip  # noqa: E402 - the test extra installs it (missing: a failure)

# Tolerance against padasip: both compute θ + (g φᵢ) ε in float64; padasip's
# φᵀθ and φᵀφ are BLAS dot products (another summation order) and adaptid's
# kernel may fuse a*b + c into one FMA (adaptid._config), so each step differs
# by a few ulps; over 2000 contracting steps the difference stays ~1e-15.
TOL = 1e-12


def _data(rng, N=2000, n=4, p=None, noise=0.1):
    Phi = rng.standard_normal((N, n))
    theta = np.linspace(1.0, -1.0, n) if p is None else rng.standard_normal((n, p))
    y = Phi @ theta + noise * rng.standard_normal(N if p is None else (N, p))
    return Phi, y


# ------------------------------------------------------------------ padasip
# n = 10: the kernel sums the dot products in four partial sums plus a tail
# for n >= 8 (adaptid._kernels.recursions._lms._dot), sequentially below
@pytest.mark.parametrize("n", [4, 10])
@pytest.mark.parametrize("theta0", [None, "random"])
def test_lms_equals_padasip_filterlms(rng, theta0, n):
    Phi, y = _data(rng, n=n)
    mu = 0.01
    w0 = np.zeros(n) if theta0 is None else rng.standard_normal(n)
    f = padasip.filters.FilterLMS(n=n, mu=mu, w=w0.copy())
    yp, ep, w_hist = f.run(y, Phi)  # w_hist[k]: the weights BEFORE sample k
    est = adaptid.LMS(n, step=mu, theta0=None if theta0 is None else w0)
    tr = est.run(Phi, y)
    np.testing.assert_allclose(tr.error, ep, rtol=TOL, atol=TOL)
    np.testing.assert_allclose(tr.theta[:-1], w_hist[1:], rtol=TOL, atol=TOL)
    np.testing.assert_allclose(est.theta, f.w, rtol=TOL, atol=TOL)
    np.testing.assert_allclose(est.predict(Phi[:5]), Phi[:5] @ f.w, rtol=TOL, atol=TOL)


@pytest.mark.parametrize("n", [4, 10])
@pytest.mark.parametrize("mu, eps", [(0.5, 0.001), (1.0, 1.0), (0.2, 0.0)])
def test_nlms_equals_padasip_filternlms(rng, mu, eps, n):
    Phi, y = _data(rng, n=n)
    Phi *= np.resize([1.0, 10.0, 0.1, 3.0], n)  # NLMS is insensitive to the scale
    f = padasip.filters.FilterNLMS(n=n, mu=mu, eps=eps, w="zeros")
    yp, ep, w_hist = f.run(y, Phi)
    est = adaptid.NLMS(n, step=mu, eps=eps)
    tr = est.run(Phi, y)
    np.testing.assert_allclose(tr.error, ep, rtol=TOL, atol=TOL)
    np.testing.assert_allclose(tr.theta[:-1], w_hist[1:], rtol=TOL, atol=TOL)
    np.testing.assert_allclose(est.theta, f.w, rtol=TOL, atol=TOL)


def test_padasip_adapt_step_by_step_equals_update(rng):
    Phi, y = _data(rng, N=300)
    f = padasip.filters.FilterNLMS(n=4, mu=0.7, eps=0.01, w="zeros")
    est = adaptid.NLMS(4, step=0.7, eps=0.01)
    for k in range(300):
        f.adapt(y[k], Phi[k])
        est.update(Phi[k], y[k])
    np.testing.assert_allclose(est.theta, f.w, rtol=TOL, atol=TOL)


# ------------------------------------------------------- MATLAB's equations
def matlab_gradient(Phi, Y, gain, bias=None, weights=None, theta0=None):
    """recursiveLS, EstimationMethod 'Gradient' / 'NormalizedGradient' (MathWorks
    documentation, "Recursive Algorithms for Online Parameter Estimation"):
    θ(t) = θ(t−1) + K(t) (y(t) − ψᵀ(t) θ(t−1)),
    K(t) = γ ψ(t)                         (Gradient),
    K(t) = γ ψ(t) / (|ψ(t)|² + Bias)      (NormalizedGradient);
    a weight w scales γ (adaptid's extension, w = 1 is MATLAB's)."""
    N, n = Phi.shape
    Y = Y.reshape(N, -1)
    th = np.zeros((n, Y.shape[1])) if theta0 is None else np.array(theta0, float).reshape(n, -1)
    out = np.empty((N,) + th.shape)
    for t in range(N):
        psi = Phi[t]
        g = gain * (1.0 if weights is None else weights[t])
        K = g * psi if bias is None else g * psi / (psi @ psi + bias)
        th = th + np.outer(K, Y[t] - psi @ th)
        out[t] = th
    return out


@pytest.mark.parametrize("n", [3, 9])
@pytest.mark.parametrize("p", [None, 2])
def test_matlab_gradient_equations(rng, p, n):
    Phi, y = _data(rng, N=1500, n=n, p=p)
    w = rng.uniform(0.0, 2.0, 1500)
    ref = matlab_gradient(Phi, y, 0.02, weights=w)
    tr = adaptid.LMS(n, step=0.02, n_outputs=p).run(Phi, y, weights=w)
    got = tr.theta if p is not None else tr.theta[..., None]
    # a few ulps per step (other summation order, FMA), contracting dynamics
    np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-13)


@pytest.mark.parametrize("n", [3, 9])
@pytest.mark.parametrize("p", [None, 2])
def test_matlab_normalized_gradient_equations(rng, p, n):
    Phi, y = _data(rng, N=1500, n=n, p=p)
    Phi[::7] *= 50.0  # badly scaled samples: the normalisation matters
    ref = matlab_gradient(Phi, y, 0.8, bias=np.finfo(float).eps)  # MATLAB's default Bias
    est = adaptid.estimator("nlms", n, step=0.8, n_outputs=p)
    assert est.eps == np.finfo(float).eps
    tr = est.run(Phi, y)
    got = tr.theta if p is not None else tr.theta[..., None]
    np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-13)


def test_converges_to_truth_noise_free(rng):
    Phi = rng.standard_normal((3000, 3))
    y = Phi @ [1.0, -2.0, 0.5]
    for est in (adaptid.LMS(3, step=0.05), adaptid.NLMS(3, step=0.5)):
        est.run(Phi, y)
        np.testing.assert_allclose(est.theta, [1.0, -2.0, 0.5], atol=1e-10)


# --------------------------------------------------------- engine contract
MAKERS = {"lms": lambda **kw: adaptid.LMS(3, step=0.03, **kw),
          "nlms": lambda **kw: adaptid.NLMS(3, step=0.6, eps=1e-3, **kw)}


@pytest.mark.parametrize("kind", sorted(MAKERS))
@pytest.mark.parametrize("p", [None, 2])
def test_run_equals_updates_bit_for_bit(rng, kind, p):
    Phi, y = _data(rng, N=400, n=3, p=p)
    w = rng.uniform(0.0, 2.0, 400)
    w[10] = 0.0
    a, b = MAKERS[kind](n_outputs=p), MAKERS[kind](n_outputs=p)
    tr = a.run(Phi, y, weights=w)
    errs = np.array([b.update(Phi[k], y[k], weight=w[k]) for k in range(400)])
    assert np.array_equal(a.theta, b.theta)
    assert np.array_equal(tr.error, errs)
    assert np.array_equal(tr.theta[-1], b.theta)
    assert np.array_equal(tr.theta[10], tr.theta[9])  # weight 0: no step
    assert a.n_updates == b.n_updates == 400


@pytest.mark.parametrize("kind", sorted(MAKERS))
def test_run_batched_equals_separate_runs(rng, kind):
    B, N = 5, 250
    Phi = rng.standard_normal((B, N, 3))
    y = Phi @ [1.0, 0.5, -1.0] + 0.1 * rng.standard_normal((B, N))
    est = MAKERS[kind]()
    est.run(Phi[0, :20], y[0, :20])  # every stream continues this state
    start = est.copy()
    tr = est.run_batched(Phi, y)
    assert est.batch_size == B
    for b in range(B):
        alone = start.copy()
        ref = alone.run(Phi[b], y[b])
        assert np.array_equal(est.theta[b], alone.theta)
        assert np.array_equal(tr.theta[b], ref.theta)
        assert np.array_equal(tr.error[b], ref.error)


@pytest.mark.parametrize("kind", sorted(MAKERS))
def test_run_segments_equals_separate_runs(rng, kind):
    lens = [0, 7, 300, 1, 120, 0]
    off = np.concatenate([[0], np.cumsum(lens)]).astype(np.int64)
    Phi = rng.standard_normal((off[-1], 3))
    y = Phi @ [1.0, 2.0, 3.0] + 0.1 * rng.standard_normal(off[-1])
    est = MAKERS[kind](theta0=[0.1, 0.2, 0.3])
    res = est.run_segments(Phi, y, off, store=True)
    assert res.P is None  # no covariance
    for g in range(len(lens)):
        a, b = off[g], off[g + 1]
        alone = est.copy().reset()
        tr = alone.run(Phi[a:b], y[a:b])
        assert np.array_equal(res.theta[g], alone.theta)
        assert np.array_equal(res.error[a:b], tr.error)
        assert np.array_equal(res.theta_track[a:b], tr.theta)
        np.testing.assert_allclose(res.sse[g], np.sum(tr.error ** 2), rtol=1e-12)


@pytest.mark.parametrize("kind", sorted(MAKERS))
def test_state_round_trip_and_file(rng, kind, tmp_path):
    Phi, y = _data(rng, N=600, n=3)
    whole = MAKERS[kind]()
    whole.run(Phi, y)
    first = MAKERS[kind]()
    first.run(Phi[:250], y[:250])
    st = first.get_state()
    assert st["P0"] is None and st["state"].shape == (3,)  # layout [theta]
    again = type(first).from_state(st)
    again.run(Phi[250:], y[250:])
    assert np.array_equal(again.theta, whole.theta)
    path = tmp_path / "s.npz"
    first.save_state(path)
    loaded = adaptid.load_state(path)
    assert type(loaded) is type(first) and loaded.get_state()["options"] == st["options"]
    loaded.run(Phi[250:], y[250:])
    assert np.array_equal(loaded.theta, whole.theta)
    assert loaded.n_updates == whole.n_updates
    other = adaptid.NLMS if kind == "lms" else adaptid.LMS
    with pytest.raises(adaptid.StateFileError, match="not a"):
        other.load_state(path)
    with pytest.raises(ValueError, match="the state of a"):
        other.from_state(st)
    # pickling goes through the same state
    import pickle
    assert np.array_equal(pickle.loads(pickle.dumps(first)).theta, first.theta)


@pytest.mark.parametrize("kind", sorted(MAKERS))
def test_nan_policy(rng, kind):
    Phi, y = _data(rng, N=200, n=3)
    y[50] = np.nan
    Phi[120, 1] = np.inf
    est = MAKERS[kind](nan_policy="skip")
    tr = est.run(Phi, y)
    assert tr.skipped.nonzero()[0].tolist() == [50, 120]
    assert np.isnan(tr.error[[50, 120]]).all()
    assert np.array_equal(tr.theta[50], tr.theta[49]) and np.array_equal(tr.theta[120], tr.theta[119])
    assert est.n_skipped == 2 and est.n_updates == 198
    keep = np.isfinite(y) & np.isfinite(Phi).all(axis=1)
    ref = MAKERS[kind]().run(Phi[keep], y[keep])
    assert np.array_equal(tr.error[keep], ref.error)
    # raise: ValueError naming the sample, state unchanged (run and update)
    est = MAKERS[kind]()
    est.run(Phi[:10], y[:10])
    before = est.get_state()
    with pytest.raises(ValueError, match="sample 40"):  # y[50] is row 40 of this run
        est.run(Phi[10:], y[10:])
    assert np.array_equal(est.get_state()["state"], before["state"])
    assert est.n_updates == 10
    with pytest.raises(ValueError, match="finite"):
        est.update(Phi[120], 1.0)
    assert np.array_equal(est.get_state()["state"], before["state"])
    assert np.isnan(MAKERS[kind](nan_policy="skip").update(Phi[0], np.nan))


def test_overflowing_phi_norm_is_not_a_missing_sample():
    # The kernel tests finiteness through φᵀφ and ε first, then exactly: a
    # finite φ whose φᵀφ overflows must be used, not skipped.
    phi = np.array([1e200, 1.0])
    est = adaptid.NLMS(2, step=0.5, nan_policy="skip", theta0=[0.0, 0.0])
    # ... and says that its step was lost to the overflow (issue 32, point 6)
    with pytest.warns(adaptid.DivergenceWarning, match="overflowed"):
        assert est.update(phi, 1.0) == 1.0 and est.n_skipped == 0 and est.n_updates == 1
    assert np.array_equal(est.theta, [0.0, 0.0])  # μ/(ε + inf) = 0, as padasip: no step
    f = padasip.filters.FilterNLMS(n=2, mu=0.5, eps=est.eps, w="zeros")
    with np.errstate(over="ignore"):
        f.adapt(1.0, phi)
    assert np.array_equal(f.w, est.theta)
    est = adaptid.LMS(2, step=1e-300, nan_policy="skip")
    est.update(phi, 2.0)
    assert est.n_skipped == 0
    np.testing.assert_array_equal(est.theta, 1e-300 * phi * 2.0)  # θ = μ φ ε exactly


def test_no_covariance_no_forgetting(rng):
    est = adaptid.LMS(2, step=0.1)
    with pytest.raises(AttributeError, match="no covariance P"):
        est.P
    with pytest.raises(AttributeError, match="excitation"):
        est.excitation
    with pytest.raises(ValueError, match="forgetting must be None for LMS"):
        est.run(np.ones((3, 2)), np.ones(3), forgetting=0.9)
    with pytest.raises(ValueError, match="forgetting must be None for NLMS"):
        adaptid.NLMS(2, step=0.1).update(np.ones(2), 1.0, forgetting=0.9)
    with pytest.raises(ValueError, match="step must be"):
        adaptid.LMS(2, step=0.0)
    with pytest.raises(ValueError, match="eps must be"):
        adaptid.NLMS(2, step=0.1, eps=-1.0)
    with pytest.raises(TypeError, match="P0 must be an option of method='lms'"):
        adaptid.estimator("lms", 2, step=0.1, P0=1.0)
    with pytest.raises(TypeError, match="step must be given"):
        adaptid.estimator("nlms", 2)
    assert method_of(adaptid.estimator("nlms", 2, step=0.1)) == "nlms"


def test_divergence_warns(rng):
    Phi = 100.0 * rng.standard_normal((500, 2))
    est = adaptid.LMS(2, step=1.0)  # μ ≫ 2/λmax(E φφᵀ) = 2e-4
    with pytest.warns(adaptid.DivergenceWarning, match="diverged"):
        with np.errstate(over="ignore", invalid="ignore"):
            est.run(Phi, Phi @ [1.0, 1.0])
    assert not np.isfinite(est.theta).all()


def test_recursive_fit_stats_nan_stderr(rng):
    Phi, y = _data(rng, N=800, n=3)
    est = adaptid.NLMS(3, step=0.3)
    est.run(Phi, y)
    st = adaptid.recursive_fit_stats(est, Phi, y)
    r = y - Phi @ est.theta
    np.testing.assert_allclose(st.sigma2, r @ r / (800 - 3), rtol=1e-12)  # c_k = 1
    assert st.dof == 797 and np.isnan(st.stderr).all()


# ------------------------------------------------------------- CLI, fleet
def test_cli_fit_lms(rng, tmp_path):
    from typer.testing import CliRunner

    from adaptid.cli._app import app
    Phi, y = _data(rng, N=600, n=3)
    path = tmp_path / "d.csv"
    pd.DataFrame({"a": Phi[:, 0], "b": Phi[:, 1], "c": Phi[:, 2], "y": y}).to_csv(
        path, index=False, float_format="%.17g")
    runner = CliRunner()
    for method, extra, est in (("lms", [], adaptid.LMS(3, step=0.02)),
                               ("nlms", ["--eps", "0.01"], adaptid.NLMS(3, step=0.4, eps=0.01))):
        step = str(est.step)
        res = runner.invoke(app, ["fit", str(path), "--y", "y", "--phi", "a,b,c",
                                  "--method", method, "--step", step, *extra, "--json"])
        assert res.exit_code == 0, res.output
        out = json.loads(res.stdout)
        est.run(Phi, y)
        np.testing.assert_array_equal(out["theta"], est.theta)  # %.17g: exact round trip
        assert out["method"] == method
        r = y - Phi @ est.theta
        np.testing.assert_allclose(out["sigma2"], r @ r / (600 - 3), rtol=1e-12)
    bad = runner.invoke(app, ["fit", str(path), "--y", "y", "--phi", "a,b,c", "--method", "lms"])
    assert bad.exit_code == 2 and "--step" in bad.stderr
    bad = runner.invoke(app, ["fit", str(path), "--y", "y", "--phi", "a,b,c", "--step", "0.1"])
    assert bad.exit_code == 2 and "--step applies" in bad.stderr


def _fleet_frame(rng):
    rows = []
    truth = {}
    for dev in range(6):
        N = 200 + 30 * dev
        Phi = rng.standard_normal((N, 2))
        th = rng.standard_normal(2)
        truth[dev] = (Phi, Phi @ th + 0.05 * rng.standard_normal(N))
        rows.append(pd.DataFrame({"device": dev, "t": np.arange(N), "x1": Phi[:, 0],
                                  "x2": Phi[:, 1], "v": truth[dev][1]}))
    return pd.concat(rows, ignore_index=True), truth


def test_fleet_identify_lms(rng):
    from adaptid import fleet
    df, truth = _fleet_frame(rng)
    for method, opts, make in (("lms", {"step": 0.05}, lambda: adaptid.LMS(2, step=0.05)),
                               ("nlms", {"step": 0.5, "eps": 0.1},
                                lambda: adaptid.NLMS(2, step=0.5, eps=0.1))):
        res = fleet.identify(df, group="device", y="v", phi=["x1", "x2"], time="t",
                             method=method, **opts)
        for dev, (Phi, y) in truth.items():
            est = make()
            est.run(Phi, y)
            assert np.array_equal(res.loc[dev, ["x1", "x2"]].to_numpy(float), est.theta)
            r = y - Phi @ est.theta
            np.testing.assert_allclose(res.loc[dev, "sigma2"], r @ r / (len(y) - 2), rtol=1e-9)
        assert res[["stderr_x1", "stderr_x2"]].isna().all().all()


def test_cli_fleet_nlms(rng, tmp_path):
    from typer.testing import CliRunner

    from adaptid.cli._app import app
    df, truth = _fleet_frame(rng)
    path = tmp_path / "fleet.csv"
    df.to_csv(path, index=False, float_format="%.17g")
    res = CliRunner().invoke(app, ["fleet", str(path), "--group", "device", "--y", "v",
                                   "--phi", "x1,x2", "--time", "t", "--method", "nlms",
                                   "--step", "0.5", "--eps", "0.1", "--json"])
    assert res.exit_code == 0, res.output
    out = {d["device"]: d for d in json.loads(res.stdout)["devices"]}
    for dev, (Phi, y) in truth.items():
        est = adaptid.NLMS(2, step=0.5, eps=0.1)
        est.run(Phi, y)
        np.testing.assert_array_equal([out[dev]["x1"], out[dev]["x2"]], est.theta)
        assert out[dev]["stderr_x1"] is None  # NaN -> JSON null
    bad = CliRunner().invoke(app, ["fleet", str(path), "--group", "device", "--y", "v",
                                   "--phi", "x1,x2", "--method", "lms"])
    assert bad.exit_code == 2 and "--step" in bad.stderr


@pytest.mark.slow
def test_bench_lms_quick_runs_and_compares_like_with_like():
    """benchmarks/bench_lms.py --quick: it runs, and its check phase (final θ of
    adaptid, the C loop and padasip equal to 1e-9) passes. Speed is not asserted."""
    import subprocess
    import sys
    from pathlib import Path
    root = Path(__file__).resolve().parents[2]
    proc = subprocess.run([sys.executable, str(root / "benchmarks" / "bench_lms.py"), "--quick"],
                          cwd=root, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    for kind in ("LMS ", "NLMS"):
        for n in (4, 8, 16):
            assert f"{kind} n={n:2d}:" in proc.stdout
