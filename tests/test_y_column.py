"""Issue 33, point 9: y of shape (N, 1) is one output everywhere, squeezed.

Oracle: the same call with y of shape (N,) (bit-for-bit equal results).
"""

import numpy as np
import pytest

import adaptid
from adaptid.models import AR, ARX, IDData


@pytest.fixture
def data():
    rng = np.random.default_rng(3)
    Phi = rng.standard_normal((80, 3))
    u = rng.standard_normal(80)
    return Phi, Phi @ [1.0, -1.0, 0.5] + 0.1 * rng.standard_normal(80), u


@pytest.mark.parametrize("make", [lambda: adaptid.RLS(3), lambda: adaptid.RLS(3, form="sqrt"),
                                  lambda: adaptid.SlidingWindowRLS(3, 20),
                                  lambda: adaptid.KalmanRLS(3, process_cov=1e-4),
                                  lambda: adaptid.LMS(3, step=0.01),
                                  lambda: adaptid.NLMS(3, step=0.5)])
def test_estimators_take_a_column(data, make):
    Phi, y, _ = data
    a, b = make().run(Phi, y[:, None]), make().run(Phi, y)
    np.testing.assert_array_equal(a.theta, b.theta)
    np.testing.assert_array_equal(a.error, b.error)
    c = make().run_batched(np.stack([Phi] * 2), np.stack([y[:, None]] * 2))
    np.testing.assert_array_equal(c.theta[0], b.theta)


def test_lstsq_and_models_take_a_column(data):
    Phi, y, u = data
    np.testing.assert_array_equal(adaptid.lstsq(Phi, y[:, None]).theta, adaptid.lstsq(Phi, y).theta)
    np.testing.assert_array_equal(ARX(2, 1, 1).fit(y[:, None], u[:, None]).theta,
                                  ARX(2, 1, 1).fit(y, u).theta)
    np.testing.assert_array_equal(AR(2).fit(y[:, None]).theta, AR(2).fit(y).theta)
    np.testing.assert_array_equal(IDData(y[:, None], u).y, IDData(y, u).y)


def test_two_columns_are_refused_by_a_single_output_estimator(data):
    Phi, y, _ = data
    with pytest.raises(ValueError, match=r"y must be of shape \(80,\) or \(80, 1\)"):
        adaptid.RLS(3).run(Phi, np.column_stack([y, y]))
