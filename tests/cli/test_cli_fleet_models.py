"""`adaptid fleet` with model options: every device on Dask, batch or streamed.

Oracles: a Python loop over the devices (rows sorted by pandas) of the
model objects' ``fit`` and of the streaming objects' ``run``, built with
the options a user would write in Python (MATLAB's names: ``forgetting``,
``noise_cov``, ``window``), not from the CLI's estimator.
"""

import copy

import numpy as np
import pandas as pd
import pytest

from adaptid import IDData, models
from ._helpers import run, run_json

N = 240




def _frame(keys, seed=5):
    """y_k = 0.6 y_{k-1} + b u_{k-1} + e_k + 0.3 e_{k-1} per device, rows shuffled."""
    rng = np.random.default_rng(seed)
    frames = []
    for i, key in enumerate(keys):
        u, e = rng.standard_normal(N), 0.1 * rng.standard_normal(N)
        y = np.zeros(N)
        y[0] = e[0]
        for k in range(1, N):
            y[k] = 0.6 * y[k - 1] + (0.5 + 0.2 * i) * u[k - 1] + e[k] + 0.3 * e[k - 1]
        frames.append(pd.DataFrame({"device": key, "k": np.arange(N), "u": u, "y": y}))
    return pd.concat(frames, ignore_index=True).sample(frac=1.0, random_state=4)


@pytest.fixture(scope="module")
def csv_fleet(tmp_path_factory):
    df = _frame(["pump-c", "pump-a", "pump-b", "pump-d"])
    path = tmp_path_factory.mktemp("fleetcsv") / "fleet.csv"
    df.to_csv(path, index=False, float_format="%.17g")
    return path, pd.read_csv(path)   # the oracle reads what the command reads


@pytest.fixture(scope="module")
def parquet_fleet(tmp_path_factory):
    df = _frame([30, 10, 20])
    folder = tmp_path_factory.mktemp("fleetpq") / "data"
    folder.mkdir()
    for i, rows in enumerate(np.array_split(np.arange(len(df)), 2)):
        df.iloc[rows].to_parquet(folder / f"part{i}.parquet", index=False)
    return folder, df


def _parts(df):
    for key, part in sorted(df.groupby("device"), key=lambda kv: kv[0]):
        part = part.sort_values("k", kind="stable")
        yield key, part.y.to_numpy(), part.u.to_numpy()


def _count_partitions(monkeypatch):
    """Count the Dask tasks of adaptid.fleet's model path (one per partition)."""
    from adaptid.fleet import _models

    calls = []
    real = _models._models_partition

    def counted(part, **kw):
        calls.append(len(part))
        return real(part, **kw)

    monkeypatch.setattr(_models, "_models_partition", counted)
    return calls


def _batch_table(df, make):
    rows = {}
    for key, y, u in _parts(df):
        m = make().fit(IDData(y, u, y_names="y", u_names="u"))
        res = np.asarray(m.residuals)
        rows[key] = [*m.theta, *m.stderr, res.size, 0, m.noise_variance,
                     np.sqrt(np.mean(res ** 2))]
        names = list(m.names)
    cols = names + [f"stderr_{n}" for n in names] + ["n_samples", "n_skipped", "sigma2", "rms"]
    return pd.DataFrame.from_dict(rows, orient="index", columns=cols)


def test_oe_batch_csv_string_keys_on_dask(csv_fleet, tmp_path, monkeypatch):
    path, df = csv_fleet
    calls = _count_partitions(monkeypatch)
    table = tmp_path / "t.csv"
    out = run_json("fleet", path, "-g", "device", "--y", "y", "--u", "u", "--oe", "1,1,1",
                   "--time", "k", "-o", table)
    assert out["method"] == "batch" and out["n_devices"] == 4
    assert len(calls) >= 2 and sum(calls) == len(df)   # several Dask tasks, every row once
    want = _batch_table(df, lambda: models.OE(1, 1, 1))
    back = pd.read_csv(table, index_col=0)
    assert list(back.columns) == list(want.columns)
    assert list(back.index) == list(want.index)
    np.testing.assert_allclose(back.to_numpy(float), want.to_numpy(float), rtol=1e-8)


def test_arx_batch_parquet_folder_int_keys(parquet_fleet, tmp_path, monkeypatch):
    folder, df = parquet_fleet
    calls = _count_partitions(monkeypatch)
    table = tmp_path / "t.parquet"
    out = run_json("fleet", folder, "-g", "device", "--y", "y", "--u", "u", "--arx", "2,2,1",
                   "--time", "k", "-o", table)
    assert out["method"] == "batch" and [d["device"] for d in out["devices"]] == [10, 20, 30]
    assert len(calls) >= 2 and sum(calls) == len(df)
    want = _batch_table(df, lambda: models.ARX(2, 2, 1))
    back = pd.read_parquet(table)
    assert list(back.columns) == list(want.columns) and list(back.index) == [10, 20, 30]
    np.testing.assert_allclose(back.to_numpy(float), want.to_numpy(float), rtol=1e-9)


def _stream_check(out, df, proto, names, rtol=1e-12):
    for dev in out["devices"]:
        parts = {k: (y, u) for k, y, u in _parts(df)}
        y, u = parts[dev["device"]]
        obj = copy.deepcopy(proto)
        res = obj.run(IDData(y, u))
        np.testing.assert_allclose([dev[n] for n in names], res.theta[-1], rtol=rtol)
        assert dev["n_samples"] == N - obj._s and "change" in dev


def test_armax_rls_streamed_per_device_with_tracks(csv_fleet, tmp_path):
    path, df = csv_fleet
    tracks = tmp_path / "tracks"
    out = run_json("fleet", path, "-g", "device", "--y", "y", "--u", "u", "--armax", "1,1,1,1",
                   "--time", "k", "--method", "rls", "--forgetting", "0.995",
                   "--tracks", tracks)
    assert out["method"] == "rls" and out["n_devices"] == 4
    proto = models.RecursiveARMAX(1, 1, 1, 1, forgetting=0.995, start="filled")
    _stream_check(out, df, proto, ["a1", "b0", "c1"])
    back = pd.read_parquet(tracks)
    for key, y, u in _parts(df):
        res = copy.deepcopy(proto).run(IDData(y, u))
        tr = back[back.device.astype(str) == key].sort_values("sample")
        np.testing.assert_allclose(tr[["a1", "b0", "c1"]].to_numpy(), res.theta[1:], rtol=1e-12)
        np.testing.assert_allclose(tr["error"], y[1:] - res.yhat[1:], rtol=1e-12, atol=1e-15)


def test_oe_kalman_and_bj_window_streamed(parquet_fleet):
    folder, df = parquet_fleet
    out = run_json("fleet", folder, "-g", "device", "--y", "y", "--u", "u", "--oe", "1,1,1",
                   "--time", "k", "--method", "kalman", "--process-cov", "1e-5",
                   "--noise-var", "0.01", "--change-test", "a-priori")
    proto = models.RecursiveOE(1, 1, 1, method="kalman", noise_cov=1e-5, noise_var=0.01,
                               start="filled")
    _stream_check(out, df, proto, ["b0", "f1"])
    out = run_json("fleet", folder, "-g", "device", "--y", "y", "--u", "u", "--bj",
                   "1,1,1,1,1", "--time", "k", "--method", "window", "--window", "80")
    proto = models.RecursiveBJ(1, 1, 1, 1, 1, window=80, start="filled")
    _stream_check(out, df, proto, ["b0", "c1", "d1", "f1"], rtol=1e-10)


def test_streamed_models_refusals(csv_fleet, tmp_path):
    path, _ = csv_fleet
    base = ("fleet", path, "-g", "device", "--y", "y", "--u", "u", "--time", "k")
    cases = [(("--armax", "1,1,1,1", "--method", "rls", "--nan", "skip"), "--nan skip"),
             (("--oe", "1,1,1", "--method", "window", "--window", "1"), "--window"),
             (("--armax", "1,1,1,1", "--tracks", tmp_path / "tr", "--method", "batch"),
              "--tracks"),
             (("--arma", "1,1"), "--u")]
    for extra, word in cases:
        r = run(*base, *extra)
        assert r.exit_code == 2 and word in r.stderr, (extra, r.output)
    assert not (tmp_path / "tr").exists()
