r"""Kalman filter for a random-walk parameter, on U-D factors.

Entry points as in :mod:`._rls`, with ``opt = [windup threshold, R₂,
skip]`` and ``mat = R₁`` (n × n); ``lam``, ``Lk`` and ``St`` are unused. Per sample
(Ljung & Söderström 1983, eq. 2.114): the measurement update (Bierman, weight
R₂/w), then the time update ``U D Uᵀ + R₁`` re-factorised. A non-finite
sample gets the time update only when ``skip`` is set (``nan_policy="skip"``)
and leaves the state untouched otherwise (the caller then raises).
"""

import numpy as np

from ..._config import NJIT, NJIT_INLINE, njit
from ..toolchain._dims import dim
from ._bierman import _bierman_apply, _bierman_prep, _d_below, _finite_row, _gain_step, \
    _prior_errors, _store, _time_update, _views
from ._entries import Entries
from ._parallel import batched, segments


@njit(**NJIT_INLINE)
def _measurement_update(theta, U, D, phi, y, r2, w, e, f, v, b, NP, p):
    _prior_errors(theta, phi, y, e, NP, p)
    if w > 0.0:
        _bierman_prep(U, D, phi, f, v, NP)
        a = _bierman_apply(U, D, r2 / w, f, v, b, NP)
        _gain_step(theta, b, a, e, NP, p)


@njit(**NJIT)
def _kalman_core(S, Phi, Y, w, Th, E, skipped, opt, Q, ntag, ptag):
    # Called, not inlined, by the entry points (compiled once per types and tags; see
    # _rls._rls_core); other kernels pass size_tag(n).
    NP = dim(ntag)
    p = dim(ptag)
    dthr = opt[0]
    r2 = opt[1]
    skip = opt[2] != 0.0
    theta, U, D = _views(S, NP, p)
    f = np.empty(NP)
    v = np.empty(NP)
    b = np.empty(NP)
    W = np.empty((NP, NP))
    store = Th.shape[0] == Phi.shape[0]
    bad = -1
    for k in range(Phi.shape[0]):
        phi = Phi[k]
        y = Y[k]
        time_update = True
        if _finite_row(phi, y, NP, p):
            _measurement_update(theta, U, D, phi, y, r2, w[k], E[k], f, v, b, NP, p)
        else:
            skipped[k] = True
            for j in range(p):
                E[k, j] = np.nan
            time_update = skip
        # one time update in the code, not one per branch (a shorter cold compile)
        ok = _time_update(U, D, Q, W, NP) if time_update else True
        if bad < 0 and not (ok and _d_below(D, dthr, NP)):
            bad = k
        if store:
            _store(Th, k, theta, NP, p)
    return bad


@njit(**NJIT)
def kalman_run(S, Phi, Y, lam, w, Th, E, skipped, Lk, St, opt, mat, ntag, ptag):
    """N Kalman steps; returns the first sample at which P lost definiteness or
    a pivot passed the windup threshold, or -1."""
    return _kalman_core(S, Phi, Y, w, Th, E, skipped, opt, mat, ntag, ptag)


kalman_run_batched = batched(kalman_run, "kalman_run_batched")
kalman_run_segments = segments(kalman_run, "kalman_run_segments")


#: this module's entry points, by the name adaptid._kernels gives them
ENTRIES = {"KALMAN": Entries(kalman_run, kalman_run_batched, kalman_run_segments)}
