r"""Streaming model objects: MATLAB's ``recursiveARX`` and ``recursiveAR``.

:class:`RecursiveARX` and :class:`RecursiveAR` keep the lag buffers of a
polynomial model and a core recursive estimator (built by
:func:`adaptid.estimator`), and identify the model one sample at a time
(:meth:`~RecursiveARX.step`) or over a record in one compiled pass
(:meth:`~RecursiveARX.run`), as MATLAB's ``step(obj, y, u)`` does.

The behavioural reference is MATLAB's System Identification Toolbox
(``recursiveARX``, ``recursiveAR``); the algorithms are those of
L. Ljung, *System Identification: Theory for the User*, 2nd ed., Prentice
Hall, 1999, sec. 11.2.
"""

from __future__ import annotations

from ._arx import RecursiveAR, RecursiveARX, StreamResult

__all__ = ["RecursiveARX", "RecursiveAR", "StreamResult"]


def _register():
    from ...estimators._statefile import register_state_class
    register_state_class("RecursiveARX", RecursiveARX)
    register_state_class("RecursiveAR", RecursiveAR)


_register()
