"""Compile-time sizes: the tags that specialise a kernel per n and p.

Every entry point of the recursive kernels takes two tags, ``ntag`` and
``ptag``, and reads the sizes from them with :func:`dim`:

* a tuple ``(0,) * n`` (numba type ``UniTuple(int64, n)``) gives ``n`` as a
  compile-time constant: LLVM unrolls the small loops, keeps the factor in
  registers, and :func:`~adaptid._kernels._scratch.scratch` puts the work
  arrays on the stack. Each n is one more compiled signature, cached on disk
  by numba like any other (``cache=True``): no source is generated anywhere.
* an ``int`` gives the size at run time (the generic kernel, one signature
  for every n).

:func:`tags` chooses: tuples for n ≤ ``MAX_SPECIALISED_N`` and for p = 1
(the common single-output case), ints otherwise.
"""

import os

from numba import types
from numba.extending import overload

from .. import _config

__all__ = ["dim", "tags"]


def dim(tag):  # pragma: no cover - replaced by the overload in compiled code
    """The size a tag stands for (``len`` of a tuple tag, or the int itself)."""
    return len(tag) if isinstance(tag, tuple) else int(tag)


@overload(dim, inline="always")
def _dim(tag):
    if isinstance(tag, types.UniTuple):
        size = tag.count

        def impl(tag):
            return size  # a constant of the closure: typed as a literal
        return impl
    if isinstance(tag, (types.BaseTuple,)) and len(tag) == 0:
        return lambda tag: 0
    if isinstance(tag, types.Integer):
        return lambda tag: tag
    return None


def tags(n: int, p: int):
    """(ntag, ptag) for a state of n parameters and p outputs."""
    if os.environ.get("NUMBA_DISABLE_JIT") == "1":
        return n, p
    ntag = (0,) * n if n <= _config.MAX_SPECIALISED_N else n
    ptag = (0,) if p == 1 else p
    return ntag, ptag
