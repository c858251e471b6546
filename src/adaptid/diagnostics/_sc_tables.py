"""The tables of R strucchange 1.5.3 (its R/sysdata.rda), read from a data file.

The numbers live in ``data/sc_tables.json`` beside this module, written by
``tests/reference/strucchange/export_tables.R`` (do not edit by hand; floats
are written so that they read back to the same float64). This module reads
the file once, on first use of one of its names, and exposes the tables as
read-only arrays:

* ``SC_BETA_SUP``, ``SC_BETA_AVE``, ``SC_BETA_EXP`` — Hansen (1997), JBES
  15(1):60-67, response surfaces: rows (k-1)*25 .. k*25-1 for k = 1..40; the
  last column is the degrees of freedom of the chi-square;
* ``SC_ME`` — Chu, Hornik & Kuan (1995) ME-test critical values: rows
  (k-1)*10 .. k*10-1 for h = 0.05..0.50; columns alpha = 0.1, 0.05, 0.025,
  0.01;
* ``SC_MEANL2`` — quantiles of the mean squared L2 norm of a k-dim Brownian
  bridge (k = 1..25; columns 1 - p for p in ``SC_MEANL2_P``);
* ``MONITOR_ME`` — Leisch, Hornik & Kuan (2000) max-functional critical
  values, shape (winsize ``MONITOR_ME_WINSIZE``, period
  ``MONITOR_ME_PERIOD``, 1-alpha ``MONITOR_ME_PROB`` = 0.950..0.999).
"""

from __future__ import annotations

import functools
import json
from importlib import resources

import numpy as np

__all__ = ["SC_BETA_SUP", "SC_BETA_AVE", "SC_BETA_EXP", "SC_ME", "SC_MEANL2", "SC_MEANL2_P",
           "MONITOR_ME_WINSIZE", "MONITOR_ME_PERIOD", "MONITOR_ME_PROB", "MONITOR_ME"]

#: the data file, in the package folder ``data/`` of :mod:`adaptid.diagnostics`
FILE = "sc_tables.json"
#: names read as tuples (looked up with ``.index``); every other name is an array
_TUPLES = {"MONITOR_ME_WINSIZE": float, "MONITOR_ME_PERIOD": int}
#: arrays stored as rows of a 2-D table and reshaped on reading
_SHAPES = {"MONITOR_ME": (3, 5, 50)}


@functools.cache
def tables() -> dict:
    """Every table of the data file, keyed by the names of ``__all__`` (read once)."""
    text = resources.files("adaptid.diagnostics").joinpath("data", FILE).read_text("utf-8")
    raw = json.loads(text)
    out = {}
    for name in __all__:
        if name in _TUPLES:
            out[name] = tuple(_TUPLES[name](v) for v in raw[name])
            continue
        a = np.array(raw[name], dtype=np.float64)
        a = a.reshape(_SHAPES.get(name, a.shape))
        a.flags.writeable = False
        out[name] = a
    return out


def __getattr__(name):
    if name in __all__:
        return tables()[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
