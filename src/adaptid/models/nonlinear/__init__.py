r"""Nonlinear models linear in the parameters: polynomial NARX with FROLS, SINDy.

* :class:`NARX` — polynomial NARX, terms chosen by forward regression with
  orthogonal least squares (error reduction ratio) and an information
  criterion; results per output in :class:`NARXResult`.
"""

from __future__ import annotations

from ._narx import NARX, NARXResult

__all__ = ["NARX", "NARXResult"]
