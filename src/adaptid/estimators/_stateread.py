r"""Reading a state file as untrusted input: bounded, step by step, never pickle.

The order is what bounds time and memory (see :mod:`._statefile` for the format):

1. The path must name a regular file (a FIFO, a device such as ``/dev/zero``,
   a directory are refused without being read; the file is opened with
   ``O_NONBLOCK`` and checked with ``fstat``, so a FIFO never blocks).
2. The zip's end record is checked (at most :data:`MAX_MEMBERS` members in
   :data:`MAX_DIRECTORY_BYTES`) before the directory it points to is read; then
   the directory: each member ``<name>.npy``, once, stored or deflated, not
   encrypted.
3. ``header.npy`` is read with a cap of :data:`MAX_HEADER_BYTES` and its JSON
   parsed (a nesting too deep for the parser is refused, not a RecursionError).
4. The header's sizes are checked against fixed limits (:data:`MAX_PARAMS`,
   :data:`MAX_OUTPUTS`, :data:`MAX_WINDOW`, :data:`MAX_BATCH`,
   :data:`MAX_ARRAY_BYTES`) and give every array's exact shape; each member's
   declared uncompressed size and its ``.npy`` preamble (parsed with
   :mod:`numpy.lib.format`, dtype float64 only) must match that shape *before*
   its data are inflated, and at most that many bytes are read.
5. After the checksum, the content is validated (:func:`check_content`):
   θ, the window buffers and the prior finite, U unit upper triangular,
   D > 0 and finite. The options and the prior are then validated by the
   estimator's own constructor.
"""

from __future__ import annotations

import json
import os
import stat
import struct
import zipfile

import numpy as np
import numpy.lib.format as npy_format

from .._exceptions import StateFileError

#: Largest number of parameters a state file may declare (P is n × n float64:
#: 32 MiB at the limit; the prior is factorised when the file is read).
MAX_PARAMS = 2048
#: Largest number of outputs p.
MAX_OUTPUTS = 1024
#: Largest sliding window M.
MAX_WINDOW = 100_000_000
#: Largest batch B (streams of ``run_batched``).
MAX_BATCH = 10_000_000
#: Largest total size of the arrays a header may declare (bytes).
MAX_ARRAY_BYTES = 2 ** 31
#: Largest ``header.npy`` member (bytes, uncompressed).
MAX_HEADER_BYTES = 2 ** 20
#: Largest number of members of the archive.
MAX_MEMBERS = 16
#: Room for a ``.npy`` preamble (magic, version, dict) in front of the data.
_NPY_PREAMBLE_MAX = 4096
CORE_KINDS = ("RLS", "SlidingWindowRLS", "KalmanRLS", "LMS", "NLMS", "FastRLS")
#: gradient estimators: the state is θ alone, no P0 (no covariance)
GRADIENT_KINDS = ("LMS", "NLMS")


def refuse(path, what):
    raise StateFileError(f"{path}: {what}")


def open_regular(path):
    """A binary file object on ``path`` if it is a regular file; else StateFileError."""
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0)
    try:
        fd = os.open(path, flags)
    except OSError as err:
        raise StateFileError(f"path {str(path)!r} cannot be read: {err.strerror or err}") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            refuse(path, "not a regular file (a FIFO, device, socket or directory is "
                   "never read as a state file)")
        if st.st_size > MAX_ARRAY_BYTES + MAX_HEADER_BYTES + 2 ** 20:
            refuse(path, f"{st.st_size} bytes is larger than any state file adaptid reads "
                   f"({MAX_ARRAY_BYTES} bytes of arrays)")
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


#: Largest zip directory read (bytes): MAX_MEMBERS entries with short names.
MAX_DIRECTORY_BYTES = 2 ** 16


def check_end_record(path, fh):
    """Check the zip's end record before ``zipfile`` reads the directory it points to.

    The directory's declared size and entry count must fit :data:`MAX_DIRECTORY_BYTES`
    and :data:`MAX_MEMBERS` (``zipfile`` would read and parse all of it, whatever its
    size). The record is found as ``zipfile`` finds it: the last signature in the
    final 64 KiB + 22 bytes (APPNOTE 4.3.16).
    """
    size = os.fstat(fh.fileno()).st_size
    tail = min(size, 22 + 65535)
    fh.seek(size - tail)
    data = fh.read(tail)
    fh.seek(0)
    at = data.rfind(b"PK\x05\x06")
    if at < 0 or len(data) - at < 22:
        refuse(path, "truncated or corrupted state file (not a zip archive)")
    entries, size_cd = struct.unpack("<HL", data[at + 10: at + 16])
    if entries > MAX_MEMBERS or size_cd > MAX_DIRECTORY_BYTES:
        refuse(path, f"the zip directory declares {entries} members in {size_cd} bytes "
               f"(a state file has at most {MAX_MEMBERS} members)")


def directory(path, zf):
    """{member name without .npy: ZipInfo}, after checking the zip's directory."""
    infos = zf.infolist()
    if len(infos) > MAX_MEMBERS:
        refuse(path, f"{len(infos)} members (a state file has at most {MAX_MEMBERS})")
    out = {}
    for info in infos:
        name = info.filename
        if not name.endswith(".npy") or name[:-4] in out:
            refuse(path, f"unexpected or repeated member {name[:60]!r}")
        if info.flag_bits & 0x1:
            refuse(path, f"member {name!r} is encrypted")
        if info.compress_type not in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED):
            refuse(path, f"member {name!r} uses compression method {info.compress_type} "
                   "(only stored or deflated members are read)")
        if info.compress_type == zipfile.ZIP_STORED and info.compress_size != info.file_size:
            refuse(path, f"member {name!r}: stored with two different sizes")
        out[name[:-4]] = info
    if "header" not in out:
        refuse(path, "not an adaptid state file (no header)")
    return out


def read_member(path, zf, info, shape_ok, max_bytes, dtype):
    """Read one ``.npy`` member, checking its preamble before reading its data.

    ``shape_ok(shape)`` says whether a declared shape is acceptable; at most
    ``max_bytes`` of data are ever read.
    """
    name = info.filename
    if info.file_size > max_bytes + _NPY_PREAMBLE_MAX:
        refuse(path, f"member {name!r} declares {info.file_size} bytes, more than its "
               f"header allows ({max_bytes})")
    with zf.open(info) as fh:
        try:
            version = npy_format.read_magic(fh)
            if version == (1, 0):
                shape, fortran, dt = npy_format.read_array_header_1_0(fh)
            elif version == (2, 0):
                shape, fortran, dt = npy_format.read_array_header_2_0(fh)
            else:
                raise ValueError(f"npy version {version} is not read")
        except (ValueError, SyntaxError, TypeError, OverflowError, EOFError) as err:
            refuse(path, f"member {name!r} is not a .npy array ({err})")
        if dt != dtype or dt.hasobject:
            refuse(path, f"member {name!r} has dtype {dt}, expected {dtype}")
        if not isinstance(shape, tuple) or not shape_ok(shape):
            refuse(path, f"member {name!r} has shape {shape}, which does not match the header")
        nbytes = int(np.prod(shape, dtype=np.int64)) * dt.itemsize
        if nbytes > max_bytes:
            refuse(path, f"member {name!r} declares {nbytes} bytes, more than allowed ({max_bytes})")
        data = fh.read(nbytes)
        if len(data) != nbytes or fh.read(1):
            refuse(path, f"member {name!r} is truncated or has trailing data")
    arr = np.frombuffer(data, dtype=dt).reshape(shape, order="F" if fortran else "C")
    return np.array(arr, order="C")  # writable, C-contiguous copy


def parse_header(path, zf, info):
    """The JSON header as a dict (size-capped, depth errors refused)."""
    raw = read_member(path, zf, info, lambda s: len(s) == 1, MAX_HEADER_BYTES,
                      np.dtype(np.uint8))
    try:
        header = json.loads(raw.tobytes().decode("utf-8"))
    except (ValueError, UnicodeDecodeError, RecursionError) as err:
        refuse(path, f"corrupted header ({type(err).__name__}: {str(err)[:80]})")
    if not isinstance(header, dict):
        refuse(path, "corrupted header (header is not an object)")
    return header


def _int(path, header, key, low, high):
    v = header.get(key)
    if type(v) is not int or not low <= v <= high:
        refuse(path, f"header field {key!r} must be an integer in [{low}, {high}], got {v!r:.40}")
    return v


def core_layout(path, header, kind):
    """{array name: exact shape} of a core estimator, from its checked header."""
    n = _int(path, header, "n_params", 1, MAX_PARAMS)
    p = _int(path, header, "n_outputs", 1, MAX_OUTPUTS)
    single = header.get("single_output")
    if type(single) is not bool or (single and p != 1):
        refuse(path, f"header field 'single_output' must be a boolean (true only with one "
               f"output), got {single!r:.40}")
    batch = header.get("batch")
    if batch is not None:
        batch = _int(path, header, "batch", 1, MAX_BATCH)
    for key in ("n_updates", "n_skipped"):
        _int(path, header, key, 0, 2 ** 63 - 1)
    opts = header.get("options")
    if not isinstance(opts, dict):
        refuse(path, f"header field 'options' must be an object, got {type(opts).__name__}")
    if kind in GRADIENT_KINDS:
        return {"theta0": (n, p), "state": (n * p,) if batch is None else (batch, n * p)}
    if kind == "FastRLS":  # the delay-line filter: its own layout (estimators/_fastrls.py)
        from ._fastlayout import state_length
        L = state_length(opts, n)
        return {"theta0": (n, 1), "state": (L,) if batch is None else (batch, L)}
    L = n * p + n * n + n
    if kind == "SlidingWindowRLS":
        M = _int(path, opts, "window", n, MAX_WINDOW)
        L = 2 * L + 3 + M * (n + p + 2)
    P0 = opts.get("P0")
    if P0 is not None and P0 != "diffuse":
        refuse(path, f"header option 'P0' must be 'diffuse' when present, got {P0!r:.40}")
    L += diffuse_tail(kind, n, p) if P0 == "diffuse" else 0
    shapes = {"theta0": (n, p), "state": (L,) if batch is None else (batch, L)}
    if P0 is None:
        shapes["P0"] = (n, n)
    if kind == "KalmanRLS":
        shapes["process_cov"] = (n, n)
    total = sum(8 * int(np.prod(s, dtype=np.float64)) for s in shapes.values())
    if total > MAX_ARRAY_BYTES:
        refuse(path, f"the header declares {total} bytes of arrays, more than any state "
               f"file adaptid reads ({MAX_ARRAY_BYTES})")
    return shapes


def outer_layout(path, header, n_inner, own_names):
    """{name: (shape check, byte cap)} of a wrapping estimator's own arrays: ndim ≤ 2,
    each side ≤ its n_params."""
    outer = header.get("outer")
    if not isinstance(outer, dict):
        refuse(path, "header field 'outer' must be an object")
    m = _int(path, outer, "n_params", n_inner, MAX_PARAMS)
    return {name: ((lambda s, m=m: len(s) <= 2 and all(0 <= d <= m for d in s)), 8 * m * m)
            for name in own_names}


def _unit_upper_ok(Ucols, n):
    """Rows of U stored by columns (U.T raveled): unit diagonal, zero below, finite."""
    U = np.swapaxes(Ucols.reshape(-1, n, n), -1, -2)
    i, j = np.indices((n, n))
    return (np.all(U[:, i == j] == 1.0, axis=1) & np.all(U[:, i > j] == 0.0, axis=1)
            & np.all(np.isfinite(U), axis=(1, 2)))


def _factor_ok(S, o, n, p):
    """θ finite, U unit upper, D finite and > 0 for the block of rows S starting at o."""
    th = S[:, o: o + n * p]
    U = S[:, o + n * p: o + n * p + n * n]
    D = S[:, o + n * p + n * n: o + n * p + n * n + n]
    return (np.all(np.isfinite(th), axis=1) & _unit_upper_ok(U, n)
            & np.all(np.isfinite(D) & (D > 0), axis=1))


#: Relative tolerance of the symmetry and definiteness checks of a loaded P (the
#: covariance form symmetrises each update; rounding stays far below this).
SYM_RTOL = 1e-8


def _sym_psd(M, *, definite, ref=0.0):
    """Per row of M (rows, n, n): symmetric and positive (semi-)definite, to SYM_RTOL.

    The tolerance is relative to max(|M|, ``ref``): P∞ of the diffuse start
    goes from I to rounding-level zeros, judged against its start (ref 1).
    """
    scale = np.maximum(np.max(np.abs(M), axis=(1, 2)), ref)
    n = M.shape[-1]
    sym = np.max(np.abs(M - M.swapaxes(1, 2)), axis=(1, 2)) <= SYM_RTOL * scale
    ok = sym.copy()
    if ok.any():
        lam = np.linalg.eigvalsh(0.5 * (M[ok] + M[ok].swapaxes(1, 2)))
        floor = -SYM_RTOL * n * scale[ok]
        ok[ok] = lam[:, 0] >= floor if not definite else (
            (lam[:, 0] > 0) & np.all(np.diagonal(M[ok], axis1=1, axis2=2) > 0, axis=1))
    return ok


def _form_ok(S, form, n, p):
    """The covariance block of RLS's ``form="covariance"`` (P) or ``"sqrt"`` (S, P = S Sᵀ).

    P must be symmetric positive definite (P = 0, −I or an asymmetric P are
    refused); S of full rank (S = 0 refused); the block's last n entries zero.
    """
    o = n * p
    M = S[:, o:o + n * n].reshape(-1, n, n).swapaxes(1, 2)  # stored by columns
    zeros = np.all(S[:, o + n * n:o + n * n + n] == 0.0, axis=1)
    if form == "covariance":
        return zeros & _sym_psd(M, definite=True)
    sv = np.linalg.svd(M, compute_uv=False)
    return zeros & (sv[:, -1] > np.finfo(float).tiny) & (sv[:, -1] > 1e-300 * sv[:, 0])


def _tail_ok(kind, T, n):
    """The exact diffuse start's tail (see :func:`diffuse_tail`), its flag already checked."""
    if kind == "RLS":  # [flag, R (n·n, by rows, upper triangular, diag ≥ 0), z]
        R = T[:, 1:1 + n * n].reshape(-1, n, n)
        low = np.tril(np.ones((n, n), bool), -1)
        return (np.all(R[:, low] == 0.0, axis=1)
                & np.all(np.diagonal(R, axis1=1, axis2=2) >= 0.0, axis=1))
    if kind == "KalmanRLS":  # [flag, rank steps, P∞ (n·n), P* (n·n)]
        steps = T[:, 1]
        ok = (steps == np.round(steps)) & (steps >= 0) & (steps <= n)
        Pinf = T[:, 2:2 + n * n].reshape(-1, n, n)
        Pst = T[:, 2 + n * n:2 + 2 * n * n].reshape(-1, n, n)
        return ok & _sym_psd(Pinf, definite=False, ref=1.0) & _sym_psd(Pst, definite=False)
    return np.ones(T.shape[0], bool)  # the window's [flag, stop]: scratch, any finite value


def diffuse_tail(kind, n, p):
    """Length of the diffuse tail of a ``P0="diffuse"`` state (see ``_kernels.recursions._diffuse``)."""
    return {"RLS": 1 + n * n + n * p, "SlidingWindowRLS": 2,
            "KalmanRLS": 2 + 2 * n * n}.get(kind, 0)


def check_content(path, kind, header, arrays):
    """Refuse values no saved estimator holds (after the checksum: forged, not damaged)."""
    n, p = header["n_params"], header["n_outputs"]
    tail = diffuse_tail(kind, n, p) if header["options"].get("P0") == "diffuse" else 0
    for name in ("theta0", "P0", "process_cov"):
        if name in arrays and not np.all(np.isfinite(arrays[name])):
            refuse(path, f"array {name!r} holds NaN or inf")
    S = arrays["state"].reshape(-1, arrays["state"].shape[-1])
    form = header["options"].get("form", "ud") if kind == "RLS" else "ud"
    for what, ok in _content_checks(kind, form, S, n, p, tail):
        if not ok.all():
            row = int(np.flatnonzero(~ok)[0])
            refuse(path, f"inconsistent state{' (stream %d)' % row if S.shape[0] > 1 else ''}:"
                   f" {what}")


def _content_checks(kind, form, S, n, p, tail):
    """(what must hold, per-row verdict) in order; later ones assume the earlier hold."""
    if kind in GRADIENT_KINDS + ("FastRLS",):  # FastRLS: its own checks (_fastlayout)
        yield "θ must be finite", np.all(np.isfinite(S), axis=1)
        return
    if form == "ud":
        yield "θ must be finite, U unit upper triangular, D finite and > 0", _factor_ok(S, 0, n, p)
    else:
        yield "θ and the covariance block must be finite", np.all(np.isfinite(S), axis=1)
        yield ("P must be symmetric positive definite" if form == "covariance" else
               "the square root S of P must have full rank"), _form_ok(S, form, n, p)
    if kind == "SlidingWindowRLS":
        core = n * p + n * n + n
        yield ("the window buffers must be finite and the prior's U, D valid",
               np.all(np.isfinite(S[:, core:-core]), axis=1)
               & _factor_ok(S, S.shape[1] - core - tail, n, p))
    if tail:
        T = S[:, S.shape[1] - tail:]
        yield ("the diffuse start's flag must be 0 or 1 and its tail finite",
               np.isin(T[:, 0], (0.0, 1.0)) & np.all(np.isfinite(T), axis=1))
        yield ("the diffuse start's R must be upper triangular with a non-negative diagonal"
               if kind == "RLS" else "the diffuse start's rank-step count must be an integer "
               "in 0…n and its P∞, P* symmetric positive semi-definite"), _tail_ok(kind, T, n)
