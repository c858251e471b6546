"""adaptid.fleet.fit_models: model objects per device on Dask.

Oracles written here: a Python loop over the devices calling the model
objects' own ``fit`` (batch) and the streaming objects' ``run`` (step by
step equals run bit for bit, tested in tests/models/), with the rows of each
device sorted by pandas; the Brown-Durbin-Evans crossing statistic of the
a-priori errors computed in NumPy.
"""

import copy

import numpy as np
import pandas as pd
import pytest

import adaptid
from adaptid import IDData, fleet, models

N = 240


def _device(rng, b, n=N, jump=None):
    u = rng.standard_normal(n)
    e = 0.1 * rng.standard_normal(n)
    bb = np.full(n, b)
    if jump is not None:
        bb[n // 2:] = jump
    y = np.empty(n)
    y[0] = e[0]
    for k in range(1, n):  # y_k = 0.6 y_{k-1} + b_k u_{k-1} + e_k + 0.3 e_{k-1}: ARMAX(1,1,1,1)
        y[k] = 0.6 * y[k - 1] + bb[k] * u[k - 1] + e[k] + 0.3 * e[k - 1]
    return u, y


def _fleet_frame(keys, seed=3, jump_at=None):
    rng = np.random.default_rng(seed)
    frames = []
    for i, key in enumerate(keys):
        u, y = _device(rng, 0.5 + 0.2 * i, jump=1.8 if key == jump_at else None)
        frames.append(pd.DataFrame({"device": key, "k": np.arange(N), "u": u, "y": y}))
    return pd.concat(frames, ignore_index=True).sample(frac=1.0, random_state=2)


def _parts(df):
    """Each device's rows in time order, by pandas (the oracle's sort)."""
    for key, part in sorted(df.groupby("device"), key=lambda kv: kv[0]):
        part = part.sort_values("k", kind="stable")
        yield key, part.y.to_numpy(), part.u.to_numpy()


def _python_batch(df, make, *, time_series=False):
    """The loop a user writes: one model object's fit per device."""
    rows, keys = [], []
    for key, y, u in _parts(df):
        m = make()
        m.fit(y if time_series else IDData(y, u, y_names="y", u_names="u"))
        res = np.asarray(m.residuals)
        row = dict(zip(m.names, m.theta))
        row.update({f"stderr_{n}": s for n, s in zip(m.names, m.stderr)})
        row.update(n_samples=res.size, n_skipped=0, sigma2=m.noise_variance,
                   rms=np.sqrt(np.mean(res ** 2)))
        rows.append(row)
        keys.append(key)
    return pd.DataFrame(rows, index=pd.Index(keys, name="device"))


def _check_same(got, want, rtol=1e-9):
    assert list(got.columns) == list(want.columns)
    assert list(got.index) == list(want.index)
    for c in want.columns:
        np.testing.assert_allclose(got[c].to_numpy(dtype=float), want[c].to_numpy(dtype=float),
                                   rtol=rtol, atol=1e-12, err_msg=c)


def _parquet_folder(df, path, n_files=2):
    """The fleet as a folder of Parquet files, devices split across them (dask shuffles)."""
    path.mkdir()
    for i, chunk in enumerate(np.array_split(np.arange(len(df)), n_files)):
        df.iloc[chunk].to_parquet(path / f"part{i}.parquet", index=False)
    return str(path)


def test_arx_batch_pandas_string_keys_equals_python_loop():
    df = _fleet_frame(["pump-b", "pump-a", "pump-c", "pump-d"])
    got = fleet.fit_models(df, models.ARX(1, 1, 1), group="device", y="y", u="u", time="k",
                           npartitions=3)
    _check_same(got, _python_batch(df, lambda: models.ARX(1, 1, 1)))
    assert got["n_samples"].dtype.kind == "i" and (got["n_skipped"] == 0).all()


def test_arx_batch_dask_frame_int_keys_equals_python_loop():
    import dask.dataframe as dd

    df = _fleet_frame([7, 3, 11, 5, 1])
    ddf = dd.from_pandas(df, npartitions=3)
    got = fleet.fit_models(ddf, models.ARX(2, 2, 1), group="device", y="y", u="u", time="k",
                           npartitions=2)
    _check_same(got, _python_batch(df, lambda: models.ARX(2, 2, 1)))
    assert list(got.index) == [1, 3, 5, 7, 11]


def test_armax_batch_parquet_int_keys_equals_python_loop(tmp_path):
    df = _fleet_frame([40, 10, 30, 20])
    path = _parquet_folder(df, tmp_path / "fleet")
    got = fleet.fit_models(path, models.ARMAX(1, 1, 1, 1), group="device", y="y", u="u",
                           time="k", npartitions=2)
    _check_same(got, _python_batch(df, lambda: models.ARMAX(1, 1, 1, 1)), rtol=1e-7)
    np.testing.assert_allclose(got[["a1", "b0", "c1"]].mean(), [-0.6, 0.8, 0.3], atol=0.1)


def test_oe_and_arma_batch_pandas_string_keys():
    df = _fleet_frame(["b", "a", "c"])
    got = fleet.fit_models(df, models.OE(1, 1, 1), group="device", y="y", u="u", time="k",
                           npartitions=2)
    _check_same(got, _python_batch(df, lambda: models.OE(1, 1, 1)), rtol=1e-7)
    got = fleet.fit_models(df, models.ARMA(1, 1), group="device", y="y", time="k",
                           npartitions=2)
    _check_same(got, _python_batch(df, lambda: models.ARMA(1, 1), time_series=True), rtol=1e-7)


def _python_stream(df, proto):
    """Per device: a copy of the streaming object run over the record in Python."""
    out = {}
    for key, y, u in _parts(df):
        obj = copy.deepcopy(proto)
        res = obj.run(IDData(y, u))
        out[key] = (res, y, u)
    return out


def test_streaming_armax_equals_stream_run_per_device(tmp_path):
    df = _fleet_frame(["d2", "d0", "d1", "d3"], jump_at="d1")
    proto = models.RecursiveARMAX(1, 1, 1, 1, forgetting=0.999, start="filled")
    tracks = tmp_path / "tracks"
    got = fleet.fit_models(df, proto, group="device", y="y", u="u", time="k", npartitions=3,
                           tracks=str(tracks))
    assert proto.n_updates == 0   # the prototype is copied, never run
    ref = _python_stream(df, proto)
    names = ["a1", "b0", "c1"]
    assert list(got.columns) == names + [f"stderr_{n}" for n in names] + [
        "n_samples", "n_skipped", "sigma2", "rms", "change", "change_stat", "change_pvalue",
        "change_at"]
    back = pd.read_parquet(tracks)
    for key, (res, y, u) in ref.items():
        np.testing.assert_allclose(got.loc[key, names].to_numpy(float), res.theta[-1],
                                   rtol=1e-12)
        assert got.loc[key, "n_samples"] == N - 1   # start="filled": no update at sample 0
        # the statistics are those of fit_recursive with the same estimator (the model
        # `adaptid fit --armax ... --method rls --forgetting 0.999` reports)
        m = models.ARMAX(1, 1, 1, 1)
        m.fit_recursive(IDData(y, u), estimator=adaptid.RLS(3, forgetting=0.999))
        np.testing.assert_allclose(got.loc[key, [f"stderr_{n}" for n in names]].to_numpy(float),
                                   m.stderr, rtol=1e-9)
        assert got.loc[key, "sigma2"] == pytest.approx(m.noise_variance, rel=1e-9)
        tr = back[back.device.astype(str) == key].sort_values("sample")
        np.testing.assert_array_equal(tr["sample"], np.arange(1, N))
        np.testing.assert_allclose(tr[names].to_numpy(), res.theta[1:], rtol=1e-12)
        np.testing.assert_allclose(tr["error"], y[1:] - res.yhat[1:], rtol=1e-12, atol=1e-15)
        np.testing.assert_array_equal(tr["k"], np.arange(1, N))
    # the device whose b jumps from 1.0 to 1.8 at sample 120 is flagged (supF), dated near it
    assert got["change"].tolist() == [False, True, False, False]
    assert abs(got.loc["d1", "change_at"] - N // 2) <= 10


def test_streaming_oe_kalman_parquet_int_keys_a_priori_test(tmp_path):
    df = _fleet_frame([2, 1, 3])
    path = _parquet_folder(df, tmp_path / "fleet")
    proto = models.RecursiveOE(1, 1, 1, method="kalman", noise_cov=1e-5, noise_var=0.01,
                               start="filled")
    got = fleet.fit_models(path, proto, group="device", y="y", u="u", time="k",
                           change_test="a-priori", npartitions=2)
    a = 0.948   # BDE's crossing constant at level 0.05
    for key, (res, y, _) in _python_stream(df, proto).items():
        np.testing.assert_allclose(got.loc[key, ["b0", "f1"]].to_numpy(float), res.theta[-1],
                                   rtol=1e-12)
        e = (y - res.yhat)[1:]
        m = e.size
        burn = max(10 * 2, int(np.ceil(0.1 * m)))
        w = e[burn:]
        W = np.cumsum(w) / np.sqrt(np.mean(w ** 2))
        j = np.arange(1, w.size + 1)
        ratio = np.max(np.abs(W) / (a * np.sqrt(w.size) + 2 * a * j / np.sqrt(w.size)))
        assert got.loc[key, "change_stat"] == pytest.approx(ratio, rel=2e-3)
        assert got.loc[key, "change"] == (ratio > 1)
        assert np.isnan(got.loc[key, "change_pvalue"])


def test_refusals_before_anything_runs(tmp_path):
    df = _fleet_frame(["a", "b"])
    with pytest.raises(ValueError, match="u"):
        fleet.fit_models(df, models.ARX(1, 1, 1), group="device", y="y", u="x")
    with pytest.raises(ValueError, match="group"):
        fleet.fit_models(df, models.ARX(1, 1, 1), group="dev", y="y", u="u")
    with pytest.raises(ValueError, match="u"):
        fleet.fit_models(df, models.AR(1), group="device", y="y", u="u")
    with pytest.raises(ValueError, match="u"):
        fleet.fit_models(df, models.ARX(1, 1, 1), group="device", y="y")
    with pytest.raises(ValueError, match="tracks"):
        fleet.fit_models(df, models.ARX(1, 1, 1), group="device", y="y", u="u",
                         tracks=str(tmp_path / "t"))
    with pytest.raises(TypeError, match="model"):
        fleet.fit_models(df, adaptid.RLS(2), group="device", y="y", u="u")
    with pytest.raises(ValueError, match="change_test"):
        fleet.fit_models(df, models.RecursiveOE(1, 1, 1), group="device", y="y", u="u",
                         change_test="nope")
    assert not (tmp_path / "t").exists()
    bad = df.copy()
    bad.loc[bad.device == "b", "u"] = bad.loc[bad.device == "b", "u"].where(
        bad.loc[bad.device == "b", "k"] != 50)
    with pytest.raises(ValueError, match="device 'b'.*missing"):
        fleet.fit_models(bad, models.OE(1, 1, 1), group="device", y="y", u="u", time="k")
