"""Modules imported on first use: ``signal = lazy("scipy.signal")``.

``scipy.signal`` is slow to import and most programs that import
:mod:`adaptid.models` never filter a signal (``adaptid demo`` among them);
the proxy imports the module on the first attribute access instead of at
import time.
"""

from __future__ import annotations

import importlib

__all__ = ["lazy", "pyplot"]


class _LazyModule:
    __slots__ = ("_name",)

    def __init__(self, name: str):
        self._name = name

    def __getattr__(self, attr):
        return getattr(importlib.import_module(self._name), attr)

    def __repr__(self):
        return f"<module {self._name!r}, imported on first use>"


def lazy(name: str):
    """A stand-in for module ``name`` that imports it on the first attribute access."""
    return _LazyModule(name)


def pyplot():
    """``matplotlib.pyplot``, or an ImportError naming the extra that installs it."""
    try:
        import matplotlib.pyplot as plt
    except ImportError as err:  # pragma: no cover - depends on the extra
        raise ImportError("plot needs matplotlib: pip install 'adaptid[plot]'") from err
    return plt
