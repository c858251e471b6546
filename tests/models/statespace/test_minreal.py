"""The orthogonal staircase reduction (models/statespace/_minreal.py) on systems
built as a Kalman decomposition, whose controllable-and-observable part is known
by construction, hidden by a random orthogonal change of coordinates."""

import numpy as np
import pytest
from scipy.stats import ortho_group

from adaptid.models.statespace._minreal import controllable_part, minimal_realization


def _kalman_decomposition(rng, sizes, m=2, p=2):
    """(A, B, C) in the coordinates (co, c-not-o, not-c-o, not-c-not-o), rotated.

    Returns the rotated system and the co block's (A, B, C)."""
    n_co, n_cno, n_nco, n_ncno = sizes
    n = sum(sizes)
    A = np.zeros((n, n))
    i = np.cumsum([0] + list(sizes))
    blocks = [slice(i[k], i[k + 1]) for k in range(4)]
    co, cno, nco, ncno = blocks
    for b in blocks:   # stable diagonal blocks with distinct eigenvalues
        A[b, b] = np.diag(rng.uniform(-0.9, 0.9, b.stop - b.start)) + \
            0.1 * np.triu(rng.standard_normal((b.stop - b.start,) * 2), 1)
    # the couplings the decomposition allows (Kalman 1963's block pattern)
    A[co, nco] = rng.standard_normal((n_co, n_nco))
    A[cno, co] = rng.standard_normal((n_cno, n_co))
    A[cno, nco] = rng.standard_normal((n_cno, n_nco))
    A[cno, ncno] = rng.standard_normal((n_cno, n_ncno))
    A[ncno, nco] = rng.standard_normal((n_ncno, n_nco))
    B = np.zeros((n, m))
    B[co] = rng.standard_normal((n_co, m))
    B[cno] = rng.standard_normal((n_cno, m))
    C = np.zeros((p, n))
    C[:, co] = rng.standard_normal((p, n_co))
    C[:, nco] = rng.standard_normal((p, n_nco))
    Q = ortho_group.rvs(n, random_state=rng)
    return (Q.T @ A @ Q, Q.T @ B, C @ Q), (A[co, co], B[co], C[:, co])


def _markov(A, B, C, K):
    out, X = [], B
    for _ in range(K):
        out.append(C @ X)
        X = A @ X
    return np.array(out)


@pytest.mark.parametrize("sizes", [(3, 2, 2, 1), (4, 0, 0, 0), (2, 3, 0, 0), (1, 0, 3, 2),
                                   (0, 2, 2, 1)])
def test_minimal_part_of_a_kalman_decomposition(rng, sizes):
    (A, B, C), (Aco, Bco, Cco) = _kalman_decomposition(rng, sizes)
    Am, Bm, Cm, D = minimal_realization(A, B, C)
    assert Am.shape == (sizes[0],) * 2 and D.shape == (2, 2) and not D.any()
    np.testing.assert_allclose(np.sort_complex(np.linalg.eigvals(Am)),
                               np.sort_complex(np.linalg.eigvals(Aco)), atol=1e-10)
    K = 2 * A.shape[0]
    np.testing.assert_allclose(_markov(Am, Bm, Cm, K), _markov(Aco, Bco, Cco, K), atol=1e-10)
    np.testing.assert_allclose(_markov(Am, Bm, Cm, K), _markov(A, B, C, K), atol=1e-10)


def test_controllable_part_keeps_the_controllable_states(rng):
    sizes = (3, 2, 2, 1)
    (A, B, C), _ = _kalman_decomposition(rng, sizes)
    Ac, Bc, Cc = controllable_part(A, B, C)
    assert Ac.shape == (5, 5)
    ctrb = np.hstack([np.linalg.matrix_power(Ac, k) @ Bc for k in range(5)])
    assert np.linalg.matrix_rank(ctrb) == 5


def test_orthogonal_transformations_only(rng):
    """Staircase reductions are orthogonal: with nothing to remove, A_m is similar to A
    by an orthogonal matrix, so its singular values (not only its eigenvalues) are A's."""
    (A, B, C), _ = _kalman_decomposition(rng, (4, 0, 0, 0))
    Am, *_ = minimal_realization(A, B, C)
    np.testing.assert_allclose(np.linalg.svd(Am, compute_uv=False),
                               np.linalg.svd(A, compute_uv=False), rtol=1e-12)


def test_bad_input_names_the_argument():
    A, B, C = np.eye(2), np.ones((2, 1)), np.ones((1, 2))
    for args, name in [((np.ones((2, 3)), B, C), "A"), ((A, np.ones((3, 1)), C), "B"),
                       ((A, B, np.ones((1, 3))), "C"), ((A, B, C, np.ones((2, 2))), "D")]:
        with pytest.raises(ValueError, match=f"^{name} must"):
            minimal_realization(*args)
    with pytest.raises(ValueError, match="^tol must"):
        minimal_realization(A, B, C, tol=-1.0)


def test_state_space_model_minreal_keeps_the_noise_channel(rng):
    """A state reached only by the innovations stays; unreachable and unseen ones go."""
    from adaptid.models import StateSpaceModel

    A = np.diag([0.5, -0.3, 0.7, 0.2])
    A[0, 1] = 0.4
    B = np.array([[1.0], [0.0], [0.0], [0.5]])    # state 2: from e only; state 3: from nothing
    K = np.array([[0.1], [0.3], [0.0], [0.0]])
    C = np.array([[1.0, 1.0, 2.0, 0.0]])           # state 4: unseen
    Q = ortho_group.rvs(4, random_state=rng)
    m = StateSpaceModel(Q.T @ A @ Q, Q.T @ B, C @ Q, [[0.2]], Q.T @ K, noise_cov=[[0.01]],
                        dt=0.5, y_names="flow", u_names="valve")
    r = m.minreal()
    assert r.order == 2 and r.dt == 0.5 and r.y_names == ("flow",) and r.u_names == ("valve",)
    np.testing.assert_allclose(np.sort(np.linalg.eigvals(r.A).real), [-0.3, 0.5], atol=1e-12)
    np.testing.assert_allclose(r.markov(12), m.markov(12), atol=1e-12)
    np.testing.assert_allclose(_markov(r.A, r.K, r.C, 12), _markov(m.A, m.K, m.C, 12),
                               atol=1e-12)
    y, u = rng.standard_normal((80, 1)), rng.standard_normal((80, 1))
    np.testing.assert_allclose(r.predict(y, u, k=2), m.predict(y, u, k=2), atol=1e-12)
    assert StateSpaceModel(A[:1, :1], B[:1], C[:, :1]).minreal().order == 1


def test_slicot_tb01pd_published_example():
    """SLICOT-Reference examples/data/TB01PD.dat (N = 3, M = 1, P = 2, TOL = 0,
    JOB = 'M', EQUIL = 'N') and examples/results/TB01PD.res (printed to 4
    decimals): the system is already minimal (NR = 3). The printed realisation
    is in SLICOT's own basis, so basis-free quantities are compared."""
    A = np.array([[1.0, 2.0, 0.0], [4.0, -1.0, 0.0], [0.0, 0.0, 1.0]])
    B = np.array([[1.0], [0.0], [1.0]])
    C = np.array([[0.0, 1.0, -1.0], [0.0, 0.0, 1.0]])
    Ar = np.array([[1.0, -1.4142, 1.4142], [-2.8284, 0.0, 1.0], [2.8284, 1.0, 0.0]])
    Br = np.array([[-1.0], [0.7071], [0.7071]])
    Cr = np.array([[0.0, 0.0, -1.4142], [0.0, 0.7071, 0.7071]])
    Am, Bm, Cm, _ = minimal_realization(A, B, C)
    assert Am.shape == (3, 3)
    np.testing.assert_allclose(np.sort(np.linalg.eigvals(Am).real),
                               np.sort(np.linalg.eigvals(Ar).real), atol=1e-3)
    np.testing.assert_allclose(_markov(Am, Bm, Cm, 6), _markov(Ar, Br, Cr, 6), rtol=2e-3,
                               atol=2e-3)
    np.testing.assert_allclose(_markov(Am, Bm, Cm, 6), _markov(A, B, C, 6), atol=1e-12)
    # with a fourth state that the outputs do not see appended, it is removed
    A4 = np.zeros((4, 4))
    A4[:3, :3], A4[3, 3] = A, 0.5
    Am4, *_ = minimal_realization(A4, np.vstack([B, [[1.0]]]), np.hstack([C, np.zeros((2, 1))]))
    assert Am4.shape == (3, 3)
