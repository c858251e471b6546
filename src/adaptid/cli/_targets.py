"""The files a command writes, checked against the files it reads, before any work.

Every output a command will write, including the names it generates
(``--out R`` writes ``R/estimates.csv``, ``R/index.html`` and figures;
``--export-c D --c-name N`` writes ``D/N.h`` and ``D/N.c``), is compared
with every input (the data, ``--resume``, the state file of ``export-c``)
and with every other output. Two names are the same file when they resolve
to the same path, or when both exist and are one file (hard links,
symlinks, ``./x`` and ``x``). The one allowed overlap is ``--save-state``
naming the ``--resume`` file: that advances the state.

:func:`state_lock` serialises the commands that read and write one state
file (``fit --resume X --save-state X`` twice at once would otherwise lose
one run's samples): an exclusive ``flock`` on the state file's folder, held
from before the state is read until after it is written.
"""

from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path

from ._errors import CLIError

__all__ = ["REPORT_FILES", "check_targets", "report_targets", "c_targets", "state_lock"]

#: Files ``fit --out R`` (and ``demo --out R``) may write in ``R``.
REPORT_FILES = ("index.html", "estimates.csv", "tracks.png", "errors.png", "cusum.png",
                "compare.png", "resid.png")


def report_targets(out) -> list:
    """``[("--out", R/name), ...]`` for every file of the report folder."""
    if out is None:
        return []
    folder = Path(os.fspath(out))
    return [("--out", folder / name) for name in REPORT_FILES]


def c_targets(folder, name, option="--export-c") -> list:
    """``[(option, D/N.h), (option, D/N.c)]``: the pair :func:`adaptid.codegen.to_c` writes."""
    if folder is None:
        return []
    d = Path(os.fspath(folder))
    return [(option, d / f"{name}.h"), (option, d / f"{name}.c")]


def _same(a, b) -> bool:
    a, b = os.fspath(a), os.fspath(b)
    try:
        if os.path.exists(a) and os.path.exists(b):
            return os.path.samefile(a, b)
    except OSError:
        pass
    return os.path.realpath(a) == os.path.realpath(b)


def check_targets(inputs, outputs, *, allowed=()) -> None:
    """Refuse an output that is an input or another output (one line, exit 2).

    Parameters
    ----------
    inputs, outputs : list of (option, path)
        ``None`` paths are ignored.
    allowed : iterable of (output option, input option)
        Overlaps that are meant (``("--save-state", "--resume")``).
    """
    ins = [(o, p) for o, p in inputs if p is not None]
    outs = [(o, p) for o, p in outputs if p is not None]
    allowed = set(allowed)
    for k, (opt, path) in enumerate(outs):
        for iopt, ipath in ins:
            if (opt, iopt) not in allowed and _same(path, ipath):
                what = "the data file" if iopt in ("DATA", "STATE_FILE") else f"the {iopt} file"
                raise CLIError(f"{opt} would write {path}, which is {what} ({ipath}); "
                               "choose another name")
        for opt2, path2 in outs[k + 1:]:
            if _same(path, path2):
                raise CLIError(f"{opt} and {opt2} would both write {path2}; choose other names")


@contextmanager
def state_lock(path):
    """Hold an exclusive lock on ``path``'s folder (no-op where ``fcntl`` is missing).

    Blocks while another adaptid command holds it, so concurrent
    ``--resume X --save-state X`` runs take turns instead of losing samples.
    """
    if path is None:
        yield
        return
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows: documented as not serialised
        yield
        return
    folder = Path(os.fspath(path)).parent
    try:
        fd = os.open(folder if str(folder) else ".", os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except OSError:
        yield  # the folder's problems are reported where the state is read or written
        return
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # releases the lock
