"""Issue 32, point 6: a Monitor refuses a degenerate history and stops at its horizon.

Oracles: the closed form of the history's residuals (an exact fit has σ̂ = 0
up to rounding), strucchange's definition of the ME test's period (the
critical values hold for horizon × N_h samples), and an uninterrupted
Monitor fed only the covered samples (equal process and alarm).
"""

import warnings

import numpy as np
import pytest

from adaptid._exceptions import AdaptidWarning
from adaptid.diagnostics import Monitor


def test_exact_history_refused():
    x = np.linspace(0.0, 1.0, 60)
    X = np.column_stack([np.ones(60), x])
    with pytest.raises(ValueError, match="y_hist.*fit exactly"):
        Monitor(X, 2.0 + 3.0 * x)                      # residuals are rounding only
    with pytest.raises(ValueError, match="y_hist"):
        Monitor(np.ones(50), np.full(50, 7.0), kind="me")
    with pytest.raises(ValueError, match="y_hist"):
        Monitor(np.ones(50), np.zeros(50))


def test_noisy_history_accepted():
    rng = np.random.default_rng(0)
    mon = Monitor(np.ones(50), 1e-9 * rng.standard_normal(50))   # small but real noise
    assert mon.sigma > 0


def test_me_monitor_stops_at_its_horizon():
    rng = np.random.default_rng(3)
    N = 40
    y = rng.standard_normal(N * 3)
    X = np.ones(N * 3)
    mon = Monitor(X[:N], y[:N], kind="me", horizon=2)
    with pytest.warns(AdaptidWarning, match="horizon"):
        mon.run(X[N:], y[N:])
    assert mon.n_seen == 2 * N
    ref = Monitor(X[:N], y[:N], kind="me", horizon=2)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ref.run(X[N:2 * N], y[N:2 * N])
    np.testing.assert_array_equal(mon.process, ref.process)
    assert mon.alarm == ref.alarm
    with pytest.warns(AdaptidWarning, match="1 later sample"):
        mon.update(1.0, 0.0)
    assert mon.n_seen == 2 * N


def test_ols_cusum_has_no_horizon():
    rng = np.random.default_rng(4)
    mon = Monitor(np.ones(30), rng.standard_normal(30), horizon=2)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mon.run(np.ones(200), rng.standard_normal(200))
    assert mon.n_seen == 230
