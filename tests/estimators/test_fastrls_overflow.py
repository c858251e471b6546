"""FastRLS on data whose squares overflow (issue 32, point 6, for the filter of issue 38).

Oracle: the float range (1e300² = inf); controls: the same data scaled to
order 1 run silently with finite errors.
"""

import warnings

import numpy as np
import pytest

import adaptid
from adaptid._exceptions import DivergenceWarning


@pytest.fixture
def data():
    rng = np.random.default_rng(0)
    u = rng.standard_normal(300)
    return u, np.convolve(u, [1.0, 0.5, -0.2])[:300]


def test_ftf_warns_when_the_data_overflow(data):
    u, y = data
    with pytest.warns(DivergenceWarning, match="overflowed"):
        adaptid.FastRLS(4, forgetting=0.99).run_fir(1e300 * u, 1e300 * y)


def test_lattice_refuses_and_keeps_its_state(data):
    u, y = data
    f = adaptid.FastRLS(4, forgetting=0.99, method="lattice")
    f.run_fir(u[:50], y[:50])
    before = f.get_state()
    with pytest.raises(ValueError, match="u and y"):
        f.run_fir(1e300 * u, 1e300 * y)
    after = f.get_state()
    for key, value in before.items():
        if isinstance(value, np.ndarray):
            np.testing.assert_array_equal(after[key], value)


@pytest.mark.parametrize("method", ["ftf", "lattice"])
def test_control_order_one_data_is_silent(data, method):
    u, y = data
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        tr = adaptid.FastRLS(4, forgetting=0.99, method=method).run_fir(u, y)
    assert np.isfinite(tr.error).all()
