r"""Instrumental-variable estimation of ARX models.

* :func:`iv4` — Ljung's four-stage instrumental-variable method (MATLAB's
  ``iv4``);
* :func:`ivx` — instrumental variables with given instruments (MATLAB's
  ``ivx``).
"""

from ._iv import iv4, ivx

__all__ = ["iv4", "ivx"]
