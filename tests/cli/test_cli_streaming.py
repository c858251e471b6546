"""`adaptid fit --arma / --bj` with a recursive --method runs the streaming objects (issue 33).

The Python calls the CLI must agree with: RecursiveARMA / RecursiveBJ with
``start="filled"`` and MATLAB's method of the CLI's estimator (lms: gradient, nlms:
normalised gradient, which the models' ``fit_recursive`` does not offer), on the
same CSV; the truth of the simulated record.
"""

import json

import numpy as np
import pandas as pd
import pytest
from scipy import signal
from typer.testing import CliRunner

from adaptid.cli._app import app
from adaptid.models import RecursiveARMA, RecursiveBJ


def run_json(*args):
    r = CliRunner().invoke(app, [str(a) for a in args] + ["--json"])
    assert r.exit_code == 0, r.output
    return json.loads(r.stdout)


@pytest.fixture(scope="module")
def record(tmp_path_factory):
    rng = np.random.default_rng(5)
    N = 3000
    u = np.sign(rng.standard_normal(N))
    e = 0.1 * rng.standard_normal(N)
    y = signal.lfilter([0, 1.0, 0.5], [1, -0.8], u) + signal.lfilter([1, 0.4], [1, -0.6], e)
    path = tmp_path_factory.mktemp("stream") / "rec.csv"
    pd.DataFrame({"u": u, "y": y}).to_csv(path, index=False, float_format="%.17g")
    return path, y, u


def test_arma_nlms_tracks_are_the_streaming_object(record, tmp_path):
    path, y, _ = record
    tracks = tmp_path / "t.parquet"
    out = run_json("fit", path, "--y", "y", "--arma", "1,1", "--method", "nlms", "--step",
                   "0.2", "--tracks", tracks)
    res = RecursiveARMA(1, 1, start="filled", method="ngradient", step=0.2).run(y)
    df = pd.read_parquet(tracks)
    np.testing.assert_array_equal(df["sample"], np.arange(1, len(y)))
    np.testing.assert_array_equal(df[["a1", "c1"]].to_numpy(), res.theta[1:])
    np.testing.assert_allclose(df["error"], y[1:] - res.yhat[1:], rtol=0, atol=1e-14)
    np.testing.assert_allclose(out["theta"], res.theta[-1], rtol=1e-12)   # stable C: kept
    assert out["method"] == "nlms" and out["n_samples"] == len(y) - 1


def test_bj_lms_theta_is_the_streaming_object(record, tmp_path):
    path, y, u = record
    tracks = tmp_path / "t.parquet"
    out = run_json("fit", path, "--y", "y", "--u", "u", "--bj", "2,1,1,1,1", "--method", "lms",
                   "--step", "0.01", "--tracks", tracks)
    res = RecursiveBJ(2, 1, 1, 1, 1, start="filled", method="gradient", step=0.01).run(y, u)
    df = pd.read_parquet(tracks)
    names = [c for c in df.columns if c not in ("sample", "error")]
    np.testing.assert_array_equal(df[names].to_numpy(), res.theta[2:])   # s = nk + nb - 1
    # the truth of the simulated record: b0, b1, f1 of B/F = (1 + 0.5 q^-1) q^-1 / (1 - 0.8 q^-1)
    th = np.asarray(out["theta"])
    assert np.allclose(th[[0, 1, 4]], [1.0, 0.5, -0.8], atol=0.1)
