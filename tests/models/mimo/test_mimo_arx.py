"""MIMO ARX (issue 34, point 2): estimates against statsmodels' VAR and brute-force
least squares, exact recovery, several experiments, simulation against
python-control, the workflow functions and the recursive fit."""

import numpy as np
import pandas as pd
import pytest

from adaptid.models import ARX, MIMOARX, IDData, compare, resid, select_order


def simulate_arx(A, B, U, E=None):
    """Plain loop oracle: y_k = -sum_l A[l-1] y_{k-l} + sum_l B[l] u_{k-l} (+ e_k)."""
    N, ny = U.shape[0], B[0].shape[0]
    Y = np.zeros((N, ny))
    for k in range(N):
        y = np.zeros(ny) if E is None else E[k].copy()
        for l, Al in enumerate(A, 1):
            if k - l >= 0:
                y -= Al @ Y[k - l]
        for l, Bl in enumerate(B):
            if k - l >= 0:
                y += Bl @ U[k - l]
        Y[k] = y
    return Y


# A coupled system with per-entry orders: na = [[2, 1], [1, 1]], nb = [[2, 1], [1, 2]],
# nk = [[1, 2], [1, 1]] (the equations have different regressors).
NA, NB, NK = [[2, 1], [1, 1]], [[2, 1], [1, 2]], [[1, 2], [1, 1]]
A_TRUE = [np.array([[-0.6, 0.2], [0.1, -0.5]]), np.array([[0.2, 0.0], [0.0, 0.0]])]
B_TRUE = [np.zeros((2, 2)), np.array([[1.0, 0.0], [0.3, 1.0]]),
          np.array([[0.5, 0.7], [0.0, -0.4]])]
THETA_TRUE = [-0.6, 0.2, 0.2, 1.0, 0.5, 0.7,      # y1: a1_y1_y1 a2_y1_y1 a1_y1_y2 b0_y1_u1 b1_y1_u1 b0_y1_u2
              0.1, -0.5, 0.3, 1.0, -0.4]          # y2: a1_y2_y1 a1_y2_y2 b0_y2_u1 b0_y2_u2 b1_y2_u2


def _brute_rows(Y, U, na, nb, nk, i, s):
    """Regressors of equation i built sample by sample (the test's own oracle)."""
    rows = []
    for k in range(s, Y.shape[0]):
        r = [-Y[k - l, j] for j in range(Y.shape[1]) for l in range(1, na[i][j] + 1)]
        r += [U[k - nk[i][j] - l, j] for j in range(U.shape[1]) for l in range(nb[i][j])]
        rows.append(r)
    return np.array(rows)


@pytest.fixture
def noisy(rng):
    N = 1500
    U = rng.standard_normal((N, 2))
    E = rng.multivariate_normal([0, 0], [[0.04, 0.015], [0.015, 0.02]], size=N)
    return simulate_arx(A_TRUE, B_TRUE, U, E), U


def test_noise_free_system_is_recovered_exactly(rng):
    U = rng.standard_normal((400, 2))
    Y = simulate_arx(A_TRUE, B_TRUE, U)
    m = ARX(np.array(NA), np.array(NB), np.array(NK)).fit(Y, U)
    assert isinstance(m, ARX) and isinstance(m, MIMOARX)
    np.testing.assert_allclose(m.theta, THETA_TRUE, atol=1e-8)
    assert m.names[:3] == ("a1_y1_y1", "a2_y1_y1", "a1_y1_y2")
    assert m.names[-2:] == ("b0_y2_u2", "b1_y2_u2")
    np.testing.assert_allclose(m.simulate(U), Y, atol=1e-8)
    np.testing.assert_allclose(m.predict(Y, U), Y, atol=1e-8)
    np.testing.assert_allclose(m.predict((Y, U), k=4), Y, atol=1e-8)
    np.testing.assert_allclose(m.A[1], A_TRUE[0], atol=1e-8)
    np.testing.assert_allclose(m.B[2], B_TRUE[2], atol=1e-8)


def test_statsmodels_var_with_lagged_exogenous_inputs(rng):
    """Shared regressors (na = 2, nb = 2, nk = 1 everywhere) are a VAR(2) whose exogenous
    regressors are the lagged inputs. statsmodels' VAR takes exog contemporaneously, so
    the test passes it the columns u(k-1), u(k-2) (rows before p = 2 are not used).
    Coefficients (the a's with the opposite sign), sigma_u and cov_params must agree."""
    N = 800
    U = rng.standard_normal((N, 2))
    A = [np.array([[-0.5, 0.1], [0.2, -0.3]]), np.array([[0.1, 0.0], [0.05, 0.1]])]
    B = [np.zeros((2, 2)), np.array([[1.0, 0.4], [0.2, 0.8]]), np.array([[0.3, 0.0], [0.1, -0.2]])]
    Y = simulate_arx(A, B, U, rng.multivariate_normal([0, 0], [[0.1, 0.03], [0.03, 0.05]], N))
    from statsmodels.tsa.api import VAR

    exog = np.zeros((N, 4))
    exog[2:] = np.hstack([U[1:-1], U[:-2]])            # u1(k-1), u2(k-1), u1(k-2), u2(k-2)
    ex = pd.DataFrame(exog, columns=["u1_1", "u2_1", "u1_2", "u2_2"])
    ref = VAR(pd.DataFrame(Y, columns=["y1", "y2"]), exog=ex).fit(2, trend="n")
    m = ARX(2 * np.ones((2, 2), int), 2, 1).fit(Y, U)
    assert m._orders.shared
    label = {}
    for i in (1, 2):
        for j in (1, 2):
            for l in (1, 2):
                label[f"a{l}_y{i}_y{j}"] = (f"L{l}.y{j}", f"y{i}", -1.0)
                label[f"b{l - 1}_y{i}_u{j}"] = (f"u{j}_{l}", f"y{i}", 1.0)
    ref_theta = np.array([label[n][2] * ref.params.loc[label[n][0], label[n][1]] for n in m.names])
    np.testing.assert_allclose(m.theta, ref_theta, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(m.noise_cov, ref.sigma_u.to_numpy(), rtol=1e-10)
    C = ref.cov_params()
    keys = [(label[n][0], label[n][1]) for n in m.names]
    sign = np.array([label[n][2] for n in m.names])
    ref_cov = C.loc[keys, keys].to_numpy() * np.outer(sign, sign)
    np.testing.assert_allclose(m.cov, ref_cov, rtol=1e-9, atol=1e-15)


def test_per_equation_least_squares_against_brute_force(noisy):
    """Different regressors per equation: θ_i from numpy's lstsq on rows built sample by
    sample; the covariance blocks Σ_ij Φ_i⁺ Φ_j⁺ᵀ with numpy's pinv."""
    Y, U = noisy
    m = ARX(np.array(NA), np.array(NB), np.array(NK)).fit((Y, U))
    assert not m._orders.shared
    s = 2
    Phis = [_brute_rows(Y, U, NA, NB, NK, i, s) for i in range(2)]
    thetas = [np.linalg.lstsq(P, Y[s:, i], rcond=None)[0] for i, P in enumerate(Phis)]
    np.testing.assert_allclose(m.theta, np.concatenate(thetas), rtol=1e-10)
    E = np.column_stack([Y[s:, i] - P @ th for i, (P, th) in enumerate(zip(Phis, thetas))])
    np.testing.assert_allclose(m.residuals, E, atol=1e-12)
    n, ds = E.shape[0], [P.shape[1] for P in Phis]
    Sigma = np.array([[E[:, i] @ E[:, j] / np.sqrt((n - ds[i]) * (n - ds[j])) for j in range(2)]
                      for i in range(2)])
    np.testing.assert_allclose(m.noise_cov, Sigma, rtol=1e-10)
    pinv = [np.linalg.pinv(P) for P in Phis]
    cov = np.block([[Sigma[i, j] * pinv[i] @ pinv[j].T for j in range(2)] for i in range(2)])
    np.testing.assert_allclose(m.cov, cov, rtol=1e-8, atol=1e-14)
    # the diagonal blocks are each equation's OLS covariance σ̂²(ΦᵀΦ)⁻¹
    for i, P in enumerate(Phis):
        np.testing.assert_allclose(m.cov_blocks[i], Sigma[i, i] * np.linalg.inv(P.T @ P), rtol=1e-8)
    assert abs(m.theta - THETA_TRUE).max() < 0.05


def test_several_experiments_stack_their_own_rows(rng):
    """Rows are formed inside each experiment: equal to lstsq on the stacked rows of
    each, and different from the fit of the concatenated record."""
    parts = []
    for N in (300, 250):
        U = rng.standard_normal((N, 2))
        parts.append((simulate_arx(A_TRUE, B_TRUE, U, 0.1 * rng.standard_normal((N, 2))), U))
    m = ARX(np.array(NA), np.array(NB), np.array(NK)).fit([IDData(Y, U) for Y, U in parts])
    ref = []
    for i in range(2):
        Phi = np.vstack([_brute_rows(Y, U, NA, NB, NK, i, 2) for Y, U in parts])
        ref.append(np.linalg.lstsq(Phi, np.concatenate([Y[2:, i] for Y, _ in parts]),
                                   rcond=None)[0])
    np.testing.assert_allclose(m.theta, np.concatenate(ref), rtol=1e-10)
    assert m.residuals.shape == (298 + 248, 2)
    np.testing.assert_array_equal(np.bincount(m.experiment), [298, 248])
    joined = ARX(np.array(NA), np.array(NB), np.array(NK)).fit(
        np.vstack([p[0] for p in parts]), np.vstack([p[1] for p in parts]))
    assert np.abs(joined.theta - m.theta).max() > 1e-6


def test_simulation_and_to_control_against_python_control(noisy):
    control = pytest.importorskip("control")
    Y, U = noisy
    m = ARX(np.array(NA), np.array(NB), np.array(NK)).fit(Y, U)
    ss = m.to_control("ss")
    assert ss.dt == m.dt and list(ss.input_labels) == ["u1", "u2"]
    out = control.forced_response(ss, U=U.T).outputs.T
    np.testing.assert_allclose(m.simulate(U), out, rtol=1e-9, atol=1e-9)
    tf = m.to_control("tf")
    w = np.linspace(0.05, 3.0, 7)
    G_tf = np.stack([np.squeeze(tf(np.exp(1j * wk))) for wk in w], axis=-1)
    G_ss = np.stack([np.squeeze(ss(np.exp(1j * wk))) for wk in w], axis=-1)
    np.testing.assert_allclose(m.freqresp(w).response, G_ss, rtol=1e-9)
    np.testing.assert_allclose(G_tf, G_ss, rtol=1e-7)


def test_k_step_prediction_against_iterated_substitution(noisy):
    """ŷ(t|t-k): run the model from the measured outputs up to t-k (oracle loop)."""
    Y, U = noisy
    m = ARX(np.array(NA), np.array(NB), np.array(NK)).fit(Y, U)
    A, B = m.A, m.B
    k, t_check = 3, [5, 77, 640]
    P = m.predict(Y, U, k=k)
    for t in t_check:
        Z = Y.copy()
        Z[t - k + 1:] = 0.0
        for tt in range(t - k + 1, t + 1):
            z = sum(B[l] @ U[tt - l] for l in range(B.shape[0]) if tt - l >= 0)
            z = z - sum(A[l] @ Z[tt - l] for l in range(1, A.shape[0]) if tt - l >= 0)
            Z[tt] = z
        np.testing.assert_allclose(P[t], Z[t], rtol=1e-12, atol=1e-12)


def test_compare_resid_per_output(noisy):
    from adaptid.diagnostics import fit_percent

    Y, U = noisy
    data = IDData(Y, U, 0.5, y_names=["temp", "flow"], u_names=["heat", "valve"])
    est, val = data.split(0.6)
    m = ARX(np.array(NA), np.array(NB), np.array(NK)).fit(est)
    assert m.dt == 0.5 and m.names[0] == "a1_temp_temp" and "b0_flow_valve" in m.names
    res = compare(val, m)
    assert len(res) == 2 and [r.y_name for r in res] == ["temp", "flow"]
    sim = m.simulate(val)
    for i, r in enumerate(res):
        assert r.fit[0] == pytest.approx(fit_percent(val.outputs[:, i], sim[:, i]))
        assert r.fit[0] > 80
    res1 = compare(val, m, k=1)
    one = m.predict(val)
    assert res1[1].fit[0] == pytest.approx(fit_percent(val.outputs[:, 1], one[:, 1]))
    rr = resid(val, m)
    assert len(rr) == 2 and rr[0].start == 2
    np.testing.assert_allclose(rr[0].e, (val.outputs - one)[2:, 0])
    assert all(r.white and all(r.independent) for r in rr)


def test_select_order_per_output(rng):
    """Output 1 needs (na, nb) = (1, 1) in every entry, output 2 (2, 2): AIC picks each
    output's row."""
    N = 3000
    U = rng.standard_normal((N, 2))
    A = [np.array([[-0.5, 0.2], [0.1, -0.4]]), np.array([[0.0, 0.0], [0.1, 0.2]])]
    B = [np.zeros((2, 2)), np.array([[1.0, 0.5], [0.4, 1.0]]), np.array([[0.0, 0.0], [0.6, -0.5]])]
    Y = simulate_arx(A, B, U, 0.05 * rng.standard_normal((N, 2)))
    sel = select_order(IDData(Y, U), na=[1, 2, 3], nb=[1, 2, 3], nk=[1])
    na, nb, nk = sel.best
    np.testing.assert_array_equal(na, [[1, 1], [2, 2]])
    np.testing.assert_array_equal(nb, [[1, 1], [2, 2]])
    np.testing.assert_array_equal(nk, np.ones((2, 2)))
    assert set(sel.table["output"]) == {"y1", "y2"} and len(sel.table) == 18
    m = sel.model()
    assert isinstance(m, ARX) and m.residuals.shape[0] == N - sel.start
    # the table's loss of the chosen structure is the model's own loss per output
    row = sel.table[(sel.table.output == "y2") & (sel.table.na == 2) & (sel.table.nb == 2)]
    assert float(row["loss"].iloc[0]) == pytest.approx((m.residuals[:, 1] ** 2).mean(), rel=1e-10)


@pytest.mark.parametrize("shared", [True, False])
def test_fit_recursive_diffuse_equals_least_squares(noisy, shared):
    """With an exact diffuse prior and no forgetting the recursive estimates are the
    batch least squares (shared P in one multi-output RLS, or one RLS per equation)."""
    Y, U = noisy
    orders = (2, 2, 1) if shared else (np.array(NA), np.array(NB), np.array(NK))
    batch = ARX(*orders).fit(Y, U)
    rec = ARX(*orders)
    traj = rec.fit_recursive(Y, U, "rls", P0="diffuse")
    np.testing.assert_allclose(rec.theta, batch.theta, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(rec.noise_cov, batch.noise_cov, rtol=1e-6)
    np.testing.assert_allclose(rec.cov, batch.cov, rtol=1e-5, atol=1e-12)
    if shared:
        assert traj.theta.shape == (Y.shape[0] - 2, batch.n_params // 2, 2)
    else:
        assert len(traj) == 2 and traj[1].theta.shape == (Y.shape[0] - 2, 5)


def test_fit_recursive_with_a_given_multi_output_estimator(noisy):
    import adaptid

    Y, U = noisy
    est = adaptid.RLS(8, n_outputs=2, forgetting=0.995)
    m = ARX(2, 2, 1)
    m.fit_recursive(Y, U, est)
    assert est.n_updates == 0 and m.estimator.n_updates == Y.shape[0] - 2
    with pytest.raises(ValueError, match="estimator"):
        ARX(2, 2, 1).fit_recursive(Y, U, adaptid.RLS(8))


def test_siso_arx_is_unchanged(rng):
    u = rng.standard_normal(300)
    y = np.convolve(u, [0, 1.0, 0.5])[:300]
    m = ARX(0, 2, 1)
    assert type(m) is ARX and not isinstance(m, MIMOARX)
    m.fit(y, u)
    assert m.names == ("b0", "b1") and type(m) is ARX
    np.testing.assert_allclose(m.theta, [1.0, 0.5], atol=1e-10)
    import copy

    assert type(copy.copy(m)) is ARX


def test_scalar_orders_on_several_outputs_become_mimo(noisy):
    Y, U = noisy
    m = ARX(2, [2, 1], 1, dt=0.2)
    m.fit(IDData(Y, U))
    assert type(m) is MIMOARX and isinstance(m, ARX)
    np.testing.assert_array_equal(m.nb, [[2, 1], [2, 1]])
    assert m.dt == 1.0                                # the IDData's sample time
    m2 = ARX(2, [2, 1], 1, dt=0.2).fit(Y, U)
    assert m2.dt == 0.2 and m2.n_outputs == 2


def test_bad_orders_and_data_are_refused(noisy):
    Y, U = noisy
    with pytest.raises(ValueError, match="nb"):
        ARX(np.ones((2, 2), int), np.ones((3, 2), int), 1).fit(Y, U)
    with pytest.raises(ValueError, match="na"):
        ARX(np.ones((2, 2), int) * -1, 1, 1)
    with pytest.raises(ValueError, match=r"na\[1\], nb\[1\]"):
        ARX(np.array([[1, 0], [0, 0]]), np.array([[1, 1], [0, 0]]), 1).fit(Y, U)
    with pytest.raises(ValueError, match="u"):
        ARX(np.ones((2, 2), int), 1, 1).fit(Y, U[:, :1]).simulate(U)
    with pytest.raises(ValueError, match="data"):
        ARX(np.ones((2, 2), int) * 20, 1, 1).fit(Y[:30], U[:30])


def test_summary_to_frame_plot(noisy):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    Y, U = noisy
    m = ARX(np.array(NA), np.array(NB), np.array(NK)).fit(Y, U)
    s = m.summary()
    assert s.names == m.names and s["experiments"] == 1
    np.testing.assert_allclose(s.params[:, 1], m.stderr)
    assert "fit % y2 (simulation, estimation)" in s.stats
    df = m.to_frame()
    assert list(df.columns) == ["name", "output", "regressor", "lag", "estimate", "stderr"]
    assert df.loc[df.name == "b0_y1_u2", "lag"].item() == 2
    fig = m.plot()
    assert isinstance(fig, matplotlib.figure.Figure)
    plt.close(fig)
    n, d = m.residuals.shape[0], m.n_params
    V = np.linalg.det(m.residuals.T @ m.residuals / n)
    assert m.aic == pytest.approx(n * np.log(V) + 2 * d + 2 * n * (np.log(2 * np.pi) + 1))


def test_pandas_names_and_pickle(noisy):
    import pickle

    Y, U = noisy
    Yf = pd.DataFrame(Y, columns=["p", "q"])
    Uf = pd.DataFrame(U, columns=["a", "b"])
    m = ARX(1, 1, 1).fit(Yf, Uf)
    assert m.names[:3] == ("a1_p_p", "a1_p_q", "b0_p_a") and m.y_names == ("p", "q")
    back = pickle.loads(pickle.dumps(m))
    assert type(back) is MIMOARX and isinstance(back, ARX)
    np.testing.assert_array_equal(back.theta, m.theta)
    np.testing.assert_allclose(back.simulate(U), m.simulate(U))


def test_fit_recursive_window_is_least_squares_on_the_window(noisy):
    """A sliding window of M rows (negligible prior) ends at the least squares of the
    last M rows of each equation, and σ̂ counts only those rows (the factors c_k of
    adaptid.recursive_fit_stats' rule)."""
    Y, U = noisy
    M = 300
    m = ARX(np.array(NA), np.array(NB), np.array(NK))
    m.fit_recursive(Y, U, "window", window=M, P0=1e10)
    Phis = [_brute_rows(Y, U, NA, NB, NK, i, 2)[-M:] for i in range(2)]
    ths = [np.linalg.lstsq(P, Y[-M:, i], rcond=None)[0] for i, P in enumerate(Phis)]
    np.testing.assert_allclose(m.theta, np.concatenate(ths), rtol=1e-6, atol=1e-8)
    E = np.column_stack([Y[-M:, i] - P @ th for i, (P, th) in enumerate(zip(Phis, ths))])
    ds = [P.shape[1] for P in Phis]
    S01 = E[:, 0] @ E[:, 1] / np.sqrt((M - ds[0]) * (M - ds[1]))
    assert m.noise_cov[0, 1] == pytest.approx(S01, rel=1e-5)
    assert m.noise_cov[1, 1] == pytest.approx(E[:, 1] @ E[:, 1] / (M - ds[1]), rel=1e-5)
