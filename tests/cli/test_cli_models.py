"""`adaptid fit --arx/--fir` reports the model objects' polynomial convention and names
(issue 13 point 4), checked against adaptid.models.ARX on the shipped DaISy dryer data
and against numpy's lstsq."""

import json

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

import adaptid
from adaptid import models
from adaptid.cli._app import app
from adaptid.datasets import load_daisy


def run_json(*args):
    r = CliRunner().invoke(app, [str(a) for a in args] + ["--json"])
    assert r.exit_code == 0, r.output
    return json.loads(r.stdout)


@pytest.fixture(scope="module")
def dryer_csv(tmp_path_factory):
    d = load_daisy("dryer")
    u, y = d.u - d.u.mean(), d.y - d.y.mean()
    path = tmp_path_factory.mktemp("dryer") / "dryer.csv"
    pd.DataFrame({"pump": u, "temp": y}).to_csv(path, index=False, float_format="%.17g")
    return path, u, y


def test_dryer_arx_batch_equals_models_arx(dryer_csv):
    path, u, y = dryer_csv
    out = run_json("fit", path, "--y", "temp", "--u", "pump", "--arx", "2,2,3", "--method", "batch")
    m = models.ARX(2, 2, 3).fit(y, u)
    assert out["names"] == ["a1", "a2", "b0", "b1"]  # ARX's names (issue 33)
    assert list(m.names) == ["a1", "a2", "b0", "b1"]        # the same coefficients, in order
    # the same QR least squares on the same rows: rounding only
    np.testing.assert_allclose(out["theta"], m.theta, rtol=1e-12)
    np.testing.assert_allclose(out["stderr"], np.sqrt(np.diag(m.cov)), rtol=1e-10)
    # the value the issue quotes (a1 of the mean-removed dryer, all 1000 samples)
    assert round(out["theta"][0], 4) == -1.2887


@pytest.mark.parametrize("flags, make", [
    (["--forgetting", "0.995"], lambda: adaptid.RLS(4, forgetting=0.995)),
    (["--method", "window", "--window", "300"], lambda: adaptid.SlidingWindowRLS(4, 300)),
    (["--method", "kalman", "--process-cov", "1e-6", "--noise-var", "0.01"],
     lambda: adaptid.estimator("kalman", 4, process_cov=1e-6, noise_var=0.01)),
], ids=["forgetting", "window", "kalman"])
def test_dryer_arx_recursive_equals_fit_recursive(dryer_csv, flags, make):
    """θ and the standard errors: the shell and the model object use the one rule
    of adaptid.recursive_fit_stats (under forgetting, in the window, with R₂)."""
    path, u, y = dryer_csv
    out = run_json("fit", path, "--y", "temp", "--u", "pump", "--arx", "2,2,3", *flags)
    m = models.ARX(2, 2, 3)
    est = make()
    m.fit_recursive(y, u, est)
    # a sign flip of a regressor column and of its parameter commutes exactly with RLS
    # from a P0·I prior: equal to rounding
    np.testing.assert_allclose(out["theta"], m.theta, rtol=1e-10, atol=1e-13)
    assert out["theta"][0] < 0
    np.testing.assert_allclose(out["stderr"], np.sqrt(np.diag(m.cov)), rtol=1e-9)


def test_two_inputs_named_by_column(rng, tmp_path):
    N = 600
    u1, u2 = rng.standard_normal(N), rng.standard_normal(N)
    y = np.zeros(N)
    for k in range(2, N):
        y[k] = 0.6 * y[k - 1] + 1.0 * u1[k - 1] + 0.5 * u1[k - 2] - 2.0 * u2[k - 1] \
            + 0.3 * u2[k - 2] + 0.01 * rng.standard_normal()
    path = tmp_path / "two.csv"
    pd.DataFrame({"u1": u1, "u2": u2, "y": y}).to_csv(path, index=False, float_format="%.17g")
    out = run_json("fit", path, "--y", "y", "--u", "u1,u2", "--arx", "1,2,1", "--method", "batch")
    assert out["names"] == ["a1", "b0_0", "b0_1", "b1_0", "b1_1"]  # ARX's (issue 33)
    m = models.ARX(1, 2, 1).fit(y, np.column_stack([u1, u2]))
    assert list(m.names) == ["a1", "b0_0", "b0_1", "b1_0", "b1_1"]
    np.testing.assert_allclose(out["theta"], m.theta, rtol=1e-10)
    # and the truth (simulated above), within the noise
    np.testing.assert_allclose(out["theta"], [-0.6, 1.0, 0.5, -2.0, 0.3], atol=0.01)


def test_fir_names(rng, tmp_path):
    N = 300
    u = rng.standard_normal(N)
    y = np.r_[0.0, 0.0, 2.0 * u[:-2]] + np.r_[0.0, 0.0, 0.0, -1.0 * u[:-3]]
    path = tmp_path / "fir.csv"
    pd.DataFrame({"valve": u, "flow": y}).to_csv(path, index=False, float_format="%.17g")
    out = run_json("fit", path, "--y", "flow", "--u", "valve", "--fir", "2,2", "--method", "batch")
    assert out["names"] == ["b0", "b1"]  # ARX(0, nb, nk)'s names (issue 33)
    np.testing.assert_allclose(out["theta"], [2.0, -1.0], atol=1e-12)  # noise-free: exact
