"""Compile-time choices of implementation, by argument type (numba's ``@overload``).

Two kinds, each a plain Python function replaced in compiled code:

* :func:`on_none` — a hook that compiles to nothing when its first argument is
  None (the windowed statistics of ``run(..., stats=True)``: without them
  the streams carry no trace of the hooks);
* :func:`by_constant_n` — a sweep that runs as hand-built LLVM vector code
  when n (its last argument) is a compile-time constant, and as plain loops
  otherwise or when patch ``vector-ir`` is off (:mod:`._patches`).
"""

from numba import types
from numba.extending import overload

from ._vecir import VECTOR_IR

__all__ = ["on_none", "by_constant_n"]


def on_none(fn, noop, impl=None):
    """In compiled code ``fn(St, ...)`` is ``noop`` when St is None and ``impl``
    (default: ``fn`` itself) otherwise, inlined. Returns ``fn``."""
    body = fn if impl is None else impl

    @overload(fn, inline="always", strict=False)
    def _choose(St, *rest):  # called by numba with the argument types
        return noop if isinstance(St, types.NoneType) else body
    return fn


def by_constant_n(fn, vector, plain, *, largest=None, jit_options=None):
    """In compiled code ``fn(..., NP)`` is ``vector`` when NP is a compile-time
    constant (≤ ``largest`` if given) and patch ``vector-ir`` is on, else ``plain``;
    inlined either way. Returns ``fn``."""
    @overload(fn, inline="always", prefer_literal=True, strict=False, jit_options=jit_options or {})
    def _choose(*args):
        NP = args[-1]
        if VECTOR_IR and isinstance(NP, types.IntegerLiteral) and \
                (largest is None or NP.literal_value <= largest):
            return vector
        return plain
    return fn
