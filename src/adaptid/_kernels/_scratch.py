"""Fixed-size scratch arrays on the stack, for the specialised kernels.

``scratch(n)`` / ``scratch2(n)`` behave like ``np.empty(n)`` /
``np.empty((n, n))``. When ``n`` is a compile-time constant (the kernels
called with tuple size tags, see :mod:`adaptid._kernels._dims`) the
array is an ``alloca`` in the kernel's entry block instead of a heap
allocation. LLVM then knows that it cannot alias the caller's arrays
(Φ, y, the trajectory), so the unrolled update keeps the factor in
registers across the stores to the trajectory instead of reloading it
after each one; small ones are promoted to registers outright. With ``n``
known only at run time both fall back to ``np.empty``.

The arrays live as long as the kernel's frame: they must not be returned
or stored. Their contents start undefined, as with ``np.empty``.

The sizes come from the tags of :mod:`._dims`: a tuple tag makes n a
compile-time constant (stack arrays), an int tag a run-time value (heap).
"""

import numba
import numpy as np
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic, overload

__all__ = ["scratch", "scratch2", "small_scratch"]

#: ``small_scratch`` is on the stack up to this length. Measured with the RLS
#: kernel: the work vectors on the stack gave +15-25 % updates/s at n = 8 but
#: -25 % at n = 16 (LLVM promotes them to registers and spills the factor).
SMALL_MAX = 8


@intrinsic
def _stack_ptr(typingctx, count):
    if not isinstance(count, types.IntegerLiteral) or count.literal_value <= 0:
        return None
    size = count.literal_value

    def codegen(context, builder, signature, args):
        ty = context.get_value_type(types.float64)
        ptr = cgutils.alloca_once(builder, ty, size=context.get_constant(types.intp, size))
        return ptr

    return types.CPointer(types.float64)(count), codegen


def scratch(n):  # pragma: no cover - replaced by the overload in compiled code
    """``np.empty(n)``; on the stack when ``n`` is a compile-time constant."""
    return np.empty(n)


def small_scratch(n):  # pragma: no cover - replaced by the overload in compiled code
    """``np.empty(n)``; on the stack when ``n`` is a compile-time constant <= SMALL_MAX."""
    return np.empty(n)


def scratch2(n):  # pragma: no cover - replaced by the overload in compiled code
    """``np.empty((n, n))``; on the stack when ``n`` is a compile-time constant."""
    return np.empty((n, n))


@overload(scratch, inline="always", prefer_literal=True)
def _scratch(n):
    if isinstance(n, types.IntegerLiteral) and n.literal_value > 0:
        def impl(n):
            return numba.carray(_stack_ptr(n), (n,))
        return impl
    return lambda n: np.empty(n)


@overload(scratch2, inline="always", prefer_literal=True)
def _scratch2(n):
    if isinstance(n, types.IntegerLiteral) and n.literal_value > 0:
        m = n.literal_value * n.literal_value

        def impl(n):
            return numba.carray(_stack_ptr(m), (n, n))
        return impl
    return lambda n: np.empty((n, n))


@overload(small_scratch, inline="always", prefer_literal=True)
def _small_scratch(n):
    if isinstance(n, types.IntegerLiteral) and 0 < n.literal_value <= SMALL_MAX:
        def impl(n):
            return numba.carray(_stack_ptr(n), (n,))
        return impl
    return lambda n: np.empty(n)
