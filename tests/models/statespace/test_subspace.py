"""n4sid: exact recovery on noise-free records, consistency with noise, K, order choice.

Noise-free records of a known system must give back its eigenvalues,
frequency response and Markov parameters to rounding level (all three
weightings span the same column space Γ_i in exact arithmetic): the
tolerance 1e-8 is the issue's; the errors seen are ~1e-14.
"""

import numpy as np
import pytest

from adaptid import IDData
from adaptid.models import StateSpaceModel, n4sid

from ._systems import INNOVATION, innovation_record, noise_free, random_system, sorted_poles

METHODS = ("moesp", "n4sid", "cva")
W = np.array([0.05, 0.7, 2.0, 3.1])


@pytest.fixture(scope="module")
def mimo():
    true = random_system(seed=1, n=4, m=2, p=2, feedthrough=True)
    return true, noise_free(true, N=2000)


@pytest.mark.parametrize("method", METHODS)
def test_noise_free_mimo_recovered(mimo, method):
    true, (y, u) = mimo
    model = n4sid((y, u), 4, method=method, feedthrough=True)
    assert model.order == 4 and model.A.shape == (4, 4)
    np.testing.assert_allclose(sorted_poles(model), sorted_poles(true), atol=1e-8)
    np.testing.assert_allclose(model.freqresp(W), true.freqresp(W), atol=1e-8)
    np.testing.assert_allclose(model.markov(30), true.markov(30), atol=1e-8)
    # a noise-free record has no innovation
    np.testing.assert_array_equal(model.K, 0.0)
    # the estimated initial state reproduces the record exactly
    np.testing.assert_allclose(model.simulate((y, u), x0="estimate"), y, atol=1e-8)


@pytest.mark.parametrize("method", METHODS)
def test_order_from_singular_values(mimo, method):
    true, (y, u) = mimo
    model = n4sid((y, u), method=method, feedthrough=True)
    assert model.order == 4
    sv = model.singular_values
    assert sv[3] > 1e6 * sv[4]          # the drop the rule reads
    assert "order rule" in model.info


def test_siso_without_feedthrough():
    true = random_system(seed=3, n=3, m=1, p=1, feedthrough=False)
    y, u = noise_free(true, N=1500, seed=2)
    data = IDData(y[:, 0], u[:, 0], dt=0.1)
    model = n4sid(data, 3)
    np.testing.assert_allclose(sorted_poles(model), sorted_poles(true), atol=1e-8)
    np.testing.assert_allclose(model.markov(25), true.markov(25), atol=1e-8)
    np.testing.assert_array_equal(model.D, 0.0)
    assert model.dt == 0.1 and model.y_names == ("y",) and model.u_names == ("u",)


def test_several_experiments_kept_apart():
    true = random_system(seed=4, n=2, m=1, p=2, feedthrough=False)
    parts = [noise_free(true, N=400, seed=s) for s in (1, 2, 3)]
    model = n4sid(parts, 2)
    np.testing.assert_allclose(sorted_poles(model), sorted_poles(true), atol=1e-8)
    np.testing.assert_allclose(model.markov(20), true.markov(20), atol=1e-8)
    assert model.info["x0"].shape == (3, 2) and model.info["experiments"] == 3
    # stitched into one record, the jumps between experiments are not a system's
    y = np.vstack([p[0] for p in parts])
    u = np.vstack([p[1] for p in parts])
    stitched = n4sid((y, u), 2)
    assert np.abs(stitched.markov(20) - true.markov(20)).max() > 1e-6


def test_order_range_picks_true_order_by_aic():
    y, u = innovation_record(3000, seed=7)
    model = n4sid((y, u), range(1, 5))
    assert model.order == 2
    aic = model.info["aic"]
    assert set(aic) == {1, 2, 3, 4} and min(aic, key=aic.get) == 2


def _monte_carlo(N, method, runs=6):
    true = StateSpaceModel(**INNOVATION)
    errs = [np.abs(sorted_poles(n4sid(innovation_record(N, s), 2, method=method))
                   - sorted_poles(true)).max() for s in range(runs)]
    return float(np.mean(errs))


@pytest.mark.parametrize("method", METHODS)
def test_consistent_with_noise(method):
    # eigenvalue error ~ 1/√N: quadrupling N about halves it (seen: 0.0068 -> 0.0021)
    e1, e2 = _monte_carlo(800, method), _monte_carlo(6400, method)
    assert e2 < 0.6 * e1 and e2 < 0.01


def _observer_markov(model, count=4):
    """C A^k K, k = 0 … count-1: K in a basis-free form."""
    return np.array([model.C @ np.linalg.matrix_power(model.A, k) @ model.K for k in range(count)])


@pytest.mark.parametrize("method", METHODS)
def test_innovation_gain_and_covariance(method):
    true = StateSpaceModel(**INNOVATION)
    model = n4sid(innovation_record(20000, seed=11), 2, method=method)
    # sampling error of K's Markov parameters at N = 2·10⁴ is ~0.01 (seen 0.017 at 1.6·10⁴)
    np.testing.assert_allclose(_observer_markov(model), _observer_markov(true), atol=0.05)
    np.testing.assert_allclose(model.noise_cov, true.noise_cov, atol=0.01)
    assert np.all(np.abs(np.linalg.eigvals(model.A - model.K @ model.C)) < 1)


def test_one_step_prediction_is_the_kalman_predictor():
    true = StateSpaceModel(**INNOVATION)
    y, u = innovation_record(3000, seed=3)
    e = y - true.predict(y, u, k=1)
    # the true predictor's errors are the innovations: covariance noise_cov
    np.testing.assert_allclose(e.T @ e / e.shape[0], true.noise_cov, atol=0.01)
    model = n4sid((y, u), 2)
    e_hat = y - model.predict((y, u))
    assert np.trace(e_hat.T @ e_hat) / y.shape[0] < 1.05 * np.trace(true.noise_cov)


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"method": "pem"}, "method"),
    ({"order": 0}, "order"),
    ({"order": 30, "horizon": 5}, "order"),
    ({"horizon": 1}, "horizon"),
])
def test_errors_name_the_argument(mimo, kwargs, match):
    true, (y, u) = mimo
    with pytest.raises(ValueError, match=match):
        n4sid((y, u), **kwargs)


def test_too_short_record_refused():
    with pytest.raises(ValueError, match="data"):
        n4sid((np.zeros((30, 2)), np.zeros((30, 2))), 2, horizon=10)


def test_time_series_and_mismatched_experiments_refused():
    y = np.random.default_rng(0).standard_normal((200, 1))
    with pytest.raises(ValueError, match="input"):
        n4sid((y, np.zeros((200, 0))), 1)
    with pytest.raises(ValueError, match=r"data\[1\]"):
        n4sid([(y, y), (np.hstack([y, y]), y)], 1)
