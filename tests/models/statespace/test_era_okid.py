"""era from exact Markov parameters; okid from input–output data (noise-free and noisy)."""

import numpy as np
import pytest

from adaptid.models import StateSpaceModel, era, okid

from ._systems import INNOVATION, innovation_record, noise_free, random_system, sorted_poles

W = np.array([0.05, 0.7, 2.0, 3.1])


def test_era_recovers_a_mimo_system_from_its_markov_parameters():
    true = random_system(seed=1, n=4, m=2, p=2)
    model = era(true.markov(40), 4, dt=0.5)
    np.testing.assert_allclose(sorted_poles(model), sorted_poles(true), atol=1e-8)
    np.testing.assert_allclose(model.markov(40), true.markov(40), atol=1e-8)
    np.testing.assert_allclose(model.freqresp(W / 0.5), true.freqresp(W), atol=1e-8)
    assert model.dt == 0.5 and model.info["method"] == "era"


def test_era_order_from_singular_values_and_siso_input():
    true = random_system(seed=6, n=3, m=1, p=1, feedthrough=False)
    model = era(true.markov(30)[:, 0, 0])           # a 1-D sequence: SISO
    assert model.order == 3
    np.testing.assert_allclose(model.markov(30), true.markov(30), atol=1e-8)


def test_era_refuses_too_few_parameters():
    with pytest.raises(ValueError, match="markov"):
        era(np.ones((5, 1, 1)), 4)


@pytest.mark.parametrize("feedthrough", [True, False])
def test_okid_noise_free_mimo(feedthrough):
    true = random_system(seed=1, n=4, m=2, p=2, feedthrough=feedthrough)
    y, u = noise_free(true, N=2000)
    model = okid((y, u), 4, 6, feedthrough=feedthrough)   # deadbeat: 6·2 ≥ 4
    np.testing.assert_allclose(sorted_poles(model), sorted_poles(true), atol=1e-8)
    np.testing.assert_allclose(model.markov(30), true.markov(30), atol=1e-8)
    np.testing.assert_allclose(model.freqresp(W), true.freqresp(W), atol=1e-8)


def test_okid_with_noise_estimates_the_kalman_gain():
    true = StateSpaceModel(**INNOVATION)
    model = okid(innovation_record(20000, seed=11), 2, 15)
    np.testing.assert_allclose(sorted_poles(model), sorted_poles(true), atol=0.02)
    ok = np.array([model.C @ np.linalg.matrix_power(model.A, k) @ model.K for k in range(4)])
    ot = np.array([true.C @ np.linalg.matrix_power(true.A, k) @ true.K for k in range(4)])
    np.testing.assert_allclose(ok, ot, atol=0.05)
    np.testing.assert_allclose(model.noise_cov, true.noise_cov, atol=0.01)


def test_era_exact_low_rank_hankel_gives_the_rank():
    # h_k = 0.5^(k-1): a first-order system whose Hankel matrix has exact zeros
    model = era(np.r_[0.0, 0.5 ** np.arange(10)])
    assert model.order == 1
    np.testing.assert_allclose(model.poles(), [0.5])
    assert era([0.0, 1.0, 0.5]).order == 1               # the shortest sequence ERA takes
