"""The command line at the edges (issue 14): transactional outputs, outputs that are inputs,
hostile data files, mistyped options and numeric options outside the float64 range.

Every hostile file is created here. The contract checked for each error: exit code 2, one
line ``adaptid: error: ...`` on stderr naming the file or option, nothing on stdout, and
the files on disk unchanged (compared byte for byte).
"""

import gzip
import io
import json
import subprocess
import sys
import zipfile

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

import adaptid
from adaptid.cli._app import app

runner = CliRunner()


def invoke(*args):
    return runner.invoke(app, [str(a) for a in args])


def one_line_error(res, *needles):
    assert res.exit_code == 2, (res.exit_code, res.output)
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, res.stderr
    assert lines[0].startswith("adaptid: error: "), lines[0]
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])
    assert "internal error" not in lines[0] and "Traceback" not in res.output
    assert res.stdout == ""
    return lines[0]


@pytest.fixture
def data(tmp_path):
    rng = np.random.default_rng(5)
    N = 200
    Phi = rng.standard_normal((N, 3))
    y = Phi @ [1.0, -2.0, 0.5] + 0.05 * rng.standard_normal(N)
    path = tmp_path / "d.csv"
    pd.DataFrame({"a": Phi[:, 0], "b": Phi[:, 1], "c": Phi[:, 2], "y": y}).to_csv(
        path, index=False, float_format="%.17g")
    return path, Phi, y


FIT = ("--y", "y", "--phi", "a,b,c")


# ------------------------------------------------------------- transactional outputs
def test_failed_report_does_not_advance_the_state(data, tmp_path):
    path, *_ = data
    state = tmp_path / "s.npz"
    assert invoke("fit", path, *FIT, "--save-state", state).exit_code == 0
    before = state.read_bytes()
    blocker = tmp_path / "file.txt"
    blocker.write_text("a file, not a folder")
    res = invoke("fit", path, *FIT, "--resume", state, "--save-state", state,
                 "--out", blocker / "report")
    one_line_error(res, "--out")
    assert state.read_bytes() == before                      # not advanced
    assert adaptid.load_state(state).n_updates == 200
    # a retry with a good --out advances it once: 400, not 600
    res = invoke("fit", path, *FIT, "--resume", state, "--save-state", state,
                 "--out", tmp_path / "rep", "--json")
    assert res.exit_code == 0, res.output
    assert adaptid.load_state(state).n_updates == 400


def test_unwritable_save_state_folder_checked_first(data, tmp_path):
    path, *_ = data
    res = invoke("fit", path, *FIT, "--save-state", tmp_path / "no" / "such" / "s.npz")
    one_line_error(res, "--save-state", "does not exist")


def test_save_state_over_the_data_file_refused(data):
    path, *_ = data
    before = path.read_bytes()
    one_line_error(invoke("fit", path, *FIT, "--save-state", path), "--save-state", "data file")
    assert path.read_bytes() == before


def test_fleet_output_over_the_input_refused(tmp_path):
    from adaptid.datasets import fleet as make_fleet
    df = make_fleet(n_devices=3, n_samples=100, seed=1)
    inp = tmp_path / "in.parquet"
    df.to_parquet(inp)
    before = inp.read_bytes()
    res = invoke("fleet", inp, "--group", "device", "--y", "v", "--phi", "i,di_dt,omega,sign_i",
                 "--output", inp)   # the former spelling of --out (issue 33: one -o/--out)
    one_line_error(res, "--out", "input")
    assert inp.read_bytes() == before
    res = invoke("fleet", inp, "--group", "device", "--y", "v", "--phi", "i,di_dt,omega,sign_i",
                 "--out", tmp_path / "out.xlsx")
    one_line_error(res, "--out", ".csv")
    assert not (tmp_path / "out.xlsx").exists()


# ------------------------------------------------------------------ hostile files
def _zip_set_encrypted(raw: bytes) -> bytes:
    """Set the 'encrypted' bit of every member (local and central headers), PKWARE APPNOTE 4.4.4."""
    b = bytearray(raw)
    for sig, off in ((b"PK\x03\x04", 6), (b"PK\x01\x02", 8)):
        i = b.find(sig)
        while i >= 0:
            b[i + off] |= 1
            i = b.find(sig, i + 4)
    return bytes(b)


def _hostile(tmp_path, kind):
    if kind == "corrupt.csv.gz":
        good = gzip.compress(b"a,b,c,y\n" + b"1,2,3,4\n" * 200)
        raw = good[:20] + bytes(range(256)) * 4            # a gzip header, then garbage
    elif kind == "encrypted.npz":
        buf = io.BytesIO()
        np.savez(buf, y=np.arange(5.0), a=np.arange(5.0))
        raw = _zip_set_encrypted(buf.getvalue())
    elif kind == "badly-compressed.npz":
        buf = io.BytesIO()
        np.savez_compressed(buf, y=np.random.default_rng(0).random(2000),
                            a=np.random.default_rng(1).random(2000))
        b = bytearray(buf.getvalue())
        for k in range(200, 400):
            b[k] ^= 0x5A
        raw = bytes(b)
    elif kind == "not-npy.npz":
        buf = io.BytesIO()
        with zipfile.ZipFile(buf, "w") as z:
            z.writestr("y.npy", "hello, not an array")
        raw = buf.getvalue()
    elif kind == "random.csv":
        raw = np.random.default_rng(0).bytes(20000).replace(b"\x00", b"\x01")
    elif kind == "latin1.csv":
        raw = "temp\xe9rature,y\n1,2\n3,4\n".encode("latin-1")
    else:
        raise AssertionError(kind)
    p = tmp_path / kind
    p.write_bytes(raw)
    return p


@pytest.mark.parametrize("kind, needle", [
    ("corrupt.csv.gz", "gzip"),
    ("encrypted.npz", "encrypted"),
    ("badly-compressed.npz", "not a readable .npz"),
    ("not-npy.npz", "not a NumPy array"),
    ("random.csv", "not UTF-8"),
    ("latin1.csv", "not UTF-8"),
])
def test_hostile_files_are_one_line_errors(tmp_path, kind, needle):
    p = _hostile(tmp_path, kind)
    line = one_line_error(invoke("fit", p, "--y", "y", "--phi", "a"), str(p), needle)
    assert "empty" not in line


def test_wide_header_is_read(tmp_path):
    """200 000 columns: a valid (if odd) CSV; the error is the missing column, not 'empty'."""
    p = tmp_path / "wide.csv"
    p.write_text(",".join(f"c{i}" for i in range(200_000)) + "\n"
                 + ",".join("1" for _ in range(200_000)) + "\n")
    one_line_error(invoke("fit", p, "--y", "y", "--phi", "c1"), str(p), "no column 'y'",
                   "200000")


# ------------------------------------------------------------------ mistyped options
@pytest.mark.parametrize("args, needle", [
    (["fit", "x.csv", "--phii", "a"], "--phii"),
    (["fit", "x.csv", "--window", "ten"], "--window"),
    (["fit"], "data"),
    (["fleet", "x.parquet"], "--group"),
    (["fitt"], "fitt"),
])
def test_usage_errors_are_one_line(args, needle):
    res = invoke(*args)
    line = one_line_error(res, needle)
    assert "╭" not in res.stderr and "│" not in res.stderr


def test_usage_error_one_line_in_a_real_process(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "adaptid", "fit", "x.csv", "--phii", "a"],
                          capture_output=True, text=True, cwd=tmp_path)
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [
        proc.stderr.strip()] and proc.stderr.startswith("adaptid: error: ")


# ------------------------------------------------------------------ numeric edges
@pytest.mark.parametrize("opts, needle", [
    (["--forgetting", "1e-300"], "--forgetting"),
    (["--P0", "1e308"], "--P0"),
    (["--P0", "1e-300"], "--P0"),
    (["--method", "kalman", "--process-cov", "1e308"], "--process-cov"),
    (["--method", "kalman", "--process-cov", "1e-3", "--noise-var", "1e300"], "--noise-var"),
])
@pytest.mark.parametrize("command", ["fit", "fleet"])
def test_numeric_options_outside_float64_range(data, tmp_path, command, opts, needle):
    path, *_ = data
    extra = ["--group", "a"] if command == "fleet" else []
    line = one_line_error(invoke(command, path, *FIT, *extra, *opts), needle, "float64")
    assert "1e+" in line or "1e-" in line  # the value given is named


def test_range_edges_give_correct_estimates(data):
    """At the documented edges (P0 = 1e100, λ = 1) the estimate is still least squares."""
    path, Phi, y = data
    res = invoke("fit", path, *FIT, "--P0", "1e100", "--forgetting", "1", "--json")
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout)
    theta = np.linalg.lstsq(Phi, y, rcond=None)[0]
    # a prior 1e-100·I in the information matrix: rounding of the RLS recursion only
    np.testing.assert_allclose(out["theta"], theta, rtol=1e-8)
    np.testing.assert_allclose(out["stderr"], np.sqrt(
        np.sum((y - Phi @ theta) ** 2) / (len(y) - 3) * np.diag(np.linalg.inv(Phi.T @ Phi))),
        rtol=1e-6)


def test_save_state_onto_a_fifo_refused(data, tmp_path):
    """Issue 32, point 2: an existing non-regular target is refused before the run."""
    import os
    import stat
    path, *_ = data
    fifo = tmp_path / "s.fifo"
    os.mkfifo(fifo)
    one_line_error(invoke("fit", path, *FIT, "--save-state", fifo), "--save-state", "FIFO")
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)
    tracks = tmp_path / "t.csv"
    os.mkfifo(tracks)
    one_line_error(invoke("fit", path, *FIT, "--method", "rls", "--tracks", tracks), "--tracks",
                   "FIFO")
    assert stat.S_ISFIFO(os.stat(tracks).st_mode)


# ------------------------------------------- issue 32: errors that name the option
def test_huge_window_refused_before_allocating(data):
    path, *_ = data
    one_line_error(invoke("fit", path, *FIT, "--method", "window", "--window", "1000000000"),
                   "--window", "1e+08")


def test_window_longer_than_the_data_refused(data, tmp_path):
    path, *_ = data
    one_line_error(invoke("fit", path, *FIT, "--method", "window", "--window", "201"),
                   "--window", "200", "--save-state")
    # with --save-state a later --resume may fill the window: accepted
    res = invoke("fit", path, *FIT, "--method", "window", "--window", "201",
                 "--save-state", tmp_path / "s.npz")
    assert res.exit_code == 0, res.output


def test_c_keyword_as_c_name(data, tmp_path):
    path, *_ = data
    one_line_error(invoke("fit", path, *FIT, "--export-c", tmp_path / "c", "--c-name", "int"),
                   "--c-name", "keyword")


def test_tiny_cutoff_names_cutoff(tmp_path):
    d, _ = adaptid.datasets.dc_motor(seed=1, duration=1.0)
    path = tmp_path / "motor.csv"
    d.to_csv(path, index=False)
    one_line_error(invoke("fit", path, "--dc-motor", "--cutoff", "1e-300"), "cutoff", "1e-300")


def test_bad_max_specialised_n_in_a_real_process(data, tmp_path):
    import os
    path, *_ = data
    env = dict(os.environ, ADAPTID_MAX_SPECIALISED_N="abc")
    proc = subprocess.run([sys.executable, "-m", "adaptid", "fit", str(path), *FIT, "--json"],
                          capture_output=True, text=True, cwd=tmp_path, env=env)
    assert proc.returncode == 0, proc.stderr
    assert "ADAPTID_MAX_SPECIALISED_N" in proc.stderr
    json.loads(proc.stdout)


# ------------------------------------------------ issue 32, point 5: the columns used
@pytest.mark.parametrize("phi", ["a,a", "a,b,a"])
def test_duplicated_phi_column_refused(data, phi):
    path, *_ = data
    one_line_error(invoke("fit", path, "--y", "y", "--phi", phi), "--phi", "'a' twice")


def test_no_samples_left_after_nan_skip(tmp_path):
    path = tmp_path / "n.csv"
    rng = np.random.default_rng(1)
    pd.DataFrame({"a": rng.standard_normal(20), "c": np.nan, "y": rng.standard_normal(20)}
                 ).to_csv(path, index=False)
    one_line_error(invoke("fit", path, "--y", "y", "--phi", "a,c", "--nan", "skip"),
                   str(path), "no samples left", "'c'")
    res = invoke("fit", path, "--y", "y", "--phi", "a", "--nan", "skip", "--json")
    assert res.exit_code == 0, res.output


def test_fewer_samples_than_parameters_warns(data, tmp_path):
    path, *_ = data
    short = tmp_path / "short.csv"
    short.write_text("".join(path.read_text().splitlines(keepends=True)[:3]))
    res = invoke("fit", short, *FIT, "--json")
    assert res.exit_code == 0, res.output
    assert "2 samples for 3 parameters" in res.stderr
    json.loads(res.stdout)
