r"""Nonlinear models linear in the parameters: polynomial NARX with FROLS, SINDy.

* :class:`NARX` — polynomial NARX, terms chosen by forward regression with
  orthogonal least squares (error reduction ratio) and an information
  criterion; results per output in :class:`NARXResult`;
* :func:`stlsq` — sequentially thresholded (ridge) least squares;
* :class:`SINDy` — sparse identification of (continuous- or discrete-time)
  dynamics on a polynomial library, lagged states allowed;
* :class:`RecursiveNARX` — a selected NARX structure re-estimated sample by
  sample (``step``, ``run``, state files).
"""

from __future__ import annotations

from ._narx import NARX, NARXResult
from ._sindy import SINDy, stlsq
from ._streaming import RecursiveNARX

__all__ = ["NARX", "NARXResult", "stlsq", "SINDy", "RecursiveNARX"]


def _register():
    from ...estimators._statefile import register_state_class
    register_state_class("RecursiveNARX", RecursiveNARX)


_register()
