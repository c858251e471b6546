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
in name order. The file is written to a temporary name in the same folder,
flushed and fsync'ed, then renamed over the target, so a reader sees the old
file or the new one, never half of one. Reading checks the magic, the format
version, the checksum, the estimator type and every shape; any mismatch raises
:class:`~adaptid.StateFileError` (a ``ValueError``). Pickle is never used: a
pickled object array inside the archive is refused by ``allow_pickle=False``.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import tempfile
from pathlib import Path

import numpy as np

from .._exceptions import StateFileError

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
               "NLMS": "adaptid.estimators", "ConstrainedRLS": "adaptid.constrained"}


def register_state_class(name: str, cls) -> None:
    """Make ``load_state`` build files whose header names ``name`` with ``cls.from_state``."""
    _REGISTRY[name] = cls


def _lookup(name):
    if name not in _REGISTRY and name in _DEFINED_IN:
        import importlib
        importlib.import_module(_DEFINED_IN[name])  # registers its classes
    return _REGISTRY.get(name)


def _classes():
    return {k: _lookup(k) for k in ("RLS", "SlidingWindowRLS", "KalmanRLS", "LMS", "NLMS")}


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
    theta0 = np.asarray(state["theta0"])
    if theta0.ndim != 2:
        raise ValueError(f"state['theta0'] must be 2-dimensional (n, p), got shape {theta0.shape}")
    kwargs = dict(theta0=theta0 if not state["single_output"] else theta0[:, 0], **opts)
    if getattr(cls, "_has_covariance", True):  # the gradient estimators have no P0
        kwargs["P0"] = np.asarray(state["P0"])
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


def save_state(est, path) -> None:
    """Write ``est.get_state()`` to ``path`` atomically (see module docstring)."""
    header, arrays = _payload(est.get_state())
    header["checksum"] = _digest(header, arrays)
    buf = io.BytesIO()
    np.savez(buf, header=np.frombuffer(json.dumps(header).encode(), dtype=np.uint8), **arrays)
    path = Path(os.fspath(path))
    folder = path.parent if str(path.parent) else Path(".")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(buf.getvalue())
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def load_state(path):
    """Read a state file written by any estimator's ``save_state``.

    Parameters
    ----------
    path : str or os.PathLike
        The file.

    Returns
    -------
    RLS, SlidingWindowRLS, KalmanRLS or ConstrainedRLS
        The estimator, exactly as it was saved: continuing it gives bit for
        bit the results of the uninterrupted run.

    Raises
    ------
    StateFileError
        (a ``ValueError``) on any damage or mismatch: unreadable, truncated,
        not an adaptid state file, a newer format, a checksum mismatch, an
        unknown estimator type or an inconsistent state. Nothing is unpickled.

    See Also
    --------
    RLS.load_state : the same, refusing a file of another estimator type.
    """
    path = Path(os.fspath(path))
    try:
        data = path.read_bytes()
    except OSError as err:
        raise StateFileError(f"path {str(path)!r} cannot be read: {err.strerror or err}") from None
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as npz:
            names = set(npz.files)
            if "header" not in names:
                raise StateFileError(f"{path}: not an adaptid state file (no header)")
            raw = npz["header"]
            arrays = {k: npz[k] for k in names - {"header"}}
    except StateFileError:
        raise
    except ValueError as err:  # includes "Object arrays cannot be loaded when allow_pickle=False"
        raise StateFileError(f"{path}: refused ({err})") from None
    except Exception as err:  # noqa: BLE001 - a damaged zip raises anything (NotImplementedError,
        # RuntimeError "encrypted", zlib.error, ...): all of it means a corrupted file
        raise StateFileError(f"{path}: truncated or corrupted state file ({type(err).__name__}: {err})") from None
    try:
        if raw.dtype != np.uint8 or raw.ndim != 1:
            raise ValueError("header is not a byte string")
        header = json.loads(raw.tobytes().decode("utf-8"))
        if not isinstance(header, dict):
            raise ValueError("header is not an object")
    except (ValueError, UnicodeDecodeError) as err:
        raise StateFileError(f"{path}: corrupted header ({err})") from None
    if header.get("magic") != _MAGIC:
        raise StateFileError(f"{path}: not an adaptid state file")
    fmt = header.get("format")
    if not isinstance(fmt, int) or fmt > FORMAT:
        raise StateFileError(f"{path}: state format {fmt!r} is newer than this adaptid "
                             f"supports ({FORMAT}); upgrade adaptid")
    if fmt != FORMAT:
        raise StateFileError(f"{path}: unknown state format {fmt!r}")
    checksum = header.pop("checksum", None)
    kind = header.get("estimator")
    cls = _lookup(kind) if isinstance(kind, str) else None
    own = getattr(cls, "_STATE_FILE_ARRAYS", {}) if "inner_estimator" in header else {}
    allowed = set(_ARRAYS) | set(own.values())
    if set(arrays) - allowed:
        raise StateFileError(f"{path}: unexpected arrays {sorted(set(arrays) - allowed)}")
    if any(a.dtype != np.float64 for a in arrays.values()):
        raise StateFileError(f"{path}: arrays must be float64")
    if checksum != _digest(header, arrays):
        raise StateFileError(f"{path}: checksum mismatch (the file was altered or damaged)")
    wrapped = bool(own)
    core = header.get("inner_estimator") if wrapped else kind
    if cls is None or core not in _classes() or ("inner_estimator" in header) != wrapped:
        raise StateFileError(f"{path}: unknown estimator type {kind!r}")
    try:
        opts = header["options"]
        if not isinstance(opts, dict):
            raise TypeError(f"options must be an object, got {type(opts).__name__}")
        opts = dict(opts)
        if "process_cov" in arrays:
            opts["process_cov"] = arrays["process_cov"]
        state = {
            "estimator": core, "format": fmt, "n_params": header["n_params"],
            "n_outputs": header["n_outputs"], "single_output": header["single_output"],
            "options": opts, "theta0": arrays.get("theta0"), "P0": arrays.get("P0"),
            "state": arrays.get("state"), "batch": header["batch"],
            "n_updates": header["n_updates"], "n_skipped": header["n_skipped"],
        }
        if not wrapped:
            return estimator_from_state(state)
        outer = header["outer"]
        if not isinstance(outer, dict) or not isinstance(outer.get("options"), dict):
            raise TypeError("outer must be an object with options")
        return cls.from_state({
            "estimator": kind, "format": outer["format"], "n_params": outer["n_params"],
            "options": dict(outer["options"]), "inner": state,
            **{key: arrays[name] for key, name in own.items()}})
    except (ValueError, TypeError, KeyError, IndexError, AttributeError) as err:
        raise StateFileError(f"{path}: inconsistent state ({err})") from None
