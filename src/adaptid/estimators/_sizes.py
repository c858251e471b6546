"""Which compiled kernels new estimators use: specialised per n, or size-generic."""

from __future__ import annotations

import os
from contextlib import contextmanager

from .. import _config

__all__ = ["size_generic_kernels"]


@contextmanager
def size_generic_kernels():
    """Estimators built inside use the size-generic compiled kernels (n a run-time value).

    By default the kernels are specialised for each n <= 16 (faster per sample,
    one compilation per size). A short process whose time is mostly compilation
    (a shell command, a test module) is better served by the generic kernel of
    each algorithm, compiled (or loaded) once for every model size. Results are
    bit for bit the same. An ``ADAPTID_MAX_SPECIALISED_N`` in the environment
    keeps its choice.
    """
    if "ADAPTID_MAX_SPECIALISED_N" in os.environ:
        yield
        return
    saved = _config.MAX_SPECIALISED_N
    _config.MAX_SPECIALISED_N = 0
    try:
        yield
    finally:
        _config.MAX_SPECIALISED_N = saved
