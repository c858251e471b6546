"""Exact diffuse start in the models' recursive fits (issue 16, point 1).

``fit_recursive(..., estimator)`` with an estimator built with ``P0="diffuse"``.

Oracles (none of them adaptid code):

* ``numpy.linalg.lstsq`` on the regressor rows so far, scaled by
  sqrt(λ^{k-j}) (forgetting) and cut to the last M rows (window): the exact
  weighted least-squares solution, the minimum-norm one when rank-deficient
  (rcond = 1e-10, adaptid's documented ``DIFFUSE_RCOND``);
* ``numpy.linalg.matrix_rank`` of the same rows with the same relative
  tolerance for the ``identified`` flags;
* for the pseudo-linear models (ARMAX, ARMA, OE, BJ) the regressors the
  recursion formed (``Trajectory.meta["regressors"]``) are first checked
  against their textbook definitions (Ljung 1999, sec. 11.3 RELS; Söderström
  & Stoica 1989, sec. 9.4 RPLR), every dynamic entry recomputed here from
  the earlier rows and estimates: the a-posteriori residual
  ε_t = y_t − φ_tᵀθ_t, the simulated output w_t of the B/F part,
  v_t = y_t − w_t, all zero before the first row. The recursion with a
  diffuse start must then be exactly the weighted least squares on them;
* the Kalman filter with a random walk (R₁ ≠ 0) against the core
  ``KalmanRLS(P0="diffuse")`` on those rebuilt regressors (that one is tested
  against statsmodels' exact diffuse filter in test_diffuse.py).

Tolerance 1e-10 relative: the data here have cond(Φ) below ~1e3 (measured
errors 1e-14 .. 1e-12); a 1/P0 ridge term of a large finite P0 = 1e10 gives
errors of 1e-8 and more at the first samples (test_diffuse.py).
"""

import numpy as np
import pytest
from scipy.signal import lfilter

import adaptid
from adaptid import KalmanRLS, RLS, SlidingWindowRLS
from adaptid.models import ARMA, ARMAX, ARX, BJ, OE

RCOND = 1e-10


def _rel(a, b):
    return np.max(np.abs(np.asarray(a) - np.asarray(b))) / max(np.max(np.abs(b)), 1e-300)


def _plant(rng, N=300, quiet=None):
    """y = (q⁻¹ + 0.5q⁻²)/(1 − 1.5q⁻¹ + 0.7q⁻²) u + (1 + 0.5q⁻¹)/(1 − 0.5q⁻¹) e;
    u is zero on the slice ``quiet`` (a stretch without excitation)."""
    u = rng.standard_normal(N)
    if quiet is not None:
        u[quiet] = 0.0
    e = 0.1 * rng.standard_normal(N)
    y = lfilter([0, 1.0, 0.5], [1, -1.5, 0.7], u) + lfilter([1, 0.5], [1, -0.5], e)
    return y, u


ESTIMATORS = {
    "rls": (lambda n: RLS(n, P0="diffuse"), 0, 1.0),
    "rls_forgetting": (lambda n: RLS(n, forgetting=0.97, P0="diffuse"), 0, 0.97),
    "window": (lambda n: SlidingWindowRLS(n, 40, P0="diffuse"), 40, 1.0),
    "window_forgetting": (lambda n: SlidingWindowRLS(n, 40, forgetting=0.98, P0="diffuse"), 40,
                          0.98),
    # a random walk with R₁ = 0 is least squares (weights 1/R₂, all equal)
    "kalman": (lambda n: KalmanRLS(n, process_cov=0.0, noise_var=0.3, P0="diffuse"), 0, 1.0),
}


def _check_exact(traj, Phi, Y, M, lam, tol=1e-10):
    """θ_k is the weighted (windowed) least squares on the rows so far, at every k;
    ``identified[k]`` is the full numerical rank of those rows. Returns the
    number of identified samples."""
    n = Phi.shape[1]
    assert traj.identified is not None and traj.identified.shape == (len(Y),)
    count = 0
    for k in range(len(Y)):
        lo = max(0, k - M + 1) if M else 0
        s = np.sqrt(lam ** (k - np.arange(lo, k + 1)))
        A, b = Phi[lo:k + 1] * s[:, None], Y[lo:k + 1] * s
        sv = np.linalg.svd(A, compute_uv=False)
        full = sv.size == n and sv[-1] > RCOND * sv[0]
        assert bool(traj.identified[k]) == full, k
        ref = np.linalg.lstsq(A, b, rcond=RCOND)[0]
        assert _rel(traj.theta[k], ref) < tol, (k, full)
        count += full
    return count


# ----------------------------------------------------------------------- ARX
@pytest.mark.parametrize("kind", sorted(ESTIMATORS))
def test_arx_every_sample_is_weighted_lstsq(rng, kind):
    """ARX regressors (fixed): φ_t = [-y_{t-1}, -y_{t-2}, u_{t-1}, u_{t-2}], built here."""
    make, M, lam = ESTIMATORS[kind]
    y, u = _plant(rng)
    tr = ARX(2, 2, 1).fit_recursive(y, u, make(4))
    t = np.arange(2, len(y))
    np.testing.assert_array_equal(tr.meta["index"], t)
    Phi = np.column_stack([-y[t - 1], -y[t - 2], u[t - 1], u[t - 2]])
    assert _check_exact(tr, Phi, y[t], M, lam) >= len(t) - 4


# ------------------------------------------------- pseudo-linear regressors
# The recursion's regressors are Trajectory.meta["regressors"]. They are checked
# here row by row against their definition, each dynamic entry recomputed from
# the previous rows and estimates (rebuilding them recursively instead would
# amplify rounding by |c| > 1 of early estimates at every step).
def _armax_rows(tr, y, u, na, nb, nc, nk=1):
    """RELS regressors [-y_{t-1..t-na}, u_{t-nk..}, ε_{t-1..t-nc}], ε_t = y_t − φ_tᵀθ_t."""
    t = tr.meta["index"]
    Phi = tr.meta["regressors"]
    eps = y[t] - np.sum(Phi * tr.theta, axis=1)
    cols = [-y[t - i] for i in range(1, na + 1)] + [u[t - nk - j] for j in range(nb)]
    cols += [np.r_[np.zeros(i), eps[:-i]] for i in range(1, nc + 1)]
    _same_rows(Phi, np.column_stack(cols), y)
    return Phi


def _bj_rows(tr, y, u, nb, nc, nd, nf, nk=1):
    """PLR regressors of BJ / OE (nc = nd = 0): [u_{t-nk..}, ε_{t-1..}, −v_{t-1..}, −w_{t-1..}]
    with w_t the B and F part of φ_tᵀθ_t (simulated output), v_t = y_t − w_t,
    ε_t = y_t − φ_tᵀθ_t."""
    t = tr.meta["index"]
    Phi = tr.meta["regressors"]
    prod = Phi * tr.theta
    w = prod[:, :nb].sum(axis=1) + prod[:, nb + nc + nd:].sum(axis=1)
    v = y[t] - w
    eps = y[t] - prod.sum(axis=1)

    def lag(x, i):
        return np.r_[np.zeros(i), x[:-i]]

    cols = [u[t - nk - j] for j in range(nb)] + [lag(eps, i) for i in range(1, nc + 1)]
    cols += [-lag(v, i) for i in range(1, nd + 1)] + [-lag(w, i) for i in range(1, nf + 1)]
    _same_rows(Phi, np.column_stack(cols), y)
    return Phi


def _same_rows(Phi, expected, y):
    # the kernel sums φᵢθᵢ in another order: rounding of |y|·|θ|-sized terms
    scale = np.max(np.abs(y)) * max(1.0, np.max(np.abs(expected)))
    np.testing.assert_allclose(Phi, expected, rtol=0, atol=1e-13 * scale)


MODELS = {
    "armax": (lambda: ARMAX(2, 2, 1), True, lambda tr, y, u: _armax_rows(tr, y, u, 2, 2, 1)),
    "arma": (lambda: ARMA(2, 1), False, lambda tr, y, u: _armax_rows(tr, y, u, 2, 0, 1)),
    "oe": (lambda: OE(2, 2, 1), True, lambda tr, y, u: _bj_rows(tr, y, u, 2, 0, 0, 2)),
    "bj": (lambda: BJ(2, 1, 1, 2, 1), True, lambda tr, y, u: _bj_rows(tr, y, u, 2, 1, 1, 2)),
}


def _fit(model, with_u, est, y, u):
    m = model()
    tr = m.fit_recursive(y, u, est) if with_u else m.fit_recursive(y, est)
    return m, tr


@pytest.mark.parametrize("kind", sorted(ESTIMATORS))
@pytest.mark.parametrize("name", sorted(MODELS))
def test_pseudolinear_is_weighted_lstsq_on_its_regressors(rng, name, kind):
    model, with_u, rows = MODELS[name]
    make, M, lam = ESTIMATORS[kind]
    y, u = _plant(rng)
    n = {"armax": 5, "arma": 3, "oe": 4, "bj": 6}[name]
    est = make(n)
    m, tr = _fit(model, with_u, est, y, u)
    assert est.n_updates == 0 and not est.identified  # the argument is read, not run
    Phi = rows(tr, y, u)
    Y = y[tr.meta["index"]]
    # identified from the first full-rank sample on (the lagged signals start at 0)
    assert _check_exact(tr, Phi, Y, M, lam) >= len(Y) - 2 * n
    assert np.all(np.isfinite(m.P))


@pytest.mark.parametrize("name", ["armax", "bj"])
def test_window_loses_and_regains_rank(rng, name):
    """u = 0 on a stretch longer than the window: the input columns of the rows in the
    window vanish, the window is re-solved without a prior and is not identified
    (θ the minimum-norm solution), then identified again once u returns."""
    model, with_u, rows = MODELS[name]
    y, u = _plant(rng, N=260, quiet=slice(100, 170))
    n = 5 if name == "armax" else 6
    with pytest.warns(adaptid.DefinitenessLossWarning):  # as the core window warns
        m, tr = _fit(model, with_u, SlidingWindowRLS(n, 30, P0="diffuse"), y, u)
    Phi = rows(tr, y, u)
    _check_exact(tr, Phi, y[tr.meta["index"]], 30, 1.0)
    ident = tr.identified
    assert ident[60] and not ident[150] and ident[-1]


def test_kalman_random_walk_equals_core_filter_on_the_regressors(rng):
    """R₁ ≠ 0: the pseudo-linear recursion is the core diffuse Kalman filter run on the
    regressors it formed (same arithmetic: equal to rounding)."""
    y, u = _plant(rng)
    Q = np.diag([1e-4, 1e-4, 1e-3, 1e-3, 1e-5])
    m, tr = _fit(MODELS["armax"][0], True, KalmanRLS(5, process_cov=Q, noise_var=0.2,
                                                      P0="diffuse"), y, u)
    Phi = _armax_rows(tr, y, u, 2, 2, 1)
    core = KalmanRLS(5, process_cov=Q, noise_var=0.2, P0="diffuse")
    ref = core.run(Phi, y[tr.meta["index"]])
    np.testing.assert_array_equal(tr.identified, ref.identified)
    np.testing.assert_allclose(tr.theta, ref.theta, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(tr.error, ref.error, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(m.P, core.P, rtol=1e-9)


def test_continues_a_diffuse_rls_that_already_ran(rng):
    """An RLS in its diffuse phase (2 samples, rank 2 < 5) is the starting point:
    θ is then least squares on its 2 rows and the rows the recursion formed."""
    y, u = _plant(rng)
    A0 = rng.standard_normal((2, 5))
    b0 = rng.standard_normal(2)
    est = RLS(5, P0="diffuse")
    est.run(A0, b0)
    m, tr = _fit(MODELS["armax"][0], True, est, y, u)
    Phi = np.vstack([A0, _armax_rows(tr, y, u, 2, 2, 1)])
    Y = np.r_[b0, y[tr.meta["index"]]]
    for k in (0, 1, 2, 3, 50, len(Y) - 3):
        ref = np.linalg.lstsq(Phi[:k + 3], Y[:k + 3], rcond=RCOND)[0]
        assert _rel(tr.theta[k], ref) < 1e-10, k
    assert tr.identified[2] and not tr.identified[0]


def test_finite_prior_has_no_identified_flags(rng):
    y, u = _plant(rng)
    _, tr = _fit(MODELS["oe"][0], True, RLS(4, P0=1e4), y, u)
    assert tr.identified is None


def test_used_diffuse_window_is_refused(rng):
    y, u = _plant(rng)
    est = SlidingWindowRLS(5, 30, P0="diffuse")
    est.run(rng.standard_normal((3, 5)), rng.standard_normal(3))
    with pytest.raises(ValueError, match="estimator"):
        ARMAX(2, 2, 1).fit_recursive(y, u, est)


# ----------------------------------------------------------------------- CLI
@pytest.mark.parametrize("args,make", [
    (["--bj", "2,1,1,2,1", "--method", "rls"],
     lambda y, u: BJ(2, 1, 1, 2, 1).fit_recursive(y, u, RLS(6, P0="diffuse"))),
    (["--arma", "2,1", "--method", "window", "--window", "60"],
     lambda y, u: ARMA(2, 1).fit_recursive(y, SlidingWindowRLS(3, 60, P0="diffuse"))),
    (["--bj", "2,1,1,2,1", "--method", "kalman", "--process-cov", "1e-6"],
     lambda y, u: BJ(2, 1, 1, 2, 1).fit_recursive(
         y, u, KalmanRLS(6, process_cov=1e-6, P0="diffuse"))),
], ids=["bj_rls", "arma_window", "bj_kalman"])
def test_cli_model_fit_P0_diffuse_matches_python(rng, tmp_path, args, make):
    import json

    import pandas as pd
    from typer.testing import CliRunner

    from adaptid.cli._app import app
    y, u = _plant(rng)
    path = tmp_path / "d.csv"
    pd.DataFrame({"u": u, "y": y}).to_csv(path, index=False, float_format="%.17g")
    cols = ["--y", "y"] + (["--u", "u"] if "--bj" in args else [])
    res = CliRunner().invoke(app, ["fit", str(path), *cols, *args, "--P0", "diffuse", "--json"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout)
    tr = make(y, u)
    assert tr.identified[-1]
    # the CSV holds every digit: same data, same compiled recursion (1e-12: rounding only)
    np.testing.assert_allclose(out["theta"], tr.theta[-1], rtol=1e-12)


def test_factory_estimator_goes_through(rng):
    """``adaptid.estimator(..., P0="diffuse")`` is the estimator the CLI builds."""
    y, u = _plant(rng)
    tr = OE(2, 2, 1).fit_recursive(y, u, adaptid.estimator("rls", 4, P0="diffuse"))
    assert tr.identified[-1]
