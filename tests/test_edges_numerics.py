"""Numerics at the edges (issue 14, library side): no samples, standard errors past
float64, and data far below the prior's scale.

Oracles are closed forms: for one regressor column the least-squares standard
error is σ̂/‖φ‖ and the ridge (prior) minimiser is Σφy / (Σφ² + 1/P0).
"""

import math
import warnings

import numpy as np
import pytest

import adaptid
from adaptid import AdaptidWarning, PrecisionWarning, RLS


# ---------------------------------------------------------------- lstsq, N = 0
@pytest.mark.parametrize("kw", [{}, {"ridge": 1.0}, {"weights": np.zeros(0)}])
@pytest.mark.parametrize("n", [1, 3])
def test_lstsq_without_samples_says_so(n, kw):
    with pytest.raises(ValueError, match=r"Phi must be .*N >= 1.*no samples.*shape \(0, ") as e:
        adaptid.lstsq(np.zeros((0, n)), np.zeros(0), **kw)
    assert "reshape" not in str(e.value)


# ------------------------------------------------------- standard errors overflow
def test_stderr_overflow_warns_and_matches_the_closed_form():
    phi = np.array([1e-305, 1e-305])
    y = np.array([1e10, -1e10])
    res = adaptid.lstsq(phi[:, None], y)
    # closed form: θ = φᵀy/φᵀφ = 0 (QR rounding amplified by 1/‖φ‖ leaves |θ| < 1e300,
    # i.e. |φθ| < 1e-5, nothing against y), σ̂² = Σr²/(N−1) = 2e20,
    # se = σ̂/‖φ‖ = 1e315 > 1.8e308
    assert abs(res.theta[0]) < 1e300 and res.sigma2 == pytest.approx(2e20, rel=1e-12)
    assert math.sqrt(2e20) / (math.sqrt(2) * 1e-305) > np.finfo(float).max
    with pytest.warns(PrecisionWarning, match="standard errors overflow"):
        se = res.stderr
    assert np.isinf(se).all()
    assert issubclass(PrecisionWarning, AdaptidWarning)


def test_stderr_near_the_edge_is_finite_and_silent():
    """Control: the same shape of problem with a finite answer warns nothing."""
    phi = np.array([1e-290, 1e-290])
    y = np.array([1.0, -1.0])
    res = adaptid.lstsq(phi[:, None], y)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        se = res.stderr
    # se = σ̂/‖φ‖ = sqrt(2)/(sqrt(2)·1e-290) = 1e290
    np.testing.assert_allclose(se, [1e290], rtol=1e-14)


def test_stderr_of_huge_residuals_warns():
    """σ̂² = inf (residuals past 1e154, a case the fuzz found): inf standard errors, warned."""
    res = adaptid.lstsq(np.array([[1.0], [1.0], [1.0]]), np.array([1.7e308, -1.7e308, 1.7e308]))
    assert res.sigma2 == np.inf
    with pytest.warns(PrecisionWarning):
        assert np.isinf(res.stderr).all()


# ------------------------------------------- RLS on data far below the prior's scale
def test_rls_on_tiny_data_returns_the_correctly_rounded_prior_minimiser():
    """Documented behaviour (docs/reliability.md, "Numerics"): RLS minimises the cost
    with the prior term (θ − θ₀)ᵀP₀⁻¹(θ − θ₀). With data of scale 1e-200 and P0 = 1e4
    the exact minimiser is Σφy/(Σφ² + 1e-4) ≈ 2e-396·N, below the smallest float64
    (4.9e-324): θ = 0 is its correctly rounded value, not a failure. Rescaling the data
    (or using lstsq, which has no prior) recovers θ = 2."""
    rng = np.random.default_rng(0)
    x = rng.standard_normal(50)
    scale = 1e-200
    Phi, y = (scale * x)[:, None], scale * 2.0 * x
    est = RLS(1, P0=1e4)
    est.run(Phi, y)
    exact = float(np.sum(x * 2 * x)) * scale * scale / (1e-4)   # ≈ prior-dominated value
    assert exact == 0.0                       # underflows: the float64 answer is 0
    assert est.theta[0] == 0.0
    # the remedies the documentation names
    est = RLS(1, P0=1e4)
    est.run(Phi / scale, y / scale)
    assert est.theta[0] == pytest.approx(2.0, rel=1e-4)   # prior 1e-4 vs Σx² ≈ 50
    assert adaptid.lstsq(Phi, y).theta[0] == pytest.approx(2.0, rel=1e-14)
