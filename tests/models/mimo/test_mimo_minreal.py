"""Minimal realisation of MIMO ARX models and the cancelled transfer function.

Oracles the code under test did not produce: the McMillan degree as the
rank (by SVD, here) of the block Hankel matrix of Markov parameters
computed from the lagged-signal form (minimal=False) by matrix powers; impulse responses by
the model's own simulation and by scipy's ``lfilter``; the transfer
function entries of a 2×2 model as the polynomials of adj(A)B / det A
written out by hand, with the cancellation done on paper; python-control's
transfer-function ``minreal`` (root cancellation); scipy's ``ss2tf``; and
python-control's state-space ``minreal`` when slycot is installed.
"""

import numpy as np
import pytest
from scipy import signal

from adaptid.models import ARX


def _model(na, nb, nk, coeffs, ny, nu, seed=0):
    """A MIMO ARX of these orders with the named coefficients (others zero)."""
    rng = np.random.default_rng(seed)
    m = ARX(np.array(na), np.array(nb), np.array(nk)).fit(
        rng.standard_normal((200, ny)), rng.standard_normal((200, nu)))
    unknown = set(coeffs) - set(m.names)
    assert not unknown, unknown
    m.theta = np.array([coeffs.get(n, 0.0) for n in m.names])
    return m


def _random_model(na, nb, nk, ny, nu, seed):
    m = _model(na, nb, nk, {}, ny, nu, seed)
    rng = np.random.default_rng(seed + 100)
    m.theta = 0.3 * rng.standard_normal(m.theta.size)
    return m


def _markov(F, G, H, D, K):
    """D, HG, HFG, ..., HF^(K-2)G by plain matrix powers."""
    out = [D]
    for k in range(1, K):
        out.append(H @ np.linalg.matrix_power(F, k - 1) @ G)
    return np.array(out)


def _mcmillan(markov, rtol=1e-9):
    """Rank of the block Hankel matrix [h_(i+j+1)] of Markov parameters, by SVD."""
    K = (len(markov) - 1) // 2
    Hk = np.block([[markov[i + j + 1] for j in range(K)] for i in range(K)])
    s = np.linalg.svd(Hk, compute_uv=False)
    return int(np.sum(s > rtol * s[0])) if s.size and s[0] > 0 else 0


def _impulses(m, K):
    """Impulse responses (K, ny, nu) by the model's simulation, one input at a time."""
    nu = m.n_inputs
    out = np.empty((K, m.n_outputs, nu))
    for j in range(nu):
        U = np.zeros((K, nu))
        U[0, j] = 1.0
        out[:, :, j] = m.simulate(U)
    return out


def _check_minimal(m, expected_order, tol=None):
    full = m.realization(minimal=False)
    Fm, Gm, Hm, Dm = m.realization(tol=tol)
    K = 2 * full[0].shape[0] + 4
    h_full = _markov(*full, K)
    assert Fm.shape[0] == expected_order
    assert _mcmillan(h_full) == expected_order
    np.testing.assert_allclose(_markov(Fm, Gm, Hm, Dm, K), h_full, atol=1e-10)
    np.testing.assert_allclose(_markov(Fm, Gm, Hm, Dm, K), _impulses(m, K), atol=1e-10)
    # the reduced system is controllable and observable (full-rank Kalman matrices)
    if expected_order:
        ctrb = np.hstack([np.linalg.matrix_power(Fm, k) @ Gm for k in range(expected_order)])
        obsv = np.vstack([Hm @ np.linalg.matrix_power(Fm, k) for k in range(expected_order)])
        assert np.linalg.matrix_rank(ctrb) == expected_order
        assert np.linalg.matrix_rank(obsv) == expected_order
    return full, (Fm, Gm, Hm, Dm)


@pytest.mark.parametrize("na, nb, nk", [(2, 2, 3), (3, 1, 1), (1, 3, 0), (2, 3, 1)])
def test_siso_order_is_max_of_na_and_nb_plus_nk_minus_one(na, nb, nk):
    m = _random_model([[na]], [[nb]], [[nk]], 1, 1, seed=na + 3 * nb + 7 * nk)
    full, _ = _check_minimal(m, max(na, nb + nk - 1))
    assert full[0].shape[0] == na + nb + nk - 1  # the lagged-signal form's 1*La + 1*(Lb - 1)
    # impulse response of the SISO model by scipy's lfilter (A, B in powers of q^-1)
    a = np.r_[1.0, m.theta[:na]]
    b = np.r_[np.zeros(nk), m.theta[na:]]
    imp = signal.lfilter(b, a, np.r_[1.0, np.zeros(29)])
    Fm, Gm, Hm, Dm = m.realization()
    np.testing.assert_allclose(_markov(Fm, Gm, Hm, Dm, 30)[:, 0, 0], imp, atol=1e-10)


def test_decoupled_mimo_needs_fewer_states_than_the_lagged_signal_form():
    # y1: (1 - 0.9q^-1 + 0.2q^-2) y1 = 1.0 u1(k-1); y2: (1 - 0.5q^-1) y2 = (2u2(k-1) + 0.7u2(k-2))
    coeffs = {"a1_y1_y1": -0.9, "a2_y1_y1": 0.2, "b0_y1_u1": 1.0,
              "a1_y2_y2": -0.5, "b0_y2_u2": 2.0, "b1_y2_u2": 0.7}
    m = _model([[2, 0], [0, 1]], [[1, 0], [0, 2]], 1, coeffs, 2, 2)
    full, (Fm, *_) = _check_minimal(m, 4)       # 2 (y1) + 2 (y2: pole 0.5 and the delay)
    assert full[0].shape[0] == 2 * 2 + 2 * 2
    np.testing.assert_allclose(np.sort(np.linalg.eigvals(Fm).real), [0.0, 0.4, 0.5, 0.5],
                               atol=1e-7)


def test_exact_pole_zero_cancellation_is_removed():
    # (1 - 0.5q^-1)(1 - 0.8q^-1) y = q^-1 (1 - 0.5q^-1) u  ->  y = q^-1/(1 - 0.8q^-1) u
    m = _model([[2]], [[2]], [[1]], {"a1_y_y": -1.3, "a2_y_y": 0.4,
                                     "b0_y_u": 1.0, "b1_y_u": -0.5}, 1, 1)
    _, (Fm, Gm, Hm, Dm) = _check_minimal(m, 1)
    np.testing.assert_allclose(Fm, [[0.8]], atol=1e-12)
    np.testing.assert_allclose(Hm @ Gm, [[1.0]], atol=1e-12)


def test_common_scalar_factor_of_a_mimo_model():
    # A(q) = (1 - 0.5q^-1) I, B(q) = (1 - 0.5q^-1) q^-1 B1 with B1 of rank one: G = q^-1 B1
    B1 = np.array([[1.0, 2.0], [2.0, 4.0]])
    coeffs = {"a1_y1_y1": -0.5, "a1_y2_y2": -0.5}
    for i in range(2):
        for j in range(2):
            coeffs[f"b0_y{i + 1}_u{j + 1}"] = B1[i, j]
            coeffs[f"b1_y{i + 1}_u{j + 1}"] = -0.5 * B1[i, j]
    m = _model([[1, 0], [0, 1]], 2, 1, coeffs, 2, 2)
    full, (Fm, Gm, Hm, Dm) = _check_minimal(m, 1)
    assert full[0].shape[0] == 6
    np.testing.assert_allclose(Fm, [[0.0]], atol=1e-12)
    np.testing.assert_allclose(Hm @ Gm, B1, atol=1e-12)


def test_near_cancellation_of_an_estimate_needs_a_tolerance():
    """Almost noise-free data of the cancelling system: the estimate nearly cancels."""
    rng = np.random.default_rng(5)
    u = rng.standard_normal(2000)
    y = signal.lfilter([0.0, 1.0, -0.5], [1.0, -1.3, 0.4], u) + 1e-7 * rng.standard_normal(2000)
    m = ARX(np.array([[2]]), np.array([[2]]), np.array([[1]])).fit(y[:, None], u[:, None])
    # the common factor is not identifiable: the estimate has *some* nearly common root
    a_roots, b_root = np.roots(np.r_[1.0, m.theta[:2]]), -m.theta[3] / m.theta[2]
    assert np.abs(a_roots - b_root).min() < 1e-4
    assert m.realization()[0].shape == (2, 2)     # exact cancellations only by default
    Fm, Gm, Hm, Dm = m.realization(tol=1e-3)
    assert Fm.shape == (1, 1) and Fm[0, 0] == pytest.approx(0.8, abs=1e-4)
    h = _impulses(m, 40)[:, 0, 0]
    np.testing.assert_allclose(_markov(Fm, Gm, Hm, Dm, 40)[:, 0, 0], h, atol=1e-4)


# ---------------------------------------------------------------- transfer function
# A(q) = [[A11, 0], [A21, A22]], B(q) = [[B11, B12], [0, B22]] (coefficients in powers of q^-1)
A11, A22, A21 = [1.0, -0.2, -0.15], [1.0, -1.4, 0.53], [0.0, 0.4]
B11, B12, B22 = [0.0, 1.0, 0.6], [0.0, 0.5, -0.2], [0.0, 2.0, 0.3]


def _triangular():
    c = {"a1_y1_y1": A11[1], "a2_y1_y1": A11[2], "a1_y2_y1": A21[1],
         "a1_y2_y2": A22[1], "a2_y2_y2": A22[2],
         "b0_y1_u1": B11[1], "b1_y1_u1": B11[2], "b0_y1_u2": B12[1], "b1_y1_u2": B12[2],
         "b0_y2_u2": B22[1], "b1_y2_u2": B22[2]}
    return _model([[2, 0], [1, 2]], [[2, 2], [0, 2]], 1, c, 2, 2)


def _entries_by_hand():
    """G = adj(A)B / det A with det A = A11 A22, adj A = [[A22, 0], [-A21, A11]];
    A22 cancels in the first row: G11 = B11/A11, G12 = B12/A11 (no cancellation
    in the second row for these numbers)."""
    pm, ps = np.polynomial.polynomial.polymul, np.polynomial.polynomial.polysub
    det = pm(A11, A22)
    return {(0, 0): (B11, A11), (0, 1): (B12, A11),
            (1, 0): (-pm(A21, B11), det),
            (1, 1): (ps(pm(A11, B22), pm(A21, B12)), det)}


def _roots_in_z(num_q, den_q):
    """Zeros and poles in z of num(q^-1)/den(q^-1): pad to one length, read as powers of z."""
    L = max(len(num_q), len(den_q))
    n, d = np.zeros(L), np.zeros(L)
    n[:len(num_q)], d[:len(den_q)] = num_q, den_q
    return np.sort_complex(np.roots(n)), np.sort_complex(np.roots(d))


def test_tf_entries_have_the_poles_and_zeros_of_the_cancelled_entries():
    control = pytest.importorskip("control")
    m = _triangular()
    tf = m.to_control("tf")
    for (i, j), (num_q, den_q) in _entries_by_hand().items():
        zeros, poles = _roots_in_z(num_q, den_q)
        got_z = np.sort_complex(np.roots(tf.num[i][j]))
        got_p = np.sort_complex(np.roots(tf.den[i][j]))
        assert got_p.size == poles.size and got_z.size == zeros.size, (i, j)
        np.testing.assert_allclose(got_p, poles, atol=1e-8)
        np.testing.assert_allclose(got_z, zeros, atol=1e-8)
    assert [len(tf.den[i][j]) - 1 for i in range(2) for j in range(2)] == [2, 2, 4, 4]
    # python-control's transfer-function minreal (root cancellation) of the
    # uncancelled entries leaves the same nonzero poles (rounding splits the
    # multiple poles and zeros at the origin, which it then keeps), and the
    # frequency response is the same
    full = m.to_control("tf", minimal=False)
    assert all(len(full.den[i][j]) - 1 == 8 for i in range(2) for j in range(2))
    z = np.exp(1j * np.array([0.1, 0.9, 2.5]))
    for i in range(2):
        for j in range(2):
            red = control.tf(full.num[i][j], full.den[i][j], 1.0).minreal(tol=1e-6)
            p = np.roots(red.den[0][0])
            np.testing.assert_allclose(np.sort_complex(p[np.abs(p) > 1e-2]),
                                       np.sort_complex(np.roots(tf.den[i][j])), atol=1e-6)
            np.testing.assert_allclose(tf[i, j](z), full[i, j](z), rtol=1e-9)


def test_tf_entries_equal_scipy_ss2tf_of_the_lagged_signal_form():
    pytest.importorskip("control")
    m = _triangular()
    tf = m.to_control("tf")
    F, G, H, D = m.realization(minimal=False)
    for j in range(2):
        nums, den = signal.ss2tf(F, G, H, D, input=j)
        for i in range(2):
            # the same rational function: num_full * den_ours == num_ours * den_full
            lhs = np.polymul(nums[i], tf.den[i][j])
            rhs = np.polymul(tf.num[i][j], den)
            L = max(lhs.size, rhs.size)
            lhs, rhs = np.pad(lhs, (L - lhs.size, 0)), np.pad(rhs, (L - rhs.size, 0))
            np.testing.assert_allclose(lhs, rhs, atol=1e-10)
    # and a tf2ss round trip of an entry has the entry's impulse response
    a, b, c, d = signal.tf2ss(tf.num[1][1], tf.den[1][1])
    np.testing.assert_allclose(_markov(a, b, c, d, 20)[:, 0, 0], _impulses(m, 20)[:, 1, 1],
                               atol=1e-10)


def test_cancelled_tf_has_no_common_pole_zero_pair():
    pytest.importorskip("control")
    m = _model([[2]], [[2]], [[1]], {"a1_y_y": -1.3, "a2_y_y": 0.4,
                                     "b0_y_u": 1.0, "b1_y_u": -0.5}, 1, 1)
    tf = m.to_control("tf")
    np.testing.assert_allclose(np.roots(tf.den[0][0]), [0.8], atol=1e-12)
    assert np.roots(tf.num[0][0]).size == 0
    assert len(m.to_control("tf", minimal=False).den[0][0]) - 1 == 4  # 2 + (3 - 1) states


def test_state_space_forms_and_simulation():
    control = pytest.importorskip("control")
    m = _triangular()
    _check_minimal(m, 4)        # det A has degree 4 and A, B are left coprime
    ss, ss_full = m.to_control("ss"), m.to_control("ss", minimal=False)
    assert ss.nstates == 4 and ss_full.nstates == 8
    assert list(ss.input_labels) == ["u1", "u2"] and ss.dt == m.dt
    U = np.random.default_rng(2).standard_normal((60, 2))
    out = control.forced_response(ss, U=U.T).outputs.T
    np.testing.assert_allclose(out, m.simulate(U), atol=1e-10)


def test_against_python_control_minreal_with_slycot():
    control = pytest.importorskip("control")
    pytest.importorskip("slycot")
    m = _triangular()
    ref = control.minreal(control.ss(*m.realization(minimal=False), 1.0), verbose=False)
    assert ref.nstates == m.realization()[0].shape[0]


def test_bad_arguments_name_the_argument():
    m = _triangular()
    with pytest.raises(ValueError, match="tol"):
        m.realization(tol=-1.0)
    with pytest.raises(ValueError, match="form"):
        m.to_control("zpk")
