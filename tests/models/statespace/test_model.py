"""StateSpaceModel: simulation, k-step prediction, responses, presentation, the workflow."""

import matplotlib
import numpy as np
import pytest

from adaptid import IDData
from adaptid.models import StateSpaceModel, compare, n4sid, resid

from ._systems import INNOVATION, innovation_record, random_system

matplotlib.use("Agg")


def _naive_predict(model, y, u, k):
    """ŷ(t|t−k) by brute force: the Kalman predictor to t−k+1, then k−1 free steps."""
    A, B, C, D, K = model.A, model.B, model.C, model.D, model.K
    N = y.shape[0]
    xs = [np.zeros(model.order)]            # x̂(t|t−1)
    for t in range(N):
        e = y[t] - C @ xs[t] - D @ u[t]
        xs.append(A @ xs[t] + B @ u[t] + K @ e)
    out = np.empty_like(y)
    for t in range(N):
        s = max(t - k + 1, 0)
        x = xs[s] if t - k + 1 >= 0 else np.zeros(model.order)
        start = s if t - k + 1 >= 0 else 0
        for r in range(start, t):
            x = A @ x + B @ u[r]
        out[t] = C @ x + D @ u[t]
    return out


@pytest.mark.parametrize("k", [1, 2, 5])
def test_predict_matches_brute_force(k):
    model = StateSpaceModel(**INNOVATION, D=[[0.1, 0.0], [0.0, -0.2]])
    y, u = innovation_record(120, seed=1)
    np.testing.assert_allclose(model.predict(y, u, k=k), _naive_predict(model, y, u, k),
                               atol=1e-12)


def test_simulate_equals_loop_and_python_control():
    control = pytest.importorskip("control")
    model = random_system(seed=2, n=3, m=2, p=2)
    rng = np.random.default_rng(0)
    u, x0 = rng.standard_normal((200, 2)), rng.standard_normal(3)
    y = model.simulate(u, x0=x0)
    sys = model.to_control()
    assert sys.dt == model.dt and sys.ninputs == 2 and sys.noutputs == 2
    ref = control.forced_response(sys, U=u.T, X0=x0).outputs.T
    np.testing.assert_allclose(y, ref, atol=1e-10)
    w = np.array([0.1, 1.0, 3.0])
    # issue 36: freqresp returns a FrequencyResponse, response (p, m, F) as python-control's
    np.testing.assert_allclose(model.freqresp(w).response, sys(np.exp(1j * w)), atol=1e-12)


def test_responses_and_poles():
    model = StateSpaceModel([[0.5, 0.0], [0.0, -0.25]], [[1.0], [2.0]], [[1.0, 1.0]], [[0.5]])
    mk = model.markov(4)[:, 0, 0]
    np.testing.assert_allclose(mk, [0.5, 3.0, 0.5 - 0.5, 0.25 + 0.125])
    np.testing.assert_allclose(model.step_response(4).response, np.cumsum(mk))  # (T,): SISO
    np.testing.assert_allclose(np.sort(model.poles().real), [-0.25, 0.5])
    # freqresp at ω = 0 is the DC gain D + C (I − A)⁻¹ B
    np.testing.assert_allclose(model.freqresp([0.0]).response[0], 0.5 + 2 + 2 / 1.25)


def test_estimate_x0_recovers_the_initial_state():
    model = random_system(seed=5, n=4, m=2, p=2)
    rng = np.random.default_rng(1)
    u, x0 = rng.standard_normal((300, 2)), rng.standard_normal(4)
    y = model.simulate(u, x0=x0)
    np.testing.assert_allclose(model.estimate_x0((y, u)), x0, atol=1e-10)


def test_summary_frame_plot_and_repr():
    y, u = innovation_record(1500, seed=2)
    model = n4sid(IDData(y, u, y_names=["p", "q"], u_names=["a", "b"]), 2)
    text = str(model.summary())
    for piece in ("order", "moesp", "fit % p (simulation, x0 estimated)", "K:", "poles:",
                  "singular values"):
        assert piece in text
    assert model.summary()["order"] == 2
    assert "<table>" in model._repr_html_()
    frame = model.to_frame()
    assert set(frame["matrix"]) == {"A", "B", "C", "D", "K", "noise_cov"}
    assert len(frame) == 4 + 4 + 4 + 4 + 4 + 4
    fig = model.plot()
    assert type(fig).__name__ == "Figure" and fig.axes[0].get_yscale() == "log"
    fig2 = StateSpaceModel([[0.5]], [[1.0]], [[1.0]]).plot()
    assert len(fig2.axes) == 1
    assert "StateSpaceModel(order=2" in repr(model)


def test_compare_and_resid_accept_a_siso_model():
    true = StateSpaceModel([[0.8, 0.2], [0.0, 0.5]], [[1.0], [0.5]], [[1.0, 0.0]], K=[[0.5], [0.2]],
                           noise_cov=[[0.01]])
    rng = np.random.default_rng(3)
    N = 2000
    u, e = rng.standard_normal((N, 1)), 0.1 * rng.standard_normal((N, 1))
    x, y = np.zeros(2), np.empty((N, 1))
    for k in range(N):
        y[k] = true.C @ x + e[k]
        x = true.A @ x + true.B @ u[k] + true.K @ e[k]
    est, val = IDData(y[:, 0], u[:, 0]).split(0.5)
    model = n4sid(est, 2)
    res = compare(val, model, k=1)
    assert res.fit[0] > 80
    assert compare(val, model).fit[0] > 60
    assert resid(val, model).white


def test_constructor_checks_shapes():
    with pytest.raises(ValueError, match="A"):
        StateSpaceModel(np.ones((2, 3)), np.ones((2, 1)), np.ones((1, 2)))
    with pytest.raises(ValueError, match="B"):
        StateSpaceModel(np.eye(2), np.ones((3, 1)), np.ones((1, 2)))
    with pytest.raises(ValueError, match="K"):
        StateSpaceModel(np.eye(2), np.ones((2, 1)), np.ones((1, 2)), K=np.ones((3, 1)))
    with pytest.raises(ValueError, match="x0"):
        StateSpaceModel(np.eye(2) / 2, np.ones((2, 1)), np.ones((1, 2))).simulate(
            np.ones(5), x0="zero")
