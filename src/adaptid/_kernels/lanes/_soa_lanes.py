r"""The lane primitives of the structure-of-arrays kernels (:mod:`._soa`).

``LANES`` streams advance in lock-step, lane l innermost in every work array
(:func:`lane_scratch`); where a scalar kernel branches, every lane computes
both sides and keeps one with :func:`blend` (an LLVM ``select``). Both are
compiled by ``toolchain/_lanes_ir.py``.
"""

from ..._config import NJIT_INLINE, NJIT_PARALLEL, njit
from ..toolchain._lanes_ir import LANES, blend, lane_scratch

__all__ = ["LANES", "CHUNK", "PAR", "INL", "lane_scratch", "blend", "lane_sample"]

#: Time steps transposed into the lane-major scratch at once.
CHUNK = 32
#: compiled options of the lane code: a division by zero in a discarded lane (w = 0:
#: 1/w = inf) raises nothing and puts no branch in the loop
PAR = dict(NJIT_PARALLEL, error_model="numpy")
INL = dict(NJIT_INLINE, error_model="numpy")


@njit(**INL)
def lane_sample(X, Yc, Wc, th, t, l, NP):
    """Lane l's sample t: whether it is finite (φ and y), whether it updates (finite,
    w > 0), and its prior error ε = y − φᵀθ summed in order (the scalar kernels'
    ``_prior_error`` for one output and n < 16)."""
    ok = True
    for i in range(NP):
        ok &= X[t, i, l] - X[t, i, l] == 0.0
    yk = Yc[0, t, l]
    ok &= yk - yk == 0.0
    e = yk
    for i in range(NP):
        e -= X[t, i, l] * th[0, i, l]
    return ok, ok & (Wc[0, t, l] > 0.0), e
