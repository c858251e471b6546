r"""Multi-input multi-output ARX models (MATLAB's ``arx`` with order matrices).

* :class:`MIMOARX` — :math:`A(q)y_k = B(q)u_k + e_k` with matrix
  polynomials; made by :class:`~adaptid.models.ARX` when an order is a
  matrix or the data have several outputs (``isinstance(m, ARX)`` holds).
  Least squares per output equation (one QR when the equations share
  their regressors), several experiments kept apart, simulation, k-step
  prediction, python-control conversion, frequency and step responses
  with their uncertainty, ``select_order`` per output.
"""

from __future__ import annotations

from ._model import MIMOARX

__all__ = ["MIMOARX"]
