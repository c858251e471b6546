r"""The lane primitives of the structure-of-arrays kernels (:mod:`._soa`).

``LANES`` streams advance in lock-step, lane l innermost in every work array
(:func:`lane_scratch`); where a scalar kernel branches, every lane computes
both sides and keeps one with :func:`blend` (an LLVM ``select``).
"""

import numba
import numpy as np
from numba import types
from numba.extending import intrinsic, overload

from .._config import NJIT_INLINE, NJIT_PARALLEL, njit
from ._scratch import _stack_ptr

#: Streams advanced together by one vector instruction (4 doubles with AVX2, 8
#: with AVX-512). At n = 4 on AVX-512 (Zen 4) 4 and 16 lanes were both slower
#: than 8 (``benchmarks/bench_batched.py``).
LANES = 8
#: Time steps transposed into the lane-major scratch at once.
CHUNK = 32
#: compiled options of the lane code: a division by zero in a discarded lane (w = 0:
#: 1/w = inf) raises nothing and puts no branch in the loop
PAR = dict(NJIT_PARALLEL, error_model="numpy")
INL = dict(NJIT_INLINE, error_model="numpy")


def lane_scratch(a, b):  # pragma: no cover - replaced by the overload in compiled code
    """``np.empty((a, b, LANES))``; on the stack when a and b are compile-time constants."""
    return np.empty((a, b, LANES))


@overload(lane_scratch, inline="always", prefer_literal=True)
def _lane_scratch(a, b):
    if isinstance(a, types.IntegerLiteral) and isinstance(b, types.IntegerLiteral) \
            and a.literal_value > 0 and b.literal_value > 0:
        m = a.literal_value * b.literal_value * LANES

        def impl(a, b):
            return numba.carray(_stack_ptr(m), (a, b, LANES))
        return impl
    return lambda a, b: np.empty((a, b, LANES))


def blend(c, a, b):  # pragma: no cover - replaced by the overload in compiled code
    """``a if c else b`` without a branch (an LLVM ``select``)."""
    return a if c else b


@intrinsic
def _select(typingctx, c, a, b):
    if not isinstance(c, types.Boolean) or a != b:
        return None

    def codegen(context, builder, signature, args):
        return builder.select(args[0], args[1], args[2])
    return a(c, a, b), codegen


@overload(blend, inline="always")
def _blend(c, a, b):
    # Not a branch: LLVM made masked stores of those, and a load after a masked
    # store waits for it to retire (no forwarding): the step ran several times
    # slower (benchmarks/bench_batched.py).
    return lambda c, a, b: _select(c, a, b)


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
