"""Compile-time sizes: the tags that specialise a kernel per n and p.

Every entry point of the recursive kernels takes two tags, ``ntag`` and
``ptag``, and reads the sizes from them with :func:`dim`:

* a tuple ``(0,) * n`` (numba type ``UniTuple(int64, n)``) gives ``n`` as a
  compile-time constant: LLVM unrolls the small loops, keeps the factor in
  registers, and :func:`~adaptid._kernels.toolchain._scratch.scratch` puts the work
  arrays on the stack. Each n is one more compiled signature, cached on disk
  by numba like any other (``cache=True``): no source is generated anywhere.
* an ``int`` gives the size at run time (the generic kernel, one signature
  for every n).

:func:`tags` chooses: tuples for n ≤ ``MAX_SPECIALISED_N`` and for p = 1
(the common single-output case), ints otherwise.
"""

import os

from numba import types
from numba.core.typing.templates import AbstractTemplate, infer_global, signature
from numba.extending import lower_builtin

from ... import _config

__all__ = ["dim", "size_tag", "tags"]


def dim(tag):  # pragma: no cover - replaced by the overload in compiled code
    """The size a tag stands for (``len`` of a tuple tag, or the int itself)."""
    return len(tag) if isinstance(tag, tuple) else int(tag)


@infer_global(dim)
class _DimTyper(AbstractTemplate):
    """``dim(tag)``: a tuple tag's length as an integer literal (a compile-time
    constant that :func:`~._scratch.scratch` and LLVM see), an int tag itself.

    A typing template and a lowering rather than an inlined ``@overload``: typing
    a call is then a template lookup, not a compiled and inlined implementation
    per call site.
    """
    prefer_literal = True

    def generic(self, args, kws):
        if len(args) != 1 or kws:
            return None
        tag = args[0]
        if isinstance(tag, types.UniTuple):
            return signature(types.literal(tag.count), tag)
        if isinstance(tag, types.BaseTuple) and len(tag) == 0:
            return signature(types.literal(0), tag)
        if isinstance(tag, types.Integer):
            return signature(tag, tag)
        return None


@lower_builtin(dim, types.BaseTuple)
def _dim_tuple(context, builder, sig, args):
    return context.get_constant(types.intp, len(sig.args[0]))


@lower_builtin(dim, types.Integer)
def _dim_int(context, builder, sig, args):
    return args[0]


def tags(n: int, p: int):
    """(ntag, ptag) for a state of n parameters and p outputs."""
    if os.environ.get("NUMBA_DISABLE_JIT") == "1":
        return n, p
    ntag = (0,) * n if n <= _config.MAX_SPECIALISED_N else n
    ptag = (0,) if p == 1 else p
    return ntag, ptag


def size_tag(n):  # pragma: no cover - replaced by the typing below in compiled code
    """The tag of a size: the inverse of :func:`dim` (ints stay ints in Python)."""
    return n


@infer_global(size_tag)
class _SizeTagTyper(AbstractTemplate):
    """``size_tag(n)``: ``(0,) * n`` for a compile-time constant n, else n itself.

    Lets a kernel that holds n as a constant pass it on to a kernel that is
    compiled separately (not inlined) without losing the specialisation.
    """
    prefer_literal = True

    def generic(self, args, kws):
        if len(args) != 1 or kws or not isinstance(args[0], types.Integer):
            return None
        n = args[0]
        if isinstance(n, types.IntegerLiteral) and n.literal_value >= 0:
            return signature(types.UniTuple(types.int64, n.literal_value), n)
        return signature(n, n)


@lower_builtin(size_tag, types.Integer)
def _size_tag(context, builder, sig, args):
    if isinstance(sig.return_type, types.UniTuple):
        zero = context.get_constant(types.int64, 0)
        return context.make_tuple(builder, sig.return_type, [zero] * sig.return_type.count)
    return args[0]
