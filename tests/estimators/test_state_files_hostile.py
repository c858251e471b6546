"""State files as hostile input (issue 14): non-regular files, bombs, forged sizes and
content, parser-breaking headers, and save_state's file handling.

Every hostile file is made here, by hand, from the format documented in
``src/adaptid/estimators/_statefile.py`` (zip of ``.npy`` members, JSON header,
SHA-256 checksum re-implemented below from that description, not imported), so
that a forged file tests the reader, not the writer. The contract: every
failure is ``StateFileError`` with a message naming the file, time and memory
stay bounded by what the header declares (checked with ``tracemalloc``, which
sees NumPy's and zlib's allocations), and nothing is read from a FIFO or
device.
"""

import hashlib
import io
import json
import os
import stat
import struct
import subprocess
import sys
import threading
import time
import tracemalloc
import zipfile
from pathlib import Path

import numpy as np
import pytest

import adaptid
from adaptid import KalmanRLS, RLS, SlidingWindowRLS, StateFileError
from adaptid.constrained import ConstrainedRLS

FIXTURES = Path(__file__).resolve().parents[1] / "data" / "state_format2"


# ------------------------------------------------------------------ helpers
def _digest(header, arrays):
    """The documented checksum: SHA-256 of the canonical JSON header (sorted keys,
    compact separators, without 'checksum'), then per array in name order its
    name, dtype, shape (repr) and raw bytes."""
    h = hashlib.sha256()
    h.update(json.dumps(header, sort_keys=True, separators=(",", ":")).encode())
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(name.encode())
        h.update(str(a.dtype).encode())
        h.update(repr(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()


def _raw(path):
    with zipfile.ZipFile(path) as zf:
        arrays = {n[:-4]: np.load(io.BytesIO(zf.read(n)), allow_pickle=False)
                  for n in zf.namelist()}
    header = json.loads(arrays.pop("header").tobytes().decode())
    header.pop("checksum")
    return header, arrays


def _write(path, header, arrays, *, checksum=True, header_bytes=None):
    header = dict(header)
    if checksum:
        header["checksum"] = _digest(header, arrays)
    raw = json.dumps(header).encode() if header_bytes is None else header_bytes
    np.savez(path, header=np.frombuffer(raw, dtype=np.uint8), **arrays)
    return path


def _refused(path, *needles, cls=None):
    with pytest.raises(StateFileError) as info:
        (cls or adaptid).load_state(path)
    msg = str(info.value)
    assert os.path.basename(str(path)) in msg, msg
    for needle in needles:
        assert needle in msg, (needle, msg)
    return msg


def _trained(kind, seed=3):
    rng = np.random.default_rng(seed)
    Phi = rng.standard_normal((30, 3))
    y = Phi @ [1.0, -2.0, 0.5] + 0.1 * rng.standard_normal(30)
    est = {"RLS": lambda: RLS(3, forgetting=0.99),
           "SlidingWindowRLS": lambda: SlidingWindowRLS(3, 8),
           "KalmanRLS": lambda: KalmanRLS(3, process_cov=1e-3)}[kind]()
    est.run(Phi, y)
    return est


@pytest.fixture(params=["RLS", "SlidingWindowRLS", "KalmanRLS"])
def saved(request, tmp_path):
    est = _trained(request.param)
    path = tmp_path / "s.npz"
    est.save_state(path)
    return est, path


def _bounded(fn, *, seconds, megabytes):
    """Run fn(); it must end within `seconds` and allocate at most `megabytes` at peak."""
    tracemalloc.start()
    t0 = time.perf_counter()
    try:
        fn()
    finally:
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    elapsed = time.perf_counter() - t0
    assert elapsed < seconds, elapsed
    assert peak < megabytes * 2 ** 20, peak / 2 ** 20


# ----------------------------------------------------------- non-regular files
def _in_thread(fn, timeout):
    out = {}

    def target():
        try:
            fn()
        except BaseException as err:  # noqa: BLE001 - reported to the test
            out["err"] = err
    t = threading.Thread(target=target, daemon=True)
    t.start()
    t.join(timeout)
    assert not t.is_alive(), "load_state blocked"
    return out.get("err")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this platform")
def test_fifo_is_refused_without_blocking(tmp_path):
    fifo = tmp_path / "state.fifo"
    os.mkfifo(fifo)
    # no writer ever opens it: a plain open() for reading would block forever
    err = _in_thread(lambda: adaptid.load_state(fifo), timeout=10)
    assert isinstance(err, StateFileError) and "regular file" in str(err)


@pytest.mark.parametrize("device", ["/dev/zero", "/dev/urandom", "/dev/null"])
def test_devices_are_refused_without_reading(device, tmp_path):
    if not os.path.exists(device):
        pytest.skip(f"{device} does not exist here")
    link = tmp_path / "s.npz"
    link.symlink_to(device)
    for path in (device, link):   # also through a symlink with an innocent name
        def load(path=path):
            with pytest.raises(StateFileError, match="regular file"):
                adaptid.load_state(path)
        _bounded(load, seconds=5, megabytes=5)


def test_directory_is_refused(tmp_path):
    _refused(tmp_path, "regular file")


# ------------------------------------------------------------------ bombs
def _stream_member(zf, name, preamble, nbytes, chunk=2 ** 22):
    info = zipfile.ZipInfo(name)
    info.compress_type = zipfile.ZIP_DEFLATED
    with zf.open(info, "w", force_zip64=True) as fh:
        fh.write(preamble)
        zeros = bytes(chunk)
        left = nbytes
        while left:
            k = min(chunk, left)
            fh.write(zeros[:k])
            left -= k


def _npy_preamble(shape, dtype="<f8"):
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        buf, {"descr": dtype, "fortran_order": False, "shape": tuple(shape)})
    return buf.getvalue()


def _bomb(tmp_path, saved, state_shape, declared_bytes):
    """A valid file whose 'state' member is replaced by `declared_bytes` of deflated zeros."""
    _, path = saved
    header, arrays = _raw(path)
    header["checksum"] = _digest(header, arrays)
    bomb = tmp_path / "bomb.npz"
    with zipfile.ZipFile(bomb, "w", zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("header.npy", _npy_bytes(np.frombuffer(json.dumps(header).encode(), np.uint8)))
        for name, a in arrays.items():
            if name != "state":
                zf.writestr(f"{name}.npy", _npy_bytes(a))
        _stream_member(zf, "state.npy", _npy_preamble(state_shape), declared_bytes)
    return bomb


def _npy_bytes(a):
    buf = io.BytesIO()
    np.save(buf, a, allow_pickle=False)
    return buf.getvalue()


def test_deflate_bomb_is_refused_before_inflating(tmp_path, saved):
    # 256 MiB of zeros deflate to ~250 KB (ratio ~1000): the member's declared
    # size (zip directory) is checked against the header's shapes first
    bomb = _bomb(tmp_path, saved, (2 ** 25,), 2 ** 28)
    assert bomb.stat().st_size < 2 ** 20
    _bounded(lambda: _refused(bomb, "declares"), seconds=5, megabytes=20)


def test_bomb_with_forged_small_size_reads_at_most_the_declared_size(tmp_path, saved):
    """The zip directory lies (the member's size is set to what the header implies):
    at most that many bytes are inflated, and the lie is detected (CRC / trailing data)."""
    est, path = saved
    L = est.get_state()["state"].shape[0]
    bomb = _bomb(tmp_path, saved, (L,), 2 ** 27)
    raw = bytearray(bomb.read_bytes())
    want = len(_npy_preamble((L,))) + 8 * L
    # rewrite the uncompressed size in the central directory (APPNOTE 4.3.12: bytes
    # 24..28 of a central header; no zip64 field below 4 GiB)
    off = _central_entry(raw, "state.npy")
    assert struct.unpack("<I", raw[off + 24: off + 28])[0] > 2 ** 27
    raw[off + 24: off + 28] = struct.pack("<I", want)
    bomb.write_bytes(bytes(raw))
    with zipfile.ZipFile(bomb) as zf:
        assert zf.getinfo("state.npy").file_size == want      # the lie is in place
    _bounded(lambda: _refused(bomb), seconds=10, megabytes=20)


def _central_entry(raw, name):
    i = raw.find(b"PK\x01\x02")
    while i >= 0:
        name_len = struct.unpack("<H", raw[i + 28: i + 30])[0]
        if raw[i + 46: i + 46 + name_len] == name.encode():
            return i
        i = raw.find(b"PK\x01\x02", i + 4)
    raise AssertionError(name)


@pytest.mark.parametrize("field, value, needle", [
    ("n_params", 6000, "n_params"), ("n_params", 40000, "n_params"),
    ("n_params", 2000, ""),   # within the limits: the members (or the window) do not match it
    ("n_outputs", 10 ** 6, "n_outputs"), ("batch", 10 ** 9, "batch"),
    ("batch", 10 ** 6, "shape"), ("n_params", 0, "n_params"), ("n_params", True, "n_params"),
    ("n_params", 3.0, "n_params"), ("n_updates", -1, "n_updates"),
    ("single_output", "yes", "single_output"),
])
def test_header_sizes_are_checked_before_allocating(tmp_path, saved, field, value, needle):
    _, path = saved
    header, arrays = _raw(path)
    header[field] = value
    forged = _write(tmp_path / "forged.npz", header, arrays)
    assert forged.stat().st_size < 2 ** 14
    _bounded(lambda: _refused(forged, needle), seconds=5, megabytes=10)


def test_huge_window_is_refused_before_allocating(tmp_path):
    est = _trained("SlidingWindowRLS")
    est.save_state(tmp_path / "w.npz")
    header, arrays = _raw(tmp_path / "w.npz")
    for M in (10 ** 9, 10 ** 7):   # beyond the limit; within it but 10^7 × 8 floats declared
        header["options"]["window"] = M
        forged = _write(tmp_path / "forged.npz", header, arrays)
        _bounded(lambda: _refused(forged), seconds=5, megabytes=10)


def test_header_member_is_size_capped(tmp_path, saved):
    _, path = saved
    header, arrays = _raw(path)
    header["padding"] = "x" * (2 ** 21)
    _refused(_write(tmp_path / "big.npz", header, arrays), "declares")


# ------------------------------------------------------------ parser-breaking headers
def test_deeply_nested_json_header(tmp_path, saved):
    _, path = saved
    _, arrays = _raw(path)
    deep = b"[" * 100_000 + b"]" * 100_000
    _refused(_write(tmp_path / "deep.npz", {}, arrays, checksum=False, header_bytes=deep),
             "header")
    deep_opts = b'{"magic": "adaptid-state", "format": 2, "options": ' + b"[" * 50_000 \
        + b"]" * 50_000 + b"}"
    _refused(_write(tmp_path / "deep2.npz", {}, arrays, checksum=False, header_bytes=deep_opts))


@pytest.mark.parametrize("content", [b"hello, not an array", b"\x93NUMPY\x01\x00\xff\xff{",
                                     b"\x93NUMPY\x09\x00\x10\x00{}"])
def test_non_npy_header_member(tmp_path, content):
    path = tmp_path / "s.npz"
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("header.npy", content)
    _refused(path, "header.npy")


def test_object_dtype_members_are_refused_unread(tmp_path, saved):
    _, path = saved
    header, arrays = _raw(path)
    arrays["state"] = np.array([1.0, None], dtype=object)
    forged = tmp_path / "obj.npz"
    np.savez(forged, header=np.frombuffer(json.dumps(header).encode(), np.uint8), **arrays,
             allow_pickle=True)
    _refused(forged, "dtype")


def _zip_flag(raw, bit=None, method=None):
    b = bytearray(raw)
    for sig, flag_off, method_off in ((b"PK\x03\x04", 6, 8), (b"PK\x01\x02", 8, 10)):
        i = b.find(sig)
        while i >= 0:
            if bit is not None:
                b[i + flag_off] |= bit
            if method is not None:
                b[i + method_off: i + method_off + 2] = struct.pack("<H", method)
            i = b.find(sig, i + 4)
    return bytes(b)


@pytest.mark.parametrize("how, needle", [("encrypted", "encrypted"), ("bzip2", "compression"),
                                         ("lzma", "compression"), ("unknown", "compression")])
def test_encrypted_and_exotic_compression_are_refused(tmp_path, saved, how, needle):
    _, path = saved
    raw = path.read_bytes()
    raw = _zip_flag(raw, bit=1) if how == "encrypted" else \
        _zip_flag(raw, method={"bzip2": 12, "lzma": 14, "unknown": 99}[how])
    bad = tmp_path / "bad.npz"
    bad.write_bytes(raw)
    _refused(bad, needle)


def test_repeated_and_foreign_members_are_refused(tmp_path, saved):
    _, path = saved
    raw = path.read_bytes()
    dup = tmp_path / "dup.npz"
    dup.write_bytes(raw)
    with pytest.warns(UserWarning, match="Duplicate name"):
        with zipfile.ZipFile(dup, "a") as zf:
            zf.writestr("state.npy", _npy_bytes(np.zeros(3)))
    _refused(dup, "repeated")
    other = tmp_path / "other.npz"
    other.write_bytes(raw)
    with zipfile.ZipFile(other, "a") as zf:
        zf.writestr("../../etc/evil", b"x")
    _refused(other, "unexpected")


# ------------------------------------------------------- content after the checksum
def _layout(est):
    st = est.get_state()
    n, p = st["n_params"], st["n_outputs"]
    return n, p, n * p, n * p + n * n     # n, p, offset of U, offset of D


STATE_EDITS = {
    "theta inf": lambda S, n, p, oU, oD: S.__setitem__(0, np.inf),
    "theta nan": lambda S, n, p, oU, oD: S.__setitem__(1, np.nan),
    "U nan": lambda S, n, p, oU, oD: S.__setitem__(oU + n, np.nan),   # U[0, 1] (by columns)
    "U diag 2": lambda S, n, p, oU, oD: S.__setitem__(oU, 2.0),
    "U lower": lambda S, n, p, oU, oD: S.__setitem__(oU + 1, 0.5),     # U[1, 0]
    "D negative": lambda S, n, p, oU, oD: S.__setitem__(oD, -1.0),
    "D zero": lambda S, n, p, oU, oD: S.__setitem__(oD + 1, 0.0),
    "D inf": lambda S, n, p, oU, oD: S.__setitem__(oD + 2, np.inf),
}


@pytest.mark.parametrize("edit", sorted(STATE_EDITS))
@pytest.mark.parametrize("kind", ["RLS", "SlidingWindowRLS", "KalmanRLS"])
def test_forged_content_with_recomputed_checksum_is_refused(tmp_path, kind, edit):
    est = _trained(kind)
    est.save_state(tmp_path / "s.npz")
    header, arrays = _raw(tmp_path / "s.npz")
    n, p, oU, oD = _layout(est)
    S = arrays["state"].copy()
    STATE_EDITS[edit](S, n, p, oU, oD)
    arrays["state"] = S
    _refused(_write(tmp_path / "evil.npz", header, arrays), "inconsistent state")


@pytest.mark.parametrize("where", ["phi buffer", "y buffer", "theta0 copy", "D0 copy"])
def test_forged_window_buffers_are_refused(tmp_path, where):
    est = _trained("SlidingWindowRLS")
    est.save_state(tmp_path / "s.npz")
    header, arrays = _raw(tmp_path / "s.npz")
    n, p, M = 3, 1, 8
    core = n * p + n * n + n
    S = arrays["state"].copy()
    pos = {"phi buffer": core + 3 + 5, "y buffer": core + 3 + M * n + 2,
           "theta0 copy": S.size - core, "D0 copy": S.size - 1}[where]
    S[pos] = np.nan if "copy" not in where or where == "theta0 copy" else -1.0
    arrays["state"] = S
    _refused(_write(tmp_path / "evil.npz", header, arrays), "inconsistent state")


@pytest.mark.parametrize("kind, key, value", [
    ("RLS", "forgetting", 1.5), ("RLS", "forgetting", 0.0), ("RLS", "forgetting", "NaN"),
    ("RLS", "P_max", -1.0), ("RLS", "windup_threshold", -1.0), ("RLS", "nan_policy", "ignore"),
    ("SlidingWindowRLS", "window", 2), ("KalmanRLS", "noise_var", 0.0),
    ("KalmanRLS", "noise_var", float("inf")),
])
def test_options_out_of_range_are_refused(tmp_path, kind, key, value):
    est = _trained(kind)
    est.save_state(tmp_path / "s.npz")
    header, arrays = _raw(tmp_path / "s.npz")
    header["options"][key] = float(value) if value == "NaN" else value
    _refused(_write(tmp_path / "evil.npz", header, arrays))


@pytest.mark.parametrize("name, value", [("theta0", np.inf), ("P0", np.nan),
                                         ("process_cov", np.inf)])
def test_non_finite_prior_is_refused(tmp_path, name, value):
    est = _trained("KalmanRLS")
    est.save_state(tmp_path / "s.npz")
    header, arrays = _raw(tmp_path / "s.npz")
    arrays[name] = arrays[name].copy()
    arrays[name].flat[0] = value
    _refused(_write(tmp_path / "evil.npz", header, arrays), name)


def test_forged_constrained_file_is_refused(tmp_path):
    est = ConstrainedRLS(4, C=[[1.0, 1.0, 0.0, 0.0]], d=[3.0])
    est.update([1.0, 0.0, 2.0, 1.0], 2.0)
    est.save_state(tmp_path / "c.npz")
    header, arrays = _raw(tmp_path / "c.npz")
    assert ConstrainedRLS.load_state(_write(tmp_path / "same.npz", header, arrays)).n_updates == 1
    for name, value in (("C", np.zeros((3000, 4))), ("outer_P0", np.zeros((4, 4, 4)))):
        a = dict(arrays, **{name: value})
        _refused(_write(tmp_path / "evil.npz", header, a), f"{name}.npy")
    h = json.loads(json.dumps(header))
    h["outer"]["n_params"] = 10 ** 6
    _refused(_write(tmp_path / "evil.npz", h, arrays), "n_params")
    S = arrays["state"].copy()
    S[0] = np.nan
    _refused(_write(tmp_path / "evil.npz", header, dict(arrays, state=S)), "inconsistent")


def test_cli_resume_of_a_forged_file_is_exit_2(tmp_path):
    """`adaptid fit --resume evil.npz --json` printed all-null estimates with exit 0."""
    rng = np.random.default_rng(4)
    Phi = rng.standard_normal((50, 2))
    y = Phi @ [1.0, 2.0]
    data = tmp_path / "d.csv"
    data.write_text("a,b,y\n" + "".join(f"{a!r},{b!r},{c!r}\n" for (a, b), c in zip(Phi, y)))
    est = RLS(2)
    est.run(Phi, y)
    est.save_state(tmp_path / "s.npz")
    header, arrays = _raw(tmp_path / "s.npz")
    arrays["state"] = arrays["state"].copy()
    arrays["state"][0] = np.inf
    evil = _write(tmp_path / "evil.npz", header, arrays)
    proc = subprocess.run([sys.executable, "-m", "adaptid", "fit", str(data), "--y", "y",
                           "--phi", "a,b", "--resume", str(evil), "--json"],
                          capture_output=True, text=True, cwd=tmp_path,
                          env=dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path)))
    assert proc.returncode == 2, (proc.returncode, proc.stderr)
    assert proc.stdout == ""
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("adaptid: error: --resume"), proc.stderr
    assert "inconsistent state" in lines[0] and "Traceback" not in proc.stderr


# ------------------------------------------------------------- format-2 files of f66d1cc
def _fixture_data(seed, N, n):
    """The data of tests/data/state_format2/make_fixtures.py (same seeds, same draws)."""
    rng = np.random.default_rng(seed)
    Phi = rng.standard_normal((N, n))
    return Phi, Phi @ np.arange(1.0, n + 1) + 0.1 * rng.standard_normal(N)


@pytest.mark.parametrize("name", ["rls", "window", "kalman", "constrained"])
def test_files_written_by_commit_f66d1cc_still_load(name):
    """Oracle: the current code run on the same data from the same options. Bitwise
    equality is not promised across versions (kernels were re-organised), so θ and P
    agree to 1e-12 relative; the counters exactly; and the loaded estimator continues."""
    path = FIXTURES / f"{name}.npz"
    loaded = adaptid.load_state(path)
    Phi, y = _fixture_data(1, 40, 3)
    if name == "rls":
        ref = RLS(3, forgetting=0.98, P0=100.0)
    elif name == "window":
        ref = SlidingWindowRLS(3, 9, forgetting=0.995)
    elif name == "kalman":
        ref = KalmanRLS(3, process_cov=np.diag([1e-3, 2e-3, 3e-4]), noise_var=0.3)
    else:
        Phi, y = _fixture_data(2, 30, 4)
        ref = ConstrainedRLS(4, C=[[1.0, 1.0, 0.0, 0.0]], d=[3.0], forgetting=0.99)
    ref.run(Phi, y)
    assert type(loaded) is type(ref) and loaded.n_updates == ref.n_updates == len(y)
    np.testing.assert_allclose(loaded.theta, ref.theta, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(loaded.P, ref.P, rtol=1e-12, atol=1e-16)
    t1, t2 = loaded.run(Phi[:5], y[:5]), ref.run(Phi[:5], y[:5])
    np.testing.assert_allclose(t1.theta, t2.theta, rtol=1e-12, atol=1e-14)


# ------------------------------------------------------------------ save_state
def test_save_keeps_permission_bits(tmp_path):
    path = tmp_path / "s.npz"
    est = _trained("RLS")
    est.save_state(path)
    for mode in (0o664, 0o640, 0o600, 0o644):
        os.chmod(path, mode)
        est.save_state(path)
        assert stat.S_IMODE(path.stat().st_mode) == mode


def test_new_file_gets_the_umask_mode(tmp_path):
    old = os.umask(0o027)
    try:
        _trained("RLS").save_state(tmp_path / "new.npz")
    finally:
        os.umask(old)
    # the umask is read from /proc/self/status (Linux >= 4.7); where that line is
    # missing the new file is private (0600, as mkstemp makes it), never wider
    try:
        with open("/proc/self/status") as fh:
            readable = any(line.startswith("Umask:") for line in fh)
    except OSError:
        readable = False
    want = 0o640 if readable else 0o600
    assert stat.S_IMODE((tmp_path / "new.npz").stat().st_mode) == want


def test_save_writes_through_a_symlink(tmp_path):
    real_dir = tmp_path / "real"
    real_dir.mkdir()
    target = real_dir / "state.npz"
    link = tmp_path / "link.npz"
    first, second = _trained("RLS", seed=1), _trained("RLS", seed=2)
    first.save_state(target)
    os.chmod(target, 0o644)
    link.symlink_to(target)
    second.save_state(link)
    assert link.is_symlink() and os.readlink(link) == str(target)   # the link stays
    np.testing.assert_array_equal(RLS.load_state(target).theta, second.theta)
    assert stat.S_IMODE(target.stat().st_mode) == 0o644
    assert sorted(p.name for p in real_dir.iterdir()) == ["state.npz"]   # no temp left
    # a dangling link: its target is created
    dangling = tmp_path / "dangling.npz"
    dangling.symlink_to(real_dir / "later.npz")
    first.save_state(dangling)
    np.testing.assert_array_equal(RLS.load_state(real_dir / "later.npz").theta, first.theta)


def test_orphan_temporary_files_are_removed(tmp_path):
    path = tmp_path / "s.npz"
    hour_ago = time.time() - 3600
    files = {
        ".s.npz.999999999-abcd1234.tmp": (None, False),      # its writer's pid does not run
        ".s.npz.abcd1234.tmp": (hour_ago, False),             # older adaptid, an hour old
        ".s.npz.zz99zz99.tmp": (None, True),                  # older adaptid, fresh: kept
        f".s.npz.{os.getpid()}-q1w2e3r4.tmp": (None, True),   # a live writer (us): kept
        f".s.npz.{os.getppid()}-q1w2e3r4.tmp": (None, True),  # a live writer: kept
        ".other.npz.999999999-abcd1234.tmp": (hour_ago, True),  # another target: kept
        ".s.npz.999999999-abcd1234.tmp.bak": (hour_ago, True),  # not our pattern: kept
        "s.npz.999999999-abcd1234.tmp": (hour_ago, True),       # not hidden: kept
    }
    for name, (mtime, _) in files.items():
        (tmp_path / name).write_bytes(b"x" * 1000)
        if mtime is not None:
            os.utime(tmp_path / name, (mtime, mtime))
    (tmp_path / ".s.npz.999999998-abcd1234.tmp").mkdir()    # a directory: kept
    _trained("RLS").save_state(path)
    left = {p.name for p in tmp_path.iterdir()}
    for name, (_, kept) in files.items():
        assert (name in left) == kept, name
    assert ".s.npz.999999998-abcd1234.tmp" in left and "s.npz" in left


def test_load_state_time_of_a_normal_file_is_unchanged_by_the_checks(tmp_path):
    """A control for the bounds above: a real (large) state file within the limits loads."""
    est = SlidingWindowRLS(3, 20_000)
    rng = np.random.default_rng(0)
    Phi = rng.standard_normal((100, 3))
    est.run(Phi, Phi @ [1.0, 2.0, 3.0])
    est.save_state(tmp_path / "w.npz")
    back = SlidingWindowRLS.load_state(tmp_path / "w.npz")
    assert back.get_state()["state"].tobytes() == est.get_state()["state"].tobytes()


def test_huge_zip_directory_is_refused_before_parsing(tmp_path):
    """100 000 tiny members: zipfile would build 100 000 entries from the directory; the
    end record's count and size are checked first."""
    path = tmp_path / "many.npz"
    with zipfile.ZipFile(path, "w") as zf:
        for i in range(100_000):
            zf.writestr(f"m{i}.npy", b"")
    assert path.stat().st_size > 5 * 2 ** 20
    _bounded(lambda: _refused(path, "members"), seconds=5, megabytes=2)
