"""n4sid on Dask data (issue 34, point 3): the R factor of the block-Hankel
matrix by Dask's tall-skinny QR over chunks with an overlap of 2·horizon − 1
samples equals the in-memory estimate on the same record (the oracle: the
in-memory n4sid, itself tested against SLICOT and nfoursid), compared by
quantities a similarity transform does not change."""

import numpy as np
import pandas as pd
import pytest

da = pytest.importorskip("dask.array")
dd = pytest.importorskip("dask.dataframe")

from adaptid.models import StateSpaceModel, n4sid  # noqa: E402


def _record(N=3000, seed=0):
    rng = np.random.default_rng(seed)
    A = np.array([[0.9, 0.2, 0.0], [0.0, 0.5, 0.1], [0.0, 0.0, -0.4]])
    true = StateSpaceModel(A, rng.standard_normal((3, 2)), rng.standard_normal((2, 3)))
    u = rng.standard_normal((N, 2))
    return true.simulate(u) + 0.05 * rng.standard_normal((N, 2)), u


def _invariants(m):
    markov = [m.C @ np.linalg.matrix_power(m.A, k) @ np.hstack([m.B, m.K]) for k in range(6)]
    return (m.singular_values / m.singular_values[0], np.sort_complex(m.poles()),
            np.stack(markov), m.D, m.noise_cov)


@pytest.mark.parametrize("method", ["moesp", "n4sid", "cva"])
@pytest.mark.parametrize("chunk", [333, 1000])
def test_dask_equals_in_memory(method, chunk):
    y, u = _record()
    ref = n4sid((y, u), 3, horizon=6, method=method, feedthrough=True)
    got = n4sid((da.from_array(y, chunks=(chunk, 2)), da.from_array(u, chunks=(chunk, 1))), 3,
                horizon=6, method=method, feedthrough=True)
    # 1e-8: the two QRs reduce the same rows in another order (rounding only)
    for a, b in zip(_invariants(ref), _invariants(got)):
        np.testing.assert_allclose(b, a, rtol=1e-8, atol=1e-10)
    assert got.info["samples"] == 3000 and got._fit_data is None


def test_dask_dataframe_and_pairs_of_frames():
    y, u = _record(2000, 1)
    df = pd.DataFrame({"out1": y[:, 0], "out2": y[:, 1], "in1": u[:, 0], "in2": u[:, 1]})
    ddf = dd.from_pandas(df, npartitions=3)
    ref = n4sid((y, u), 3, horizon=5)
    got = n4sid((ddf[["out1", "out2"]], ddf[["in1", "in2"]]), 3, horizon=5)
    np.testing.assert_allclose(np.sort_complex(got.poles()), np.sort_complex(ref.poles()),
                               rtol=1e-8, atol=1e-10)
    assert got.y_names == ("out1", "out2") and got.u_names == ("in1", "in2")
    # one DataFrame: the first column is the output, the others the inputs
    one = n4sid(ddf[["out1", "in1", "in2"]], 3, horizon=5)
    mem = n4sid((y[:, :1], u), 3, horizon=5)
    np.testing.assert_allclose(np.sort_complex(one.poles()), np.sort_complex(mem.poles()),
                               rtol=1e-8, atol=1e-10)


def test_dask_refusals():
    y, u = _record(1500, 2)
    y[700, 0] = np.nan
    with pytest.raises(ValueError, match="data must be finite on Dask"):
        n4sid((da.from_array(y, chunks=500), da.from_array(u, chunks=500)), 3, horizon=5)
    with pytest.raises(ValueError, match="order must be an integer or None for Dask"):
        n4sid((da.from_array(u, chunks=500), da.from_array(u, chunks=500)), range(1, 4),
              horizon=5)
