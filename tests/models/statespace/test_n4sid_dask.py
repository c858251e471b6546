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

from adaptid import IDData  # noqa: E402
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


def _free_responses(m):
    """C Aᵏ x0 of each experiment's initial state (similarity invariant)."""
    return np.stack([[m.C @ np.linalg.matrix_power(m.A, k) @ x0 for k in range(5)]
                     for x0 in m.info["x0"]])


def _assert_same(got, ref):
    # 1e-8: the TSQR reduces the same Hankel rows as the in-memory QR in another order
    for a, b in zip(_invariants(ref), _invariants(got)):
        np.testing.assert_allclose(b, a, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(got.singular_values, ref.singular_values, rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(_free_responses(got), _free_responses(ref), rtol=1e-8, atol=1e-9)
    for key in ("samples", "experiments", "horizon", "method", "order rule", "feedthrough"):
        assert got.info.get(key) == ref.info.get(key), key
    assert got.order == ref.order and got.dt == ref.dt
    assert got.y_names == ref.y_names and got.u_names == ref.u_names


def _pieces(lengths, seed):
    y, u = _record(sum(lengths), seed)
    cuts = np.cumsum([0, *lengths])
    return [(y[a:b], u[a:b]) for a, b in zip(cuts[:-1], cuts[1:])]


@pytest.mark.parametrize("chunk", [7, 250, 1000])
def test_dask_experiments_equal_in_memory(chunk):
    # three experiments of different lengths; chunks of 7 rows are shorter than the
    # overlap 2·horizon − 1 = 11, and no experiment's end falls on a chunk's end
    exps = _pieces([1203, 871, 1510], 3)
    ref = n4sid(exps, 3, horizon=6, method="n4sid", feedthrough=True)
    got = n4sid([(da.from_array(y, chunks=(chunk, 2)), da.from_array(u, chunks=(chunk, 2)))
                 for y, u in exps], 3, horizon=6, method="n4sid", feedthrough=True)
    assert ref.info["experiments"] == 3 and ref.info["samples"] == 1203 + 871 + 1510
    _assert_same(got, ref)


def test_dask_gaps_split_runs_as_in_memory():
    # one record with NaN gaps inside chunks (runs 0–611, 613–1399, 1400–1409, 1420–2399):
    # the 10-sample run is shorter than 2·horizon and left out, as in memory
    y, u = _record(2400, 4)
    y[612, 0] = np.nan
    u[1399, 1] = np.nan
    y[1410:1420] = np.nan
    ref = n4sid((y, u), 3, horizon=6, method="cva")
    got = n4sid((da.from_array(y, chunks=(500, 2)), da.from_array(u, chunks=(300, 2))), 3,
                horizon=6, method="cva")
    assert ref.info["experiments"] == 3 and ref.info["samples"] == 2400 - 12 - 10
    _assert_same(got, ref)
    # a list of experiments, one of them with a gap, the first a Dask DataFrame
    y2, u2 = _record(900, 5)
    y2[450, 0] = np.nan
    df = pd.DataFrame(np.hstack([y2[:, :1], u2]), columns=["y", "u1", "u2"])
    ref = n4sid([(y2[:, :1], u2), (y[:600, :1], u[:600])], 2, horizon=5)
    got = n4sid([dd.from_pandas(df, npartitions=4),
                 (da.from_array(y[:600, :1], chunks=64), da.from_array(u[:600], chunks=64))],
                2, horizon=5)
    assert ref.info["experiments"] == 3
    _assert_same(got, ref)


@pytest.mark.parametrize("method", ["moesp", "cva"])
def test_dask_order_choice_equals_in_memory(method):
    exps = _pieces([1400, 1100], 6)
    dexps = [(da.from_array(y, chunks=333), da.from_array(u, chunks=333)) for y, u in exps]
    # order=None: the largest drop of the same singular values
    ref = n4sid(exps, None, horizon=6, method=method)
    got = n4sid(dexps, None, horizon=6, method=method)
    assert ref.order == 3
    _assert_same(got, ref)
    # a range: AIC of the one-step prediction errors (the predictor run chunk by chunk)
    ref = n4sid(exps, range(1, 6), horizon=6, method=method)
    got = n4sid(dexps, range(1, 6), horizon=6, method=method)
    assert got.info["criterion"] == ref.info["criterion"]
    assert list(got.info["aic"]) == list(ref.info["aic"]) == [1, 2, 3, 4, 5]
    np.testing.assert_allclose(list(got.info["aic"].values()), list(ref.info["aic"].values()),
                               rtol=1e-8)
    _assert_same(got, ref)


def test_dask_dt_and_names_from_a_time_index():
    # IDData reads dt and the names from a pandas time index; a Dask DataFrame of the
    # same frame gives the same (its index read chunk by chunk)
    exps = _pieces([1300, 1000], 7)
    frames = []
    for k, (y, u) in enumerate(exps):
        t = pd.date_range(f"2026-0{k + 1}-01", periods=len(y), freq="50ms", tz="Europe/Paris")
        frames.append(pd.DataFrame({"speed": y[:, 0], "torque": y[:, 1], "v1": u[:, 0],
                                    "v2": u[:, 1]}, index=t))
    mem = IDData(frames[0][["speed", "torque"]], frames[0][["v1", "v2"]]).merge(
        IDData(frames[1][["speed", "torque"]], frames[1][["v1", "v2"]]))
    assert mem.dt == 0.05
    ref = n4sid(mem, 3, horizon=6)
    dfs = [dd.from_pandas(f, npartitions=3) for f in frames]
    got = n4sid([(d[["speed", "torque"]], d[["v1", "v2"]]) for d in dfs], 3, horizon=6)
    assert got.dt == 0.05 and got.y_names == ("speed", "torque")
    _assert_same(got, ref)
    # seconds as numbers, without a frequency: dt is the mean step, as in memory
    y, u = exps[0]
    t = 2.0 + 0.125 * np.arange(len(y))
    pdf = pd.DataFrame({"y": y[:, 0], "u1": u[:, 0], "u2": u[:, 1]}, index=t)
    ref = n4sid(IDData(pdf[["y"]], pdf[["u1", "u2"]]), 2, horizon=5)
    got = n4sid(dd.from_pandas(pdf, npartitions=5), 2, horizon=5)
    assert ref.dt == got.dt == 0.125
    _assert_same(got, ref)


def test_dask_list_with_an_iddata():
    # an IDData in a list of Dask records is one experiment of it; its dt is the first
    exps = _pieces([900, 1100], 9)
    first = IDData(exps[0][0], exps[0][1], 0.5, y_names=["a", "b"], u_names=["p", "q"])
    ref = n4sid([first, exps[1]], 3, horizon=6, method="cva")
    got = n4sid([first, (da.from_array(exps[1][0], chunks=150),
                         da.from_array(exps[1][1], chunks=150))], 3, horizon=6, method="cva")
    assert ref.dt == 0.5 and ref.y_names == ("a", "b")
    _assert_same(got, ref)


def test_dask_refusals():
    y, u = _record(1500, 2)
    y[700, 0] = np.inf
    with pytest.raises(ValueError, match="data must be finite or NaN"):
        n4sid((da.from_array(y, chunks=500), da.from_array(u, chunks=500)), 3, horizon=5)
    y[700, 0] = np.nan
    with pytest.raises(ValueError, match=r"data\[1\] must be a record with complete samples"):
        n4sid([(da.from_array(y, chunks=500), da.from_array(u, chunks=500)),
               (da.from_array(np.full((50, 2), np.nan)), da.from_array(u[:50]))], 3, horizon=5)
    with pytest.raises(ValueError, match=r"data\[1\] must be 2 output\(s\) and 2 input"):
        n4sid([(da.from_array(y, chunks=500), da.from_array(u, chunks=500)),
               (da.from_array(y[:, :1]), da.from_array(u))], 3, horizon=5)
    t = np.cumsum(np.r_[1.0, np.ones(699), 3.0, np.ones(799)])      # one step of 3 s
    pdf = pd.DataFrame({"y": y[:, 1], "u1": u[:, 0], "u2": u[:, 1]}, index=t)
    with pytest.raises(ValueError, match="index of y.* must be a regular time axis for Dask"):
        n4sid(dd.from_pandas(pdf, npartitions=3), 2, horizon=5)


def test_dask_covariance_and_summary_equal_in_memory():
    # the parameter covariance (two chunked passes: errors, then sensitivities) and the
    # bands derived from it; the summary's fit % (one chunked pass) on one experiment
    exps = _pieces([1300, 700], 8)
    dexps = [(da.from_array(y, chunks=(256, 2)), da.from_array(u, chunks=(100, 2)))
             for y, u in exps]
    ref = n4sid(exps, 3, horizon=6, feedthrough=True)
    got = n4sid(dexps, 3, horizon=6, feedthrough=True)
    # 1e-8 as above: the sums and QR reductions of the same rows are taken chunk by chunk
    w = np.array([0.1, 0.7, 2.0])
    fr, fg = ref.freqresp(w), got.freqresp(w)
    np.testing.assert_allclose(fg.magnitude_sd, fr.magnitude_sd, rtol=1e-8)
    np.testing.assert_allclose(fg.phase_sd, fr.phase_sd, rtol=1e-8)
    assert np.all(fr.magnitude_sd > 0)
    np.testing.assert_allclose(got.step_response(15).sd, ref.step_response(15).sd, rtol=1e-8)
    one_ref = n4sid(exps[0], 3, horizon=6)
    one = n4sid(dexps[0], 3, horizon=6)
    assert one._fit_data is None
    s_ref, s_got = one_ref.summary().stats, one.summary().stats
    fits = [k for k in s_ref if k.startswith("fit %")]
    assert len(fits) == 4 and [k for k in s_got if k.startswith("fit %")] == fits
    np.testing.assert_allclose([s_got[k] for k in fits], [s_ref[k] for k in fits], rtol=1e-9)
    np.testing.assert_allclose(one.cov.diagonal().sum(), one_ref.cov.diagonal().sum(), rtol=1e-8)
