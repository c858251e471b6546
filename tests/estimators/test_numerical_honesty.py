"""Data that overflow or underflow, and weights below the smallest normal float
(issue 32, point 6): every form warns the same way, none returns a silent θ.

Oracles: the closed forms of the cases themselves. Data of size 1e300 have
φᵀφ = inf in float64 (so no step of any form can be exact: a warning is the
only honest answer); data of size 1e-300 with a prior P0 have an information
ΦᵀΦ ≈ 1e-598 against the prior's 1/P0, so the exact regularised estimate is
0 to float64 (numpy.linalg.lstsq of the ridge-augmented rows shows it) and
silence is honest; a weight of 1e-320 (subnormal) is compared with a weight
of 0, whose result is computed by the same estimator on the same data.
"""

import warnings

import numpy as np
import pytest

import adaptid
from adaptid import CovarianceWindupWarning, DivergenceWarning

TRUE = np.array([1.0, -2.0, 0.5])

MAKERS = {
    "ud": lambda n: adaptid.RLS(n),
    "covariance": lambda n: adaptid.RLS(n, form="covariance"),
    "sqrt": lambda n: adaptid.RLS(n, form="sqrt"),
    "kalman": lambda n: adaptid.KalmanRLS(n, process_cov=1e-4),
    "window": lambda n: adaptid.SlidingWindowRLS(n, 10),
    "lms": lambda n: adaptid.LMS(n, step=0.01),
    "nlms": lambda n: adaptid.NLMS(n, step=0.5),
}
WARNING = {name: DivergenceWarning if name in ("lms", "nlms") else CovarianceWindupWarning
           for name in MAKERS}


def _data(n=3, N=60, seed=0):
    rng = np.random.default_rng(seed)
    Phi = rng.standard_normal((N, n))
    return Phi, Phi @ np.resize(TRUE, n)


def _run(est, Phi, y, **kw):
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        est.run(Phi, y, **kw)
    return [w for w in rec if issubclass(w.category, adaptid.AdaptidWarning)]


@pytest.mark.parametrize("scale", [1e300, 1e155])
@pytest.mark.parametrize("name", sorted(MAKERS))
def test_overflowing_data_warn_in_every_form(name, scale):
    Phi, y = _data()
    assert not np.isfinite(np.einsum("ij,ij->i", Phi * scale, Phi * scale)).any()  # the case
    rec = _run(MAKERS[name](3), Phi * scale, y * scale)
    assert [w.category for w in rec] == [WARNING[name]]
    assert "overflowed" in str(rec[0].message)


@pytest.mark.parametrize("n", [3, 33])  # a compile-time n (vector sweep) and a run-time n
@pytest.mark.parametrize("name", ["sqrt", "nlms"])
def test_overflow_found_by_update_batched_and_segments(name, n):
    Phi, y = _data(n=n)
    Phi, y = Phi * 1e300, y * 1e300
    est = MAKERS[name](n)
    with pytest.warns(WARNING[name], match="overflowed"):
        for k in range(3):
            est.update(Phi[k], y[k])
    with pytest.warns(WARNING[name], match="overflowed"):
        MAKERS[name](n).run_batched(np.stack([Phi, Phi / 1e300]), np.stack([y, y / 1e300]))
    with pytest.warns(WARNING[name], match="overflowed"):
        MAKERS[name](n).run_segments(Phi, y, [0, 30, 60])


@pytest.mark.parametrize("name", ["sqrt", "nlms"])
def test_no_false_alarm_on_ordinary_and_zero_regressors(name):
    Phi, y = _data(N=400)
    Phi[::7] = 0.0  # φ = 0 (and y = 0): no information, no step, no warning
    y[::7] = 0.0
    est = MAKERS[name](3)
    assert _run(est, Phi, y) == []
    np.testing.assert_allclose(est.theta, TRUE, atol=1e-6)
    assert _run(adaptid.NLMS(3, step=0.5, eps=0.0), Phi, y) == []


@pytest.mark.parametrize("scale", [1e-300, 1e-200])
@pytest.mark.parametrize("name", ["ud", "covariance", "sqrt", "kalman", "window"])
def test_underflowing_data_give_the_exact_regularised_estimate(name, scale):
    """1e-300 data: the prior dominates; the exact minimiser rounds to 0."""
    Phi, y = _data()
    P0 = 1e4
    A = np.vstack([Phi, np.eye(3) / (np.sqrt(P0) * scale)])  # cost divided by scale²
    ref = np.linalg.lstsq(A, np.concatenate([y, np.zeros(3)]), rcond=None)[0]
    assert np.all(np.abs(ref) < 1e-290)  # the case: 0 to float64
    est = MAKERS[name](3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", adaptid.DefinitenessLossWarning)  # covariance form
        est.run(Phi * scale, y * scale)
    assert np.all(np.abs(est.theta - ref) < 1e-290)


@pytest.mark.parametrize("scale", [1e-300, 1e-160])
def test_nlms_without_bias_warns_when_the_normalisation_underflows(scale):
    """eps = 0: NLMS is scale-free in exact arithmetic, so θ → TRUE is the answer;
    φᵀφ below the smallest normal float loses it, and says so."""
    Phi, y = _data()
    assert np.all(np.einsum("ij,ij->i", Phi * scale, Phi * scale) < np.finfo(float).tiny)
    rec = _run(adaptid.NLMS(3, step=0.5, eps=0.0), Phi * scale, y * scale)
    assert [w.category for w in rec] == [DivergenceWarning]
    assert "underflowed" in str(rec[0].message)


@pytest.mark.parametrize("name", sorted(MAKERS))
def test_subnormal_weights_are_zero_weights(name):
    Phi, y = _data(N=80)
    w = np.ones(80)
    w[5:25] = 1e-320
    assert 0.0 < w[5] < np.finfo(float).tiny  # the case: subnormal
    est = MAKERS[name](3)
    assert _run(est, Phi, y, weights=w) == []
    ref = MAKERS[name](3)
    w0 = np.where(w < 1.0, 0.0, w)
    _run(ref, Phi, y, weights=w0)
    assert np.array_equal(est.theta, ref.theta)
    one = MAKERS[name](3)
    with warnings.catch_warnings():
        warnings.simplefilter("error", adaptid.AdaptidWarning)
        for k in range(80):
            one.update(Phi[k], y[k], weight=float(w[k]))
    assert np.array_equal(one.theta, ref.theta)


def test_scalar_subnormal_weight_of_run_is_zero():
    Phi, y = _data()
    est = adaptid.RLS(3)
    assert _run(est, Phi, y, weights=5e-324) == []
    assert np.array_equal(est.theta, np.zeros(3))  # no sample used: the prior θ0 = 0
