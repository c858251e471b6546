"""The parameter covariance of a state-space model from its Jacobian in chunks (issue 36).

``estimate_cov`` reduces the whitened Jacobian of the prediction errors to
its R factor chunk by chunk (``max_memory=``). The reference here is the
unchunked formula written out in NumPy: the whole Jacobian from the compiled
recursion (``_sensitivities``, not what is under test), the initial states
by one ``lstsq`` over the whole record, Λ̂ whitened by its Cholesky factor
(the code uses the symmetric square root), and one SVD pseudo-inverse of the
whole whitened Jacobian on the complement of the similarity directions.
"""

import tracemalloc

import numpy as np
import pytest

from adaptid import IDData
from adaptid.models import StateSpaceModel, n4sid
from adaptid.models.statespace import _passes
from adaptid.models.statespace._uncertainty import RCOND, _sensitivities, _similarity, n_params

from ._systems import innovation_record, random_system


def _x0_lstsq(model, Y, U):
    """arg min over x̂₀ of the one-step errors (affine in x̂₀: ε = ε(0) − C Āᵏ x̂₀)."""
    n = model.order
    Abar = model.A - model.K @ model.C
    Phi = np.empty((Y.shape[0], model.n_outputs, n))
    M = np.eye(n)
    for k in range(Y.shape[0]):
        Phi[k] = model.C @ M
        M = Abar @ M
    eps0 = Y - model.predict(Y, U, k=1)
    return np.linalg.lstsq(Phi.reshape(-1, n), eps0.reshape(-1), rcond=None)[0]


def _reference_cov(model, runs, feedthrough, x0="estimate"):
    """Cov θ = (Σ ψₖᵀ Λ̂⁻¹ ψₖ)⁺ from the whole Jacobian, similarity directions projected out."""
    n, m, p = model.order, model.n_inputs, model.n_outputs
    d, nE = n_params(n, m, p), len(runs)
    x0s = [_x0_lstsq(model, Y, U) if x0 == "estimate" else np.zeros(n) for Y, U in runs]
    errs, jacs = [], []
    for e, ((Y, U), xs) in enumerate(zip(runs, x0s)):
        E, Jb = _sensitivities(model, Y, U, xs)
        J = np.zeros((Y.shape[0], p, d + n * nE))
        J[:, :, :d] = Jb[:, :, :d]
        J[:, :, d + e * n: d + (e + 1) * n] = Jb[:, :, d:]
        errs.append(E)
        jacs.append(J)
    E, J = np.vstack(errs), np.concatenate(jacs)
    L = np.linalg.cholesky(E.T @ E / E.shape[0])
    Jw = np.linalg.solve(L, J.transpose(1, 0, 2).reshape(p, -1)).reshape(p, -1, J.shape[2])
    Jw = Jw.transpose(1, 0, 2).reshape(-1, J.shape[2])       # rows L⁻¹ψₖ, sample by sample
    free = np.ones(d + n * nE, dtype=bool)
    if not feedthrough:
        free[n * n + n * m + p * n: n * n + n * m + p * n + p * m] = False
    if x0 != "estimate":
        free[d:] = False
    V = _similarity(model.A, model.B, model.C, model.K, x0s)[free]
    Uv, sv, _ = np.linalg.svd(V)
    Q = Uv[:, int(np.sum(sv > 1e-12 * max(sv[0], 1.0))):]
    H = Q @ np.linalg.pinv(Jw[:, free] @ Q, rcond=RCOND)
    full = H @ H.T
    idx = np.flatnonzero(free[:d])
    cov = np.zeros((d, d))
    cov[np.ix_(idx, idx)] = full[: idx.size, : idx.size]
    Us, ss, _ = np.linalg.svd(_similarity(model.A, model.B, model.C, model.K, []),
                              full_matrices=False)
    P = np.eye(d) - Us[:, ss > 1e-12 * ss[0]] @ Us[:, ss > 1e-12 * ss[0]].T
    return P @ cov @ P


def _budget(model, rows):
    """max_memory that makes chunks of ``rows`` samples."""
    n, m, p = model.order, model.n_inputs, model.n_outputs
    return rows * 8 * p * (n_params(n, m, p) + n)


def _assert_close(got, ref):
    # the same sums of squares reduced in another order (chunked QR against one SVD of the
    # whole matrix; the x̂₀ by chunked QR against lstsq): equal to rounding
    assert np.abs(ref).max() > 0
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-10 * np.abs(ref).max())


def _mimo_case():
    y, u = innovation_record(230, 3)
    return n4sid((y, u), 2, horizon=5), [(y, u)], (y, u)


def _siso_feedthrough_case():
    sysm = random_system(2, n=3, m=1, p=1, feedthrough=True)
    rng = np.random.default_rng(7)
    u = rng.standard_normal((190, 1))
    y = sysm.simulate(u) + 0.2 * rng.standard_normal((190, 1))
    return n4sid((y, u), 3, horizon=6, feedthrough=True), [(y, u)], (y, u)


def _gaps_and_experiments_case():
    y, u = innovation_record(260, 4)
    y2, u2 = innovation_record(150, 5)
    y[90:93] = np.nan                          # a gap: the record is two runs
    data = [IDData(y, u), (y2, u2)]
    model = n4sid(data, 2, horizon=4, feedthrough=True)
    runs = [(y[:90], u[:90]), (y[93:], u[93:]), (y2, u2)]
    return model, runs, data


CASES = {"mimo": _mimo_case, "siso_feedthrough": _siso_feedthrough_case,
         "gaps_experiments": _gaps_and_experiments_case}


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("rows", [1, 3, 7, None, 10**6])
def test_chunked_cov_equals_the_whole_jacobian_formula(case, rows):
    """Chunks of 1 row, a few rows, a size not dividing N, the default, more than N."""
    model, runs, data = CASES[case]()
    assert sum(Y.shape[0] % 7 for Y, _ in runs) > 0          # 7 does not divide the runs
    ft = model.info["feedthrough"]
    ref = _reference_cov(model, runs, ft)
    got = model.estimate_cov(data, max_memory=None if rows is None else _budget(model, rows))
    _assert_close(got, ref)


@pytest.mark.parametrize("rows", [1, 5])
def test_chunked_cov_with_a_zero_initial_state_and_no_feedthrough(rows):
    model, runs, data = _mimo_case()
    ref = _reference_cov(model, runs, False, x0="zero")
    got = model.estimate_cov(data, x0="zero", feedthrough=False,
                             max_memory=_budget(model, rows))
    _assert_close(got, ref)
    oD = 4 + 4 + 4
    assert np.all(got[oD:oD + 4] == 0) and np.all(got[:, oD:oD + 4] == 0)


def test_max_memory_sets_the_chunk_rows(monkeypatch):
    """The sensitivity kernel sees chunks of N_c = max_memory // (8 p (d + n)) samples."""
    model, runs, data = _mimo_case()
    seen = []
    kernel = _passes.predictor_sensitivity

    def spy(*args):
        seen.append(args[5].shape[0])
        return kernel(*args)

    monkeypatch.setattr(_passes, "predictor_sensitivity", spy)
    d_plus_n = n_params(2, 2, 2) + 2
    model.estimate_cov(data, max_memory=8 * 2 * d_plus_n * 40 + 8 * 2 * d_plus_n - 1)   # 40.99
    assert seen == [40] * 5 + [30]                             # N = 230
    seen.clear()
    model.estimate_cov(data, max_memory=1)
    assert seen == [1] * 230
    seen.clear()
    model.estimate_cov(data)                                   # 32 MiB: one chunk here
    assert seen == [230]


def test_peak_memory_is_bounded_by_the_chunks():
    """A record whose whole Jacobian is 21 MB, chunks of 0.5 MiB: the peak stays a few MB."""
    y, u = innovation_record(3000, 9)
    model = n4sid((y, u), 2, horizon=5)
    N = 100_000
    rng = np.random.default_rng(0)
    U = rng.standard_normal((N, 2))
    Y = model.simulate(U) + 0.1 * rng.standard_normal((N, 2))
    jac_bytes = N * 2 * (n_params(2, 2, 2) + 2) * 8
    model.estimate_cov((Y[:500], U[:500]), max_memory=2**19)   # compile, import
    tracemalloc.start()
    try:
        cov = model.estimate_cov((Y, U), max_memory=2**19)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert np.all(np.isfinite(cov)) and np.trace(cov) > 0
    # the record (3.2 MB, copied at most once by the validation) and a few chunks of rows
    assert peak < 0.4 * jac_bytes, (peak, jac_bytes)


def test_max_memory_is_validated():
    model = StateSpaceModel([[0.5]], [[1.0]], [[1.0]], K=[[0.2]])
    y, u = np.random.default_rng(1).standard_normal((2, 50))
    for bad in (0, -5):
        with pytest.raises(ValueError, match="max_memory"):
            model.estimate_cov((y, u), max_memory=bad)
    with pytest.raises(TypeError, match="max_memory"):
        model.estimate_cov((y, u), max_memory=1.5)
