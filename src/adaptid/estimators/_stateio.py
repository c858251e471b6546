r"""The state round trip: ``get_state`` / ``from_state``, state files and pickling.

``get_state`` gives the options (``spec.options``), the prior and the state
vector as plain values and float64 arrays; ``from_state`` rebuilds an estimator
from them through the one checked constructor path of the state-file container
(:func:`._statefile.estimator_from_state`), which is also what ``load_state`` and
unpickling use. The file format itself is :mod:`._statefile` and
:mod:`._stateread`.

The functions taking ``self`` (or ``cls``) are methods (classmethods) of
:class:`~adaptid.estimators._engine.RecursiveEstimator` (bound there by name).
"""

from __future__ import annotations

import numpy as np

from .._exceptions import StateFileError
from .._validation import as_float_array, param_error
from . import _statefile

__all__ = ["options", "get_state", "kernel_settings", "from_state", "set_state", "save_state",
           "load_state", "getstate", "setstate"]


def options(self) -> dict:
    """The options of ``get_state()["options"]``: the estimator's attribute of each
    name in ``spec.options``, in that order (arrays copied, a forgetting strategy as
    its ``to_dict()``)."""
    return {name: _plain(getattr(self, name)) for name in self.spec.options}


def _plain(value):
    if isinstance(value, np.ndarray):
        return value.copy()
    return value.to_dict() if hasattr(value, "to_dict") else value


def get_state(self) -> dict:
    """Everything needed to resume exactly: options, prior and the state vector.

    The dict holds only plain Python values and float64 arrays, so it can
    be stored as JSON + arrays (see :meth:`save_state`).
    """
    return {
        "estimator": type(self).__name__,
        "format": _statefile.FORMAT,
        "n_params": self.n_params,
        "n_outputs": self.n_outputs,
        "single_output": self._single,
        "options": dict(self._options(), **({"P0": "diffuse"} if self._diffuse else {})),
        "theta0": self.theta0.copy(),
        "P0": None if self.P0 is None or self._diffuse else self.P0.copy(),
        "state": self._S.copy(),
        "batch": self._batch,
        "n_updates": self.n_updates,
        "n_skipped": self.n_skipped,
    }


def kernel_settings(self):
    """The algorithm and current state in the form a compiled recursion takes.

    A public hook for recursions built on the estimators (the models'
    pseudo-linear regressions): they read the estimator's algorithm and
    state here instead of its private fields.

    Returns
    -------
    KernelSettings
        Copies of θ (n, p) and the U-D factors of P, and the options:
        ``method`` ("rls", "window", "kalman"), ``forgetting`` (constant λ,
        1.0 under a strategy), ``strategy_mode`` (−1: none or exponential
        without ``P_max``), ``strategy_params``, ``P_max`` (inf: none),
        ``window`` (0: none), ``process_cov``, ``noise_var``;
        ``diffuse_state``: None with a finite prior, else a copy of the
        diffuse tail of the state (``adaptid._kernels.recursions._diffuse``).
    """
    from ._settings import KernelSettings
    self._check_single("kernel_settings")
    n, p = self.n_params, self.n_outputs
    U, D = self._ud_views(self._S)
    theta = self._S[: n * p].reshape(n, p).copy()
    tail = self._S[self._S.shape[0] - self._tail:].copy() if self._diffuse \
        else None
    return KernelSettings.of(self, theta, np.array(U), np.array(D), tail)


def from_state(cls, state: dict):
    """Rebuild an estimator from :meth:`get_state`'s dict (exact round trip)."""
    if not isinstance(state, dict):
        raise param_error("state", "a dict from get_state()", state, exc=TypeError)
    est = _statefile.estimator_from_state(state)
    if not isinstance(est, cls):
        raise param_error("state", f"the state of a {cls.__name__}",
                          f"<the state of a {type(est).__name__}>")
    return est


def set_state(self, S, batch, n_updates, n_skipped):
    expect = (self._state_length(),) if batch is None else (batch, self._state_length())
    S = as_float_array(S, "state['state']", shape=expect, copy=True, finite=False)
    self._check_state(S.reshape(-1, S.shape[-1]))
    self._S = S
    self._batch = batch
    self._stats_acc = None
    self.n_updates = int(n_updates)
    self.n_skipped = int(n_skipped)


def save_state(self, path):
    """Write the state to ``path`` (versioned, checksummed ``.npz``; never pickle).

    The file is written to a temporary name and renamed, so a crash
    never leaves a half-written state file. See :func:`adaptid.load_state`.
    """
    _statefile.save_state(self, path)


def load_state(cls, path):
    """Read a file written by :meth:`save_state`; raises StateFileError if it is damaged."""
    est = _statefile.load_state(path)
    if not isinstance(est, cls):
        raise StateFileError(f"{path}: holds the state of a {type(est).__name__}, "
                             f"not a {cls.__name__}")
    return est


def getstate(self):
    """Pickling stores :meth:`get_state`'s dict (never the engine's arrays)."""
    return self.get_state()


def setstate(self, state):
    """Unpickling rebuilds the estimator from the dict (checked as a state file's)."""
    other = _statefile.estimator_from_state(state)
    self.__dict__.update(other.__dict__)
