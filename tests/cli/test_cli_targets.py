"""Issue 32, points 2 and 3: outputs never replace inputs; the state is saved last,
serialised, and refused under another model.

Oracles: the bytes of the input files before and after (unchanged), the file
listing of the folders (no temporary files, no partial report), the state's
own update counter (``n_updates``) after concurrent runs equal to the sum of
the rows both runs fed.
"""

import os
import signal
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from adaptid import load_state
from adaptid.cli._app import app

runner = CliRunner()


def invoke(*args):
    return runner.invoke(app, [str(a) for a in args])


def one_line(res, *needles):
    assert res.exit_code == 2, (res.exit_code, res.output)
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("adaptid: error: "), res.stderr
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])


@pytest.fixture
def data(tmp_path, rng):
    N = 300
    x = rng.standard_normal((N, 2))
    u = rng.standard_normal(N)
    y = x @ [1.0, -0.5] + 0.1 * rng.standard_normal(N)
    path = tmp_path / "d.csv"
    pd.DataFrame({"x0": x[:, 0], "x1": x[:, 1], "u": u, "y": y}).to_csv(path, index=False)
    return path


def _listing(folder):
    return sorted(p.name for p in folder.iterdir())


def test_report_file_named_like_the_data_is_refused(tmp_path, data):
    rep = tmp_path / "rep"
    rep.mkdir()
    src = rep / "estimates.csv"
    src.write_bytes(data.read_bytes())
    res = invoke("fit", src, "--y", "y", "--phi", "x0,x1", "--out", rep)
    one_line(res, "--out", "estimates.csv", "data file")
    assert src.read_bytes() == data.read_bytes()
    assert _listing(rep) == ["estimates.csv"]


def test_tracks_onto_the_resume_file_is_refused(tmp_path, data):
    s = tmp_path / "s.npz"
    assert invoke("fit", data, "--y", "y", "--phi", "x0,x1", "--save-state", s).exit_code == 0
    before = s.read_bytes()
    t = tmp_path / "s.csv"
    t.write_bytes(b"")
    os.link(s, tmp_path / "hard.csv")  # the same file under a .csv name
    res = invoke("fit", data, "--y", "y", "--phi", "x0,x1", "--resume", s,
                 "--tracks", tmp_path / "hard.csv")
    one_line(res, "--tracks", "--resume")
    assert s.read_bytes() == before


def test_two_outputs_of_one_name_are_refused(tmp_path, data):
    x = tmp_path / "x.csv"
    res = invoke("fit", data, "--y", "y", "--phi", "x0,x1", "--tracks", x, "--save-state", x)
    one_line(res, "--tracks", "--save-state")
    assert not x.exists()


def test_export_c_onto_its_state_file_is_refused(tmp_path, data):
    s = tmp_path / "s.npz"
    assert invoke("fit", data, "--y", "y", "--phi", "x0,x1", "--save-state", s).exit_code == 0
    plant = tmp_path / "plant.h"
    plant.write_bytes(s.read_bytes())
    before = plant.read_bytes()
    res = invoke("export-c", plant, "--out", tmp_path, "--name", "plant")
    one_line(res, "--out", "plant.h")
    assert plant.read_bytes() == before and not (tmp_path / "plant.c").exists()


def test_fit_export_c_onto_the_resume_file_is_refused(tmp_path, data):
    s = tmp_path / "s.npz"
    assert invoke("fit", data, "--y", "y", "--phi", "x0,x1", "--save-state", s).exit_code == 0
    out = tmp_path / "out"
    out.mkdir()
    h = out / "rls.h"
    h.write_bytes(s.read_bytes())
    res = invoke("fit", data, "--y", "y", "--phi", "x0,x1", "--resume", h, "--export-c", out)
    one_line(res, "--export-c", "--resume")
    assert h.read_bytes() == s.read_bytes() and _listing(out) == ["rls.h"]


def test_resume_under_other_regressors_is_refused(tmp_path, data):
    s = tmp_path / "s.npz"
    assert invoke("fit", data, "--y", "y", "--arx", "1,1,1", "--u", "u",
                  "--save-state", s).exit_code == 0
    before = s.read_bytes()
    one_line(invoke("fit", data, "--y", "y", "--phi", "x0,x1", "--resume", s,
                    "--save-state", s), "--resume", "model")
    assert s.read_bytes() == before
    # the same names in another order
    s2 = tmp_path / "s2.npz"
    assert invoke("fit", data, "--y", "y", "--phi", "x0,x1", "--save-state", s2).exit_code == 0
    one_line(invoke("fit", data, "--y", "y", "--phi", "x1,x0", "--resume", s2),
             "another order")
    one_line(invoke("fit", data, "--y", "u", "--phi", "x0,x1", "--resume", s2), "output")
    # control: the same options resume
    assert invoke("fit", data, "--y", "y", "--phi", "x0,x1", "--resume", s2).exit_code == 0


def test_python_saved_state_still_resumes(tmp_path, data):
    from adaptid import RLS

    s = tmp_path / "py.npz"
    RLS(2).save_state(s)
    assert invoke("fit", data, "--y", "y", "--phi", "x1,x0", "--resume", s).exit_code == 0


def test_json_to_a_full_disk_does_not_advance_the_state(tmp_path, data):
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full on this system")
    s = tmp_path / "s.npz"
    assert invoke("fit", data, "--y", "y", "--phi", "x0,x1", "--save-state", s).exit_code == 0
    before = s.read_bytes()
    with open("/dev/full", "w") as full:
        r = subprocess.run([sys.executable, "-m", "adaptid", "fit", str(data), "--y", "y",
                            "--phi", "x0,x1", "--resume", str(s), "--save-state", str(s),
                            "--json"], stdout=full, stderr=subprocess.PIPE, text=True,
                           timeout=300)
    assert r.returncode == 2, r.stderr
    assert s.read_bytes() == before
    assert load_state(s).n_updates == 300


def test_concurrent_resumes_of_one_state_take_turns(tmp_path, data):
    s = tmp_path / "s.npz"
    assert invoke("fit", data, "--y", "y", "--phi", "x0,x1", "--save-state", s).exit_code == 0
    cmd = [sys.executable, "-m", "adaptid", "fit", str(data), "--y", "y", "--phi", "x0,x1",
           "--resume", str(s), "--save-state", str(s), "-q"]
    procs = [subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True) for _ in range(3)]
    for p in procs:
        _, err = p.communicate(timeout=300)
        assert p.returncode == 0, err
    assert load_state(s).n_updates == 4 * 300


def test_sigterm_while_writing_removes_temporaries(tmp_path, data, monkeypatch):
    """SIGTERM mid-write: the tracks' temporary file and the report's staging folder go."""
    rep = tmp_path / "rep"
    tracks = tmp_path / "t.csv"
    original = pd.DataFrame.to_csv

    def to_csv(self, path, *a, **kw):
        original(self, path, *a, **kw)  # the temporary file exists now
        os.kill(os.getpid(), signal.SIGTERM)

    monkeypatch.setattr(pd.DataFrame, "to_csv", to_csv)
    res = invoke("fit", data, "--y", "y", "--phi", "x0,x1", "--method", "rls", "--out", rep,
                 "--tracks", tracks)
    assert res.exit_code == 130, res.output
    assert _listing(tmp_path) == ["d.csv"]  # no t.csv, no .t.csv.<pid>.tmp, no rep/


def test_failed_report_leaves_no_partial_folder(tmp_path, data, monkeypatch):
    import adaptid.cli._fit as fit

    rep = tmp_path / "rep"

    def boom(*a, **kw):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(fit, "_write_outputs", boom)
    res = invoke("fit", data, "--y", "y", "--phi", "x0,x1", "--out", rep, "--tracks",
                 tmp_path / "t.csv")
    assert res.exit_code == 2
    assert not rep.exists()


def test_report_in_an_existing_folder_keeps_other_files(tmp_path, data):
    rep = tmp_path / "rep"
    rep.mkdir()
    (rep / "notes.txt").write_text("mine")
    assert invoke("fit", data, "--y", "y", "--phi", "x0,x1", "--out", rep).exit_code == 0
    names = _listing(rep)
    assert "notes.txt" in names and "index.html" in names and "estimates.csv" in names
    assert not [n for n in names if n.startswith(".")]
    np.testing.assert_equal((rep / "notes.txt").read_text(), "mine")
