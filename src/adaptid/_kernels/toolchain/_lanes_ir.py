"""The compiled lane primitives of the structure-of-arrays kernels (``lanes/``).

:func:`lane_scratch` is a work array with the lane innermost, on the stack for
compile-time sizes (patch ``stack-scratch``; off: ``np.empty``); :func:`blend`
is ``a if c else b`` as an LLVM ``select`` (numba's intrinsic API).
"""

import numba
import numpy as np
from numba import types
from numba.extending import intrinsic, overload

from ._scratch import STACK, _stack_ptr

__all__ = ["LANES", "lane_scratch", "blend"]

#: Streams advanced together by one vector instruction (4 doubles with AVX2, 8
#: with AVX-512). At n = 4 on AVX-512 (Zen 4) 4 and 16 lanes were both slower
#: than 8 (``benchmarks/bench_batched.py``).
LANES = 8

def lane_scratch(a, b):  # pragma: no cover - replaced by the overload in compiled code
    """``np.empty((a, b, LANES))``; on the stack when a and b are compile-time constants."""
    return np.empty((a, b, LANES))


@overload(lane_scratch, inline="always", prefer_literal=True)
def _lane_scratch(a, b):
    if STACK and isinstance(a, types.IntegerLiteral) and isinstance(b, types.IntegerLiteral) \
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
