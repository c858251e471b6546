"""`adaptid fleet`: the command equals the library's identify; errors are one line, exit 2."""

import json

import numpy as np
from typer.testing import CliRunner

from adaptid import fleet
from adaptid.cli._app import app
from adaptid.datasets import fleet as make_fleet

PHI = ["i", "di_dt", "omega", "sign_i"]


def _run(args):
    return CliRunner().invoke(app, args)


def test_fleet_command_equals_identify(tmp_path):
    df = make_fleet(n_devices=8, n_samples=200, seed=2)
    path = tmp_path / "fleet.parquet"
    df.to_parquet(path)
    out = tmp_path / "res.csv"
    r = _run(["fleet", str(path), "--group", "device", "--y", "v", "--phi", ",".join(PHI),
              "--time", "time", "--forgetting", "0.99", "-o", str(out), "--json"])
    assert r.exit_code == 0, r.output
    got = json.loads(r.stdout)
    ref = fleet.identify(df, group="device", y="v", phi=PHI, time="time", forgetting=0.99)
    assert got["n_devices"] == 8 and got["n_flagged"] == int(ref["change"].sum())
    theta = np.array([[d[c] for c in PHI] for d in got["devices"]])
    np.testing.assert_array_equal(theta, ref[PHI].to_numpy())
    import pandas as pd
    back = pd.read_csv(out, index_col=0)
    np.testing.assert_allclose(back[PHI].to_numpy(), ref[PHI].to_numpy(), rtol=1e-15)


def test_fleet_command_errors_are_one_line(tmp_path):
    df = make_fleet(n_devices=3, n_samples=50, seed=0)
    path = tmp_path / "f.parquet"
    df.to_parquet(path)
    cases = [
        (["--group", "nodev", "--y", "v", "--phi", "i"], "nodev"),
        (["--group", "device", "--y", "v", "--phi", "i,torque"], "torque"),
        (["--group", "device", "--y", "v", "--phi", "i", "--method", "batch"], "--method"),
        (["--group", "device", "--y", "v", "--phi", "i", "--nan", "maybe"], "--nan"),
    ]
    for extra, word in cases:
        r = _run(["fleet", str(path), *extra])
        assert r.exit_code == 2, (extra, r.output)
        lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
        assert len(lines) == 1 and lines[0].startswith("adaptid: error:") and word in lines[0], lines
        assert "Traceback" not in r.output
