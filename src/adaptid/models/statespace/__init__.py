r"""State-space models: subspace identification, ERA and OKID.

* :class:`StateSpaceModel` — innovation form x(k+1) = A x(k) + B u(k) + K e(k),
  y(k) = C x(k) + D u(k) + e(k), with simulation, k-step prediction,
  responses, summary and python-control conversion;
* :func:`n4sid` — subspace identification (N4SID, MOESP, CVA weightings);
* :func:`era` — eigensystem realisation from Markov parameters;
* :func:`okid` — observer/Kalman filter identification from input–output data.
"""

from ._era import era, okid
from ._model import StateSpaceModel
from ._present import StateSpaceSummary
from ._subspace import n4sid

__all__ = ["StateSpaceModel", "StateSpaceSummary", "n4sid", "era", "okid"]
