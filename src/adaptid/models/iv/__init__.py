r"""Instrumental-variable estimation of ARX models.

* :func:`iv4` — Ljung's four-stage instrumental-variable method (MATLAB's
  ``iv4``);
* :func:`ivx` — instrumental variables with given instruments (MATLAB's
  ``ivx``);
* :class:`RecursiveIV` — recursive instrumental variables with instruments
  from an auxiliary model (Ljung and Söderström), one sample at a time or
  a record in one compiled pass (:class:`RecursiveIVResult`), state files.
"""

from ._iv import iv4, ivx
from ._recursive import RecursiveIV, RecursiveIVResult

__all__ = ["iv4", "ivx", "RecursiveIV", "RecursiveIVResult"]


def _register():
    from ...estimators._statefile import register_state_class
    register_state_class("RecursiveIV", RecursiveIV)


_register()
