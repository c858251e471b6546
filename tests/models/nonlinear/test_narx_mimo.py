"""MIMO NARX and several experiments end to end (issue 35, point 1: one term set per
output, a scalar n_terms for each): sysidentpy's MISO FROLS per output, exact
recovery, brute-force least squares on the stacked experiments."""

import numpy as np
import pytest

from adaptid import IDData
from adaptid.models import NARX, RecursiveNARX


def mimo(N=600, seed=0, noise=0.0):
    """a(k) = 0.5 a(k-1) + f(k-1) + 0.2 b(k-1) f(k-1);
    b(k) = 0.1 + 0.3 b(k-1) - 0.4 a(k-1)^2 + 0.5 f(k-2)."""
    rng = np.random.default_rng(seed)
    f = rng.uniform(-1, 1, N)
    y = np.zeros((N, 2))
    y[:2] = rng.uniform(0.2, 0.6, (2, 2))  # nonzero start: see test_narx's sysidentpy test
    for k in range(2, N):
        y[k, 0] = 0.5 * y[k - 1, 0] + f[k - 1] + 0.2 * y[k - 1, 1] * f[k - 1]
        y[k, 1] = 0.1 + 0.3 * y[k - 1, 1] - 0.4 * y[k - 1, 0] ** 2 + 0.5 * f[k - 2]
    y += noise * rng.standard_normal((N, 2))
    return IDData(y, f, y_names=["a", "b"], u_names="f")


TRUE = ({"a(k-1)": 0.5, "f(k-1)": 1.0, "f(k-1)*b(k-1)": 0.2},
        {"1": 0.1, "b(k-1)": 0.3, "a(k-1)^2": -0.4, "f(k-2)": 0.5})


def test_each_output_equals_sysidentpy_frols_with_the_others_as_inputs():
    """sysidentpy is MISO: output o's FROLS with the other output as a second input
    (lags 1, 2: our lagged base variables) selects the same terms with the same ERR
    and θ."""
    sysidentpy = pytest.importorskip("sysidentpy")
    from sysidentpy.basis_function import Polynomial
    from sysidentpy.model_structure_selection import FROLS
    from sysidentpy.parameter_estimation import LeastSquares

    d = mimo(N=500, noise=0.02, seed=3)
    m = NARX(2, 2, 2, n_terms=6).fit(d)
    Y, f = d.outputs, d.inputs[:, 0]
    # our base variables: a(k-1), a(k-2), b(k-1), b(k-2), f(k-1), f(k-2); sysidentpy's
    # codes: 100j own output, 200j the input f, 300j the other output
    codes = {0: np.array([0, 1001, 1002, 3001, 3002, 2001, 2002]),
             1: np.array([0, 3001, 3002, 1001, 1002, 2001, 2002])}
    for o in (0, 1):
        ref = FROLS(order_selection=False, n_terms=6, ylag=2, xlag=[[1, 2], [1, 2]],
                    basis_function=Polynomial(degree=2), estimator=LeastSquares())
        ref.fit(X=np.column_stack([f, Y[:, 1 - o]]), y=Y[:, [o]])
        r = m.results[o]
        ours = [tuple(sorted(codes[o][c], reverse=True)) for c in r.combos]
        assert ours == [tuple(row) for row in ref.final_model], sysidentpy.__version__
        np.testing.assert_allclose(r.err, ref.err[:6], rtol=0, atol=1e-10)
        np.testing.assert_allclose(r.theta, ref.theta.ravel(), rtol=1e-9, atol=1e-12)


def test_several_mimo_experiments_recovered_exactly_end_to_end(tmp_path):
    d1, d2 = mimo(N=300, seed=1), mimo(N=250, seed=2)
    m = NARX(2, 2, 2).fit([d1, d2])        # each output's own AIC minimum
    assert len(m.terms) == 2 and all(set(TRUE[o]) <= set(m.terms[o]) for o in (0, 1))
    for o in (0, 1):
        th = dict(zip(m.terms[o], m.theta[o]))
        for t, v in TRUE[o].items():
            np.testing.assert_allclose(th[t], v, atol=1e-10)
        assert all(abs(th[t]) < 1e-10 for t in set(th) - set(TRUE[o]))
    np.testing.assert_array_equal(m.index, np.r_[np.arange(2, 300), np.arange(2, 250)])
    assert m.residuals.shape == (298 + 248, 2)
    for d in (d1, d2):   # every experiment simulated and predicted exactly
        np.testing.assert_allclose(m.simulate(d), d.outputs, atol=1e-9)
        np.testing.assert_allclose(m.predict(d, k=3), d.outputs, atol=1e-9)
    # the recursive re-estimation continues over both experiments, per output
    ta, tb = m.fit_recursive([d1, d2], P0=1e10)
    np.testing.assert_allclose(ta.theta[-1], m.theta[0], atol=1e-6)
    np.testing.assert_allclose(tb.theta[-1], m.theta[1], atol=1e-6)
    assert [len(t) for t in NARX(2, 2, 2, n_terms=6).fit([d1, d2]).terms] == [6, 6]
    frame = m.to_frame()
    assert set(frame.index.get_level_values("output")) == {"a", "b"}
    assert len(m.summary()) == 2


def test_stacked_theta_is_brute_force_lstsq_with_noise():
    d1, d2 = mimo(N=400, seed=4, noise=0.05), mimo(N=350, seed=5, noise=0.05)
    m = NARX(1, 2, 2, n_terms=5).fit([d1, d2])
    for o, r in enumerate(m.results):
        rows = []
        for d in (d1, d2):
            Y, f = d.outputs, d.inputs[:, 0]
            k = np.arange(2, len(d))
            base = {"a(k-1)": Y[k - 1, 0], "b(k-1)": Y[k - 1, 1], "f(k-1)": f[k - 1],
                    "f(k-2)": f[k - 2]}
            cols = []
            for t in r.terms:
                col = np.ones(k.size)
                if t != "1":
                    for fac in t.split("*"):
                        name, _, p = fac.partition("^")
                        col = col * base[name] ** int(p or 1)
                cols.append(col)
            rows.append((np.column_stack(cols), Y[k, o]))
        Phi = np.vstack([p for p, _ in rows])
        t = np.concatenate([v for _, v in rows])
        theta, *_ = np.linalg.lstsq(Phi, t, rcond=None)
        np.testing.assert_allclose(r.theta, theta, rtol=1e-9, atol=1e-12)
        res = t - Phi @ theta
        s2 = res @ res / (t.size - Phi.shape[1])
        cov = s2 * np.linalg.inv(Phi.T @ Phi)   # the oracle may invert: it is the test
        np.testing.assert_allclose(r.stderr, np.sqrt(np.diag(cov)), rtol=1e-8)


def test_mimo_streaming_tracks_each_output():
    d = mimo(N=500, seed=6, noise=0.01)
    m = NARX(1, 2, 2, n_terms=4).fit(d)
    objs = [RecursiveNARX(m, output=o, forgetting=0.995) for o in ("a", "b")]
    for k in range(len(d)):
        for obj in objs:
            obj.step(d.outputs[k], d.inputs[k])
    ref = m.fit_recursive(d, forgetting=0.995)
    for obj, tr in zip(objs, ref):
        np.testing.assert_array_equal(obj.theta, tr.theta[-1])
