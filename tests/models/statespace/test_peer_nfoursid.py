"""n4sid against the peer nfoursid (PO-MOESP, Verhaegen & Verdult 2007) on the same records.

The two realisations are compared up to a similarity transform: through
their eigenvalues and Markov parameters, which do not depend on the basis.
nfoursid builds the Hankel matrices explicitly and estimates B, D from its
state sequence, so on noise-free data both are exact to rounding; with
noise both are consistent and agree to within their sampling error.
"""

import numpy as np
import pytest

from adaptid.models import n4sid

from ._systems import innovation_record, noise_free, random_system, sorted_poles

nfoursid = pytest.importorskip("nfoursid.nfoursid")
pd = pytest.importorskip("pandas")


def _peer(y, u, horizon, order):
    cols_y = [f"y{i}" for i in range(y.shape[1])]
    cols_u = [f"u{i}" for i in range(u.shape[1])]
    df = pd.DataFrame(np.hstack([y, u]), columns=cols_y + cols_u)
    nf = nfoursid.NFourSID(df, output_columns=cols_y, input_columns=cols_u,
                           num_block_rows=horizon)
    nf.subspace_identification()
    ss, _ = nf.system_identification(rank=order)
    return ss


def _markov(a, b, c, d, count):
    out = [d]
    M = c.copy()
    for _ in range(count - 1):
        out.append(M @ b)
        M = M @ a
    return np.array(out)


def test_noise_free_same_system_as_nfoursid():
    true = random_system(seed=1, n=4, m=2, p=2)
    y, u = noise_free(true, N=1000)
    peer = _peer(y, u, 10, 4)
    ours = n4sid((y, u), 4, horizon=10, feedthrough=True)
    peer_poles = np.sort_complex(np.round(np.linalg.eigvals(peer.a), 12))
    # both exact to rounding (differences seen ~1e-13); the tolerance
    np.testing.assert_allclose(sorted_poles(ours), peer_poles, atol=1e-8)
    np.testing.assert_allclose(ours.markov(20), _markov(peer.a, peer.b, peer.c, peer.d, 20),
                               atol=1e-8)


def test_noisy_record_agrees_with_nfoursid_within_sampling_error():
    y, u = innovation_record(5000, seed=4)
    peer = _peer(y, u, 10, 2)
    ours = n4sid((y, u), 2, horizon=10)
    peer_poles = np.sort_complex(np.linalg.eigvals(peer.a))
    # same data, same horizon, both MOESP-weighted: they differ by far less than their
    # sampling error (~0.003 for the poles at N = 5000); seen 1e-4 (poles), 3e-3 (Markov)
    np.testing.assert_allclose(sorted_poles(ours), peer_poles, atol=2e-3)
    np.testing.assert_allclose(ours.markov(10)[1:], _markov(peer.a, peer.b, peer.c, peer.d,
                                                            10)[1:], atol=0.02)
