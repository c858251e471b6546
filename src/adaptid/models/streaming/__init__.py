r"""Streaming model objects: MATLAB's ``recursiveARX``, ``recursiveAR``, ``recursiveARMAX``,
``recursiveARMA``, ``recursiveOE`` and ``recursiveBJ``.

:class:`RecursiveARX` and :class:`RecursiveAR` keep the lag buffers of a
polynomial model and a core recursive estimator (built by
:func:`adaptid.estimator`); :class:`RecursiveARMAX`, :class:`RecursiveARMA`,
:class:`RecursiveOE` and :class:`RecursiveBJ` keep, besides, the state of
the compiled pseudo-linear recursion (extended least squares, pseudo-linear
regression) that their batch models' ``fit_recursive`` runs. All identify
the model one sample at a time
(:meth:`~RecursiveARX.step`) or over a record in one compiled pass
(:meth:`~RecursiveARX.run`), as MATLAB's ``step(obj, y, u)`` does.

The behavioural reference is MATLAB's System Identification Toolbox
(``recursiveARX`` …); the algorithms are those of L. Ljung, *System
Identification: Theory for the User*, 2nd ed., Prentice Hall, 1999,
secs. 11.2–11.3.
"""

from __future__ import annotations

from ._arx import RecursiveAR, RecursiveARX, StreamResult
from ._pseudolinear import RecursiveARMA, RecursiveARMAX, RecursiveBJ, RecursiveOE

__all__ = ["RecursiveARX", "RecursiveAR", "StreamResult", "RecursiveARMAX", "RecursiveARMA",
           "RecursiveOE", "RecursiveBJ"]


def _register():
    from ...estimators._statefile import register_state_class
    register_state_class("RecursiveARX", RecursiveARX)
    register_state_class("RecursiveAR", RecursiveAR)
    for cls in (RecursiveARMAX, RecursiveARMA, RecursiveOE, RecursiveBJ):
        register_state_class(cls.__name__, cls)


_register()
