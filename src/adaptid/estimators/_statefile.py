r"""Estimator state: dict round trip and safe, versioned state files.

File format (version 2)
-----------------------
A NumPy ``.npz`` archive read with ``allow_pickle=False`` holding

* ``header`` — UTF-8 JSON as a uint8 array: ``{"magic": "adaptid-state",
  "format": 2, "estimator": <class name>, "n_params", "n_outputs",
  "single_output", "options", "batch", "n_updates", "n_skipped",
  "adaptid_version", "checksum"}``;
* ``theta0``, ``P0``, ``state`` and, for KalmanRLS, ``process_cov`` — float64.

An estimator that wraps a core one (e.g. :class:`~adaptid.constrained.ConstrainedRLS`,
whose ``get_state()`` has an ``"inner"`` core state) is stored as its inner
estimator (the fields above, with ``"inner_estimator"``), plus its own
``"estimator"`` name and ``"outer": {"n_params", "format", "options"}`` in the
header and the arrays its class names in ``_STATE_FILE_ARRAYS``. Reading
rebuilds it through that class's ``from_state``. Which class reads a file is
looked up by name in a registry (:func:`register_state_class`): this module
knows the container format and nothing of the classes.

``checksum`` is the SHA-256 of the header without the checksum (canonical
JSON, sorted keys) followed by the raw bytes, dtype and shape of every array
in name order.

Writing
-------
The file is written to a temporary name ``.<name>.<pid>-<random>.tmp`` in the
same folder, flushed and fsync'ed, then renamed over the target, so a reader
sees the old file or the new one, never half of one. The new file keeps the
permission bits of the file it replaces (a new file gets ``0666`` minus the
umask, as ``open`` would give it). A ``path`` that is a symbolic link is
followed: the link's final target is replaced and the link itself stays (the
temporary file is made next to the target). After a successful save, the
temporary files that killed earlier saves of the same target left behind are
removed: only names of this pattern for this target, regular files owned by
the current user, and only if older than ten minutes (:data:`ORPHAN_AGE`) or
if the process that was writing them no longer runs on this machine (see
:func:`remove_orphans`).

Reading
-------
The file is untrusted input, read by :mod:`._stateread` in an order that
bounds memory and time by what the header declares: only a regular file is
opened (never a FIFO or a device), the zip directory and the header are read
first, the header's sizes are checked against fixed limits and give every
array's exact shape, each member's declared size and ``.npy`` preamble are
checked before its data are inflated, then the checksum, then the content
(θ finite, U unit upper triangular, D > 0 and finite, window buffers finite)
and finally the options and the prior through the estimator's own
constructor. Any failure raises :class:`~adaptid.StateFileError` (a
``ValueError``). Pickle is never used (only float64 and uint8 ``.npy``
members are read).
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import re
import stat
import tempfile
import time
import zipfile
from pathlib import Path

import numpy as np

from .._exceptions import StateFileError
from .._validation import param_error
from . import _stateread as _sr

FORMAT = 2  # 2: U stored by columns in the state vector (1: by rows; not read)
_MAGIC = "adaptid-state"
_ARRAYS = ("theta0", "P0", "state", "process_cov")  # the arrays of a core estimator
# An estimator that wraps a core one (its get_state() dict has "inner") is
# stored as the inner estimator plus its own arrays; its class names them in
# ``_STATE_FILE_ARRAYS`` ({key of its state dict: array name in the file}).


#: name in a state file -> the class that reads it (``from_state``). Classes
#: register themselves (:func:`register_state_class`); a name not registered
#: yet is looked up in the module that defines it, by name, on first use.
_REGISTRY: dict = {}
_DEFINED_IN = {"RLS": "adaptid.estimators", "SlidingWindowRLS": "adaptid.estimators",
               "KalmanRLS": "adaptid.estimators", "LMS": "adaptid.estimators",
               "NLMS": "adaptid.estimators", "ConstrainedRLS": "adaptid.constrained",
               "RecursiveARX": "adaptid.models.streaming",
               "RecursiveAR": "adaptid.models.streaming",
               "RecursiveIV": "adaptid.models.iv",
               "RecursiveNARX": "adaptid.models.nonlinear",
               "FastRLS": "adaptid.estimators"}


def register_state_class(name: str, cls) -> None:
    """Make ``load_state`` build files whose header names ``name`` with ``cls.from_state``."""
    _REGISTRY[name] = cls


def _lookup(name):
    if name not in _REGISTRY and name in _DEFINED_IN:
        import importlib
        importlib.import_module(_DEFINED_IN[name])  # registers its classes
    return _REGISTRY.get(name)


def _classes():
    return {k: _lookup(k) for k in ("RLS", "SlidingWindowRLS", "KalmanRLS", "LMS", "NLMS",
                                    "FastRLS")}


def estimator_from_state(state: dict):
    """Build an estimator from a :meth:`get_state` dict (exact round trip)."""
    from .._validation import param_error
    try:
        kind = state["estimator"]
        fmt = state["format"]
        cls = _classes()[kind]
    except (KeyError, TypeError):
        raise param_error("state", "a dict from get_state() naming a known estimator",
                          "<a dict without a valid 'estimator'>") from None
    if fmt != FORMAT:
        raise param_error("state['format']", f"{FORMAT}", fmt)
    try:
        return _build(cls, kind, state)
    except (KeyError, IndexError, AttributeError) as err:
        raise param_error("state", "a complete dict from get_state()",
                          f"<{type(err).__name__}: {err}>") from None


def _build(cls, kind, state):
    opts = state["options"]
    if not isinstance(opts, dict):
        raise TypeError(f"state['options'] must be a dict, got {type(opts).__name__}")
    opts = dict(opts)
    if kind == "RLS":
        opts.setdefault("form", "ud")  # states written before RLS had forms hold U-D factors
    theta0 = np.asarray(state["theta0"])
    if theta0.ndim != 2:
        raise ValueError(f"state['theta0'] must be 2-dimensional (n, p), got shape {theta0.shape}")
    kwargs = dict(theta0=theta0 if not state["single_output"] else theta0[:, 0], **opts)
    if getattr(getattr(cls, "spec", None), "covariance", True) and "P0" not in kwargs:
        kwargs["P0"] = np.asarray(state["P0"])  # diffuse: P0="diffuse" is an option
    if not state["single_output"]:
        kwargs["n_outputs"] = int(state["n_outputs"])
    if kind == "SlidingWindowRLS":
        window = kwargs.pop("window")
        est = cls(int(state["n_params"]), window, **kwargs)
    else:
        est = cls(int(state["n_params"]), **kwargs)
    # the prior is restored verbatim (not re-validated through a round trip)
    est.theta0 = np.array(state["theta0"], dtype=np.float64).reshape(est.theta0.shape)
    est._set_state(state["state"], state["batch"], state["n_updates"], state["n_skipped"])
    return est


def _digest(header: dict, arrays: dict) -> str:
    h = hashlib.sha256()
    h.update(json.dumps(header, sort_keys=True, separators=(",", ":")).encode())
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(name.encode())
        h.update(str(a.dtype).encode())
        h.update(repr(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()


def _payload(st: dict):
    """(header, arrays) of a get_state() dict; the header without checksum."""
    from .. import __version__
    if "inner" in st:
        header, arrays = _payload(st["inner"])
        header["inner_estimator"] = header["estimator"]
        header["estimator"] = st["estimator"]
        header["outer"] = {"n_params": st["n_params"], "format": st["format"],
                           "options": dict(st["options"])}
        names = _lookup(st["estimator"])._STATE_FILE_ARRAYS
        arrays.update({names[key]: st[key] for key in names})
        return header, arrays
    opts = dict(st["options"])
    arrays = {"theta0": st["theta0"], "state": st["state"]}
    if st["P0"] is not None:  # None: a gradient estimator (LMS, NLMS)
        arrays["P0"] = st["P0"]
    if "process_cov" in opts:
        arrays["process_cov"] = np.asarray(opts.pop("process_cov"))
    header = {
        "magic": _MAGIC, "format": FORMAT, "estimator": st["estimator"],
        "n_params": st["n_params"], "n_outputs": st["n_outputs"],
        "single_output": st["single_output"], "options": opts, "batch": st["batch"],
        "n_updates": st["n_updates"], "n_skipped": st["n_skipped"],
        "adaptid_version": __version__,
    }
    return header, arrays


#: Temporary files of :func:`save_state`: ``.<name>.<pid>-<random>.tmp`` (the pid of
#: the writer; files of adaptid before it had none: ``.<name>.<random>.tmp``).
_TMP_RE = r"\.{name}\.(?:(\d+)-)?[a-z0-9_]{{8}}\.tmp"
#: A temporary file older than this (seconds) is an orphan of a killed save.
ORPHAN_AGE = 600.0


def _target(path: Path) -> Path:
    """The file a save replaces: a symlink's final target (the link itself stays)."""
    if path.is_symlink():
        return Path(os.path.realpath(path))
    return path


def special_kind(path) -> str | None:
    """What ``path`` is if it exists and is not a regular file (following a
    symlink): "a directory", "a FIFO", "a character device", ...; else None."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return None
    for test, kind in ((stat.S_ISREG, None), (stat.S_ISDIR, "a directory"),
                       (stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return kind
    return "not a regular file"


def _new_mode(target: Path) -> int:
    """Permission bits for the new file: the old file's, else 0666 minus the umask."""
    try:
        return stat.S_IMODE(os.stat(target).st_mode)
    except OSError:
        pass
    try:  # the umask, without changing it (os.umask would race with other threads)
        with open("/proc/self/status") as fh:
            umask = next(int(line.split()[1], 8) for line in fh if line.startswith("Umask:"))
    except (OSError, StopIteration, ValueError, IndexError):
        umask = 0o077  # unknown: as private as mkstemp's file
    return 0o666 & ~umask


def _pid_running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # PermissionError: it exists (another user's)
        return True
    return True


def remove_orphans(target: Path, now=None) -> list:
    """Delete temporary files that killed earlier saves of ``target`` left behind.

    A file is removed only if its name is one of ours for this target
    (``.<name>.<pid>-<8 chars>.tmp``, or ``.<name>.<8 chars>.tmp`` of older
    adaptid), it is a regular file owned by the current user, and it is older
    than :data:`ORPHAN_AGE` or the process that was writing it (``pid``) no
    longer runs on this machine. Returns the names removed.
    """
    folder = target.parent
    pattern = re.compile(_TMP_RE.format(name=re.escape(target.name)))
    now = time.time() if now is None else now
    removed = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for entry in entries:
        m = pattern.fullmatch(entry.name)
        if m is None:
            continue
        try:
            st = entry.stat(follow_symlinks=False)
            if not stat.S_ISREG(st.st_mode) or st.st_uid != os.getuid():
                continue
            pid = int(m.group(1)) if m.group(1) else None
            dead = pid is not None and pid != os.getpid() and not _pid_running(pid)
            if dead or now - st.st_mtime > ORPHAN_AGE:
                os.unlink(entry.path)
                removed.append(entry.name)
        except OSError:
            continue
    return removed


def _state_path(path, exc=ValueError) -> Path:
    """``path`` as a Path, refusing what no file system takes (a NUL byte)."""
    try:
        raw = os.fspath(path)
    except TypeError:
        raise param_error("path", "a str or os.PathLike file name", path,
                          exc=TypeError) from None
    if ("\0" if isinstance(raw, str) else b"\0") in raw:
        raise param_error("path", "a file name without NUL bytes", path, exc=exc)
    return Path(os.fsdecode(raw))


def check_labels(labels, exc=ValueError, where="labels"):
    """Validate the optional ``labels`` of a state file: what the numbers mean.

    A flat JSON object whose keys are short strings and whose values are
    strings or lists of strings (the command line stores the model
    structure, the output and the regressor names there, and refuses to
    resume a state under other ones). Returns a plain ``dict``.
    """
    def bad(what):
        raise exc(f"{where} must be a dict of short strings or lists of strings ({what})")

    if not isinstance(labels, dict) or len(labels) > _MAX_LABELS:
        bad("not a dict" if not isinstance(labels, dict) else "too many keys")
    out = {}
    for key, value in labels.items():
        if not isinstance(key, str) or len(key) > _MAX_LABEL_CHARS:
            bad(f"key {str(key)[:40]!r}")
        if isinstance(value, str):
            items = [value]
        elif isinstance(value, (list, tuple)) and len(value) <= _MAX_LABEL_ITEMS:
            items = list(value)
        else:
            bad(f"value of {key!r}")
        if not all(isinstance(v, str) and len(v) <= _MAX_LABEL_CHARS for v in items):
            bad(f"value of {key!r}")
        out[key] = value if isinstance(value, str) else list(items)
    return out


#: Bounds of the labels a state file may carry (JSON in the header).
_MAX_LABELS, _MAX_LABEL_ITEMS, _MAX_LABEL_CHARS = 16, 4096, 256


def _check_savable(est, header, arrays) -> None:
    """Nothing is saved that :func:`load_state` would refuse (sizes, values)."""
    core = header.get("inner_estimator", header["estimator"])
    try:
        _sr.core_layout("state", dict(header), core)
        _sr.check_content("state", core, header, arrays)
    except StateFileError as err:
        raise ValueError(f"the {type(est).__name__} cannot be saved: load_state would refuse "
                         f"its {str(err)}") from None


def save_state(est, path, *, labels=None) -> None:
    """Write ``est.get_state()`` to ``path`` atomically (see module docstring).

    ``labels`` (optional, see :func:`check_labels`) is stored in the header,
    under the checksum; :func:`load_state_labelled` returns it.
    """
    header, arrays = _payload(est.get_state())
    _check_savable(est, header, arrays)
    if labels is not None:
        header["labels"] = check_labels(labels)
    header["checksum"] = _digest(header, arrays)
    buf = io.BytesIO()
    np.savez(buf, header=np.frombuffer(json.dumps(header).encode(), dtype=np.uint8), **arrays)
    target = _target(_state_path(path))
    kind = special_kind(target)
    if kind is not None:
        raise ValueError(f"path must be a regular file or a new name, got {str(path)!r} "
                         f"({kind}: a save would replace it)")
    folder = target.parent if str(target.parent) else Path(".")
    mode = _new_mode(target)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.{os.getpid()}-", suffix=".tmp",
                               dir=folder)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(buf.getvalue())
            fh.flush()
            os.fchmod(fh.fileno(), mode)
            os.fsync(fh.fileno())
        os.replace(tmp, target)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    remove_orphans(folder / target.name)


def load_state(path):
    """Read a state file written by any estimator's ``save_state``.

    Parameters
    ----------
    path : str or os.PathLike
        The file: a regular file (or a symlink to one).

    Returns
    -------
    RLS, SlidingWindowRLS, KalmanRLS or ConstrainedRLS
        The estimator, exactly as it was saved: continuing it gives bit for
        bit the results of the uninterrupted run.

    Raises
    ------
    StateFileError
        (a ``ValueError``) on any damage or mismatch: not a regular file,
        unreadable, truncated, not an adaptid state file, a newer format,
        sizes beyond the limits of :mod:`adaptid.estimators._stateread`, a
        checksum mismatch, an unknown estimator type, values no estimator
        holds (NaN in θ, D ≤ 0, ...) or options out of range. Nothing is
        unpickled, and memory stays bounded by what the header declares.

    See Also
    --------
    RLS.load_state : the same, refusing a file of another estimator type.
    """
    return load_state_labelled(path)[0]


def load_state_labelled(path):
    """``(estimator, labels)`` of a state file; ``labels`` is None when it has none.

    See :func:`load_state`; the labels are checked as :func:`check_labels`
    does (a :class:`StateFileError` otherwise).
    """
    path = _state_path(path, StateFileError)
    with _sr.open_regular(path) as fh:
        try:
            _sr.check_end_record(path, fh)
            with zipfile.ZipFile(fh) as zf:
                header, arrays, cls, own = _read_archive(path, zf)
        except StateFileError:
            raise
        except Exception as err:  # noqa: BLE001 - a damaged zip raises anything
            # (BadZipFile, NotImplementedError, RuntimeError "encrypted", zlib.error,
            # EOFError, ...): all of it means a truncated or corrupted file
            raise StateFileError(f"{path}: truncated or corrupted state file "
                                 f"({type(err).__name__}: {str(err)[:120]})") from None
    labels = header.pop("labels", None)
    if labels is not None:
        labels = check_labels(labels, StateFileError, f"{path}: labels")
    try:
        return _build_from_file(header, arrays, cls, own), labels
    except StateFileError:
        raise
    except Exception as err:  # noqa: BLE001 - the constructors validate the options
        raise StateFileError(f"{path}: inconsistent state ({type(err).__name__}: "
                             f"{str(err)[:200]})") from None


def _check_kind(path, header):
    """(class that reads the file, its own arrays {key: name}, core kind)."""
    if header.get("magic") != _MAGIC:
        _sr.refuse(path, "not an adaptid state file")
    fmt = header.get("format")
    if type(fmt) is not int or fmt > FORMAT:
        _sr.refuse(path, f"state format {fmt!r:.40} is newer than this adaptid supports "
                   f"({FORMAT}); upgrade adaptid")
    if fmt != FORMAT:
        _sr.refuse(path, f"unknown state format {fmt!r}")
    kind = header.get("estimator")
    cls = _lookup(kind) if isinstance(kind, str) else None
    wrapped = "inner_estimator" in header
    own = getattr(cls, "_STATE_FILE_ARRAYS", None) if wrapped else {}
    core = header.get("inner_estimator") if wrapped else kind
    if cls is None or own is None or core not in _sr.CORE_KINDS or (wrapped and not own):
        _sr.refuse(path, f"unknown estimator type {kind!r:.60}")
    return cls, own, core


def _read_archive(path, zf):
    """(header without checksum, arrays, class, own arrays), every size checked first."""
    members = _sr.directory(path, zf)
    header = _sr.parse_header(path, zf, members.pop("header"))
    cls, own, core = _check_kind(path, header)
    shapes = _sr.core_layout(path, header, core)
    bounds = {name: ((lambda s, want=want: s == want), 8 * int(np.prod(want)))
              for name, want in shapes.items()}
    if own:
        bounds.update(_sr.outer_layout(path, header, header["n_params"], own.values()))
    unexpected = sorted(set(members) - set(bounds))
    missing = sorted(set(bounds) - set(members))
    if unexpected or missing:
        _sr.refuse(path, f"unexpected arrays {unexpected[:8]}" if unexpected
                   else f"missing arrays {missing}")
    arrays = {name: _sr.read_member(path, zf, info, *bounds[name], np.dtype(np.float64))
              for name, info in members.items()}
    checksum = header.pop("checksum", None)
    if checksum != _digest(header, arrays):
        _sr.refuse(path, "checksum mismatch (the file was altered or damaged)")
    _sr.check_content(path, core, header, arrays)
    header["_core"] = core
    return header, arrays, cls, own


def _build_from_file(header, arrays, cls, own):
    core = header.pop("_core")
    opts = dict(header["options"])
    if "process_cov" in arrays:
        opts["process_cov"] = arrays["process_cov"]
    state = {
        "estimator": core, "format": header["format"], "n_params": header["n_params"],
        "n_outputs": header["n_outputs"], "single_output": header["single_output"],
        "options": opts, "theta0": arrays["theta0"], "P0": arrays.get("P0"),
        "state": arrays["state"], "batch": header["batch"],
        "n_updates": header["n_updates"], "n_skipped": header["n_skipped"],
    }
    if not own:
        return estimator_from_state(state)
    outer = header["outer"]
    if not isinstance(outer.get("options"), dict):
        raise TypeError("outer must be an object with options")
    return cls.from_state({
        "estimator": header["estimator"], "format": outer.get("format"),
        "n_params": outer["n_params"], "options": dict(outer["options"]), "inner": state,
        **{key: arrays[name] for key, name in own.items()}})


class StateFileMethods:
    """``save_state`` / ``load_state`` for classes registered with the state-file container.

    The model objects that stream (RecursiveARX, RecursiveIV, RecursiveNARX,
    the pseudo-linear streams) keep their state in this container; the
    methods are the same for all of them.
    """

    #: The ``format`` of this class's :meth:`get_state` dict.
    _STATE_FORMAT = 1

    @classmethod
    def _check_state(cls, state) -> None:
        """What every ``from_state`` checks first: a dict of this class, in its format."""
        if not isinstance(state, dict):
            raise param_error("state", "a dict from get_state()", state, exc=TypeError)
        if state.get("estimator") != cls._kind:
            raise param_error("state", f"the state of a {cls._kind}",
                              f"<estimator {state.get('estimator')!r}>")
        if state.get("format") != cls._STATE_FORMAT:
            raise param_error("state['format']", f"{cls._STATE_FORMAT}", state.get("format"))

    def save_state(self, path):
        """Write the state to ``path`` (adaptid's versioned, checksummed ``.npz``; never pickle)."""
        save_state(self, path)

    @classmethod
    def load_state(cls, path):
        """Read a file of :meth:`save_state` (a :class:`~adaptid.StateFileError` if damaged
        or of another class)."""
        obj = load_state(path)
        if type(obj) is not cls:
            raise StateFileError(f"{path}: not a {cls.__name__} state file")
        return obj

