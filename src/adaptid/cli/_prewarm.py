"""Compile a command's heavier kernels in a second process while the first works.

A shell command is one short process, and on a fresh install most of its time
is numba compiling kernels, one after the other in one thread (numba's
compiler holds the GIL). ``adaptid demo`` needs three recursions; while the
command simulates the motor and runs the first, a helper process compiles the
sliding window's kernels into the same disk cache, and the command loads them
from there when it gets to them (:func:`start`, :func:`wait`).

Only where it can help and cannot hurt: the kernels are cached on disk (a
trusted cache folder, :mod:`adaptid._config`), the machine has a second core,
and ``ADAPTID_PREWARM`` is not ``0``. The helper compiles exactly the
signatures the command will call (the same estimator, options and array
types, on a few rows of zeros); whatever goes wrong in it (it is killed, it
fails, it is slow) the command compiles the kernel itself, with the same
result: the cache only ever holds what numba compiled from the same source.
"""

import glob
import os
import subprocess
import sys

__all__ = ["start", "wait"]

_CHILD = "from {module} import {function}; {function}({args!r})"


def _cached(kernel):
    """Whether numba's cache folder, or the kernels compiled at install
    (:mod:`adaptid._kernels.toolchain._installed`), already hold an index for ``kernel``
    ("<module>.<function>" of adaptid/_kernels, e.g. "_window._window_core")."""
    from .. import _config
    from .._kernels.toolchain import _installed

    folders = [_config.CACHE_DIR] + ([_installed.folder()]
                                     if _installed.enabled() and _installed._ready() else [])
    return any(bool(folder) and glob.glob(os.path.join(glob.escape(folder), kernel + "-*.nbi"))
               for folder in folders)


def start(module, function, args, *, unless_cached=()):
    """Start ``module.function(args)`` in a helper process: it compiles kernels by
    running them on small inputs (e.g. :func:`adaptid.cli._demo.compile_kernels`).

    Returns the process, or None where a helper would not help (see the module), or
    when every kernel of ``unless_cached`` (names as for :func:`_cached`) is already
    in the cache (a warm install: the helper would only delay the command).
    """
    from .. import _config

    if not _config.CACHE or os.environ.get("ADAPTID_PREWARM", "1") == "0" \
            or (os.cpu_count() or 1) < 2:
        return None
    if unless_cached and all(_cached(k) for k in unless_cached):
        return None
    env = dict(os.environ, ADAPTID_PREWARM="0",
               PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    try:
        code = _CHILD.format(module=module, function=function, args=args)
        return subprocess.Popen([sys.executable, "-c", code],
                                env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
    except OSError:
        return None


def wait(proc, timeout=120.0):
    """Wait for the helper (then its kernels are on disk); kill it after ``timeout`` s."""
    if proc is None:
        return
    try:
        proc.wait(timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
