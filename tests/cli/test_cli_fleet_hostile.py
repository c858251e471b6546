"""`adaptid fleet` on hostile inputs (issue 32, "Fleet"): one line, exit 2, nothing written.

Each case builds its own input: a CSV with an empty device id (read as the text '',
refused as the library refuses a missing label), a glob that matches nothing, and
``--tracks`` inside the input folder (the oracle: the folder's files are exactly
the input ones after the refused call).
"""

import numpy as np
import pandas as pd
from typer.testing import CliRunner

from adaptid.cli._app import app


def _run(args):
    return CliRunner().invoke(app, args)


def _one_line(r, *words):
    assert r.exit_code == 2, r.output
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("adaptid: error:"), lines
    assert all(w in lines[0] for w in words), lines
    assert "Traceback" not in r.output


def _frame(labels, N=30, seed=0):
    rng = np.random.default_rng(seed)
    parts = []
    for g in labels:
        x = rng.standard_normal(N)
        parts.append(pd.DataFrame({"device": [g] * N, "x": x, "y": 2.0 * x}))
    return pd.concat(parts, ignore_index=True)


def test_empty_device_id_in_a_csv_is_refused(tmp_path):
    df = _frame(["a", "b"])
    df.loc[7, "device"] = ""
    path = tmp_path / "f.csv"
    df.to_csv(path, index=False)
    assert ",," in path.read_text() or path.read_text().count("\n,") == 1  # the case: empty
    out = tmp_path / "res.csv"
    r = _run(["fleet", str(path), "--group", "device", "--y", "y", "--phi", "x", "-o", str(out)])
    _one_line(r, "--group device", "empty device id", "data row 8")
    assert not out.exists()
    # blanks only (" ") are empty too
    df.loc[7, "device"] = "  "
    df.to_csv(path, index=False)
    _one_line(_run(["fleet", str(path), "--group", "device", "--y", "y", "--phi", "x"]),
              "empty device id")


def test_glob_matching_nothing_says_so(tmp_path):
    pattern = str(tmp_path / "none-*.parquet")
    r = _run(["fleet", pattern, "--group", "device", "--y", "y", "--phi", "x"])
    _one_line(r, f"no files match {pattern}")
    assert "columns: )" not in r.output


def test_tracks_inside_the_input_folder_is_refused(tmp_path):
    data = tmp_path / "in"
    data.mkdir()
    _frame(["a", "b"]).to_parquet(data / "p.parquet")
    before = sorted(p.relative_to(data) for p in data.rglob("*"))
    r = _run(["fleet", str(data), "--group", "device", "--y", "y", "--phi", "x",
              "--tracks", str(data / "tracks")])
    _one_line(r, "--tracks", "inside the input folder")
    assert sorted(p.relative_to(data) for p in data.rglob("*")) == before
    r = _run(["fleet", str(data), "--group", "device", "--y", "y", "--phi", "x",
              "--tracks", str(tmp_path / "tracks")])
    assert r.exit_code == 0, r.output
    assert any((tmp_path / "tracks").iterdir())
