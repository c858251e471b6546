"""Measured data sets and helpers to reproduce their published procedures.

* :func:`load_emps` — the EMPS electro-mechanical positioning system
  (Janot, Gautier & Brunot 2019), estimation and validation runs;
* :func:`load_daisy` — sets of the DaISy database (hair dryer, flexible
  robot arm, CD player arm, heat exchanger);
* :func:`matlab_filtfilt`, :func:`matlab_decimate`,
  :func:`central_difference` — MATLAB-compatible filtering, decimation and
  differentiation, so that MATLAB scripts' printed numbers can be
  reproduced;
* :func:`dc_motor` — a simulated permanent-magnet DC motor driving a load
  (the data set of ``adaptid demo``);
* :func:`fleet` — a synthetic fleet of DC motors, some with a fault.

The files are shipped unmodified with the package; their provenance and
checksums are in ``adaptid/datasets/data/README.md``.
"""

from ._daisy import DAISY_NAMES, DaisyData, load_daisy
from ._emps import EMPSData, load_emps
from ._matlab import central_difference, matlab_decimate, matlab_filtfilt

__all__ = [
    "load_emps",
    "EMPSData",
    "load_daisy",
    "DaisyData",
    "DAISY_NAMES",
    "matlab_filtfilt",
    "matlab_decimate",
    "central_difference",
    "dc_motor",
    "fleet",
]

# generated data sets: imported on first use (they need pandas)
_LAZY = {"dc_motor": "._dc_motor", "fleet": "._fleet"}


def __getattr__(name):
    if name in _LAZY:
        import importlib
        value = getattr(importlib.import_module(_LAZY[name], __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'adaptid.datasets' has no attribute {name!r}")
