"""Measured data sets and helpers to reproduce their published procedures.

* :func:`load_emps` — the EMPS electro-mechanical positioning system
  (Janot, Gautier & Brunot 2019), estimation and validation runs;
* :func:`load_daisy` — sets of the DaISy database (hair dryer, flexible
  robot arm, CD player arm, heat exchanger);
* :func:`matlab_filtfilt`, :func:`matlab_decimate`,
  :func:`central_difference` — MATLAB-compatible filtering, decimation and
  differentiation, so that MATLAB scripts' printed numbers can be
  reproduced.

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
]
