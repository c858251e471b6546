"""Fixed-size scratch arrays on the stack, for the specialised kernels.

``scratch(n)`` / ``scratch2(n)`` behave like ``np.empty(n)`` /
``np.empty((n, n))``. When ``n`` is a compile-time constant (the kernels
called with tuple size tags, see :mod:`adaptid._kernels.toolchain._dims`) the
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
With patch ``stack-scratch`` off (:mod:`._patches`) every one is ``np.empty``.
"""

import numpy as np
from numba import types
from numba.core import cgutils
from numba.core.typing.templates import AbstractTemplate, infer_global, signature
from numba.extending import intrinsic, lower_builtin
from numba.np.arrayobj import make_array, populate_array

from ._patches import enabled

__all__ = ["scratch", "scratch2", "scratch2_lines", "small_scratch", "STACK"]

#: patch ``stack-scratch`` (:mod:`._patches`): off, every scratch array is ``np.empty``
STACK = enabled("stack-scratch")

#: ``small_scratch`` is on the stack up to this length. With the RLS kernel the
#: work vectors on the stack are faster at n = 8 but slower at n = 16 (LLVM
#: promotes them to registers and spills the factor; benchmarks/bench_rls.py).
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


def scratch2_lines(n):  # pragma: no cover - replaced by the lowering in compiled code
    """``scratch2(n)`` aligned to 64 bytes: for 8 | n each row starts a cache line (the
    covariance form's P: vector loads of a row never straddle two lines; faster at
    n = 8, see ``benchmarks/bench_rls.py --forms``)."""
    return np.empty((n, n))


def _c_array(context, builder, arrty, data, shape):
    """An array struct over ``data`` (no owner: lives as long as the frame)."""
    intp = lambda v: context.get_constant(types.intp, v)  # noqa: E731
    strides, step = [], 8
    for extent in reversed(shape):
        strides.insert(0, intp(step))
        step *= extent
    ary = make_array(arrty)(context, builder)
    populate_array(ary, data=data, shape=cgutils.pack_array(builder, [intp(s) for s in shape]),
                   strides=cgutils.pack_array(builder, strides), itemsize=intp(8), meminfo=None)
    return ary._getvalue()


def _register(fn, ndim, largest, align=None):
    """Typing and lowering of ``fn(n)``: an (n,)*ndim float64 array, on the stack when n
    is a compile-time constant in (0, largest], else ``np.empty``.

    Written as a typing template and a lowering (not an inlined ``@overload``):
    the alloca is emitted straight into the caller's entry block, and typing a
    call costs a template lookup instead of compiling and inlining an
    implementation at every call site (a noticeable share of a kernel's compile
    time, ``benchmarks/bench_coldstart.py --jit``).
    """
    arrty = types.Array(types.float64, ndim, "C")

    @infer_global(fn)
    class _Typer(AbstractTemplate):
        prefer_literal = True  # the lowering must see the literal size

        def generic(self, args, kws):
            if len(args) == 1 and not kws and isinstance(args[0], types.Integer):
                return signature(arrty, args[0])
            return None

    @lower_builtin(fn, types.Integer)
    def _lower(context, builder, sig, args):
        n = sig.args[0]
        if STACK and isinstance(n, types.IntegerLiteral) and 0 < n.literal_value <= largest:
            size = n.literal_value
            data = cgutils.alloca_once(builder, context.get_value_type(types.float64),
                                       size=context.get_constant(types.intp, size ** ndim))
            if align is not None:
                data.align = align
            return _c_array(context, builder, arrty, data, (size,) * ndim)
        empty = (lambda m: np.empty(m)) if ndim == 1 else (lambda m: np.empty((m, m)))
        return context.compile_internal(builder, empty, signature(arrty, types.intp),
                                        [context.cast(builder, args[0], n, types.intp)])


_register(scratch, 1, 1 << 30)
_register(scratch2, 2, 1 << 15)
_register(small_scratch, 1, SMALL_MAX)
_register(scratch2_lines, 2, 1 << 15, align=64)
