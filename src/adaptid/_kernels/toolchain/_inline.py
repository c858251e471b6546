"""Faster numba inlining of adaptid's ``inline="always"`` pieces (compile time only).

adaptid's kernels are built of small pieces that numba inlines into each
entry point at its IR level (``@njit(inline="always")``). numba's inliner
(``numba.core.inline_closurecall.InlineWorker.inline_ir``) copies the
callee's IR before splicing it in, and copies it block by block, each with a
``copy.deepcopy`` of its own: every block's copy deep-copies the callee's
whole variable scope again. The cost grows as blocks × variables, and for
adaptid's larger streams it was a large part of the compile time of an entry
point (``benchmarks/bench_coldstart.py --jit`` times the cold compile)
(numba issue #8989; numba-cuda #688 and #689 make the same fix).

:func:`install` makes those copies share one ``deepcopy`` memo per
``inline_ir`` call, so the scope is copied once. The IR handed to the rest of
numba is the same (one scope object where numba made equal copies, which it
replaces by the caller's scope right after), and so is the machine code:
``tests/test_inline_copy.py`` compiles kernels with and without it and
compares the assembly. It applies only while numba inlines into a function of
:mod:`adaptid`; every other package's compilation runs numba's own code.
``ADAPTID_FAST_INLINE=0`` (or ``ADAPTID_NUMBA_PATCHES=0``) in the environment
leaves numba untouched (patch ``fast-inline`` of :mod:`._patches`).
"""

from __future__ import annotations

import copy as _copy
import threading

from numba.core import ir as _ir

from ._patches import enabled

__all__ = ["install", "installed"]

_state = threading.local()


class _SharedMemoCopy:
    """Stands in for the :mod:`copy` module inside numba's inliner.

    ``deepcopy(block)`` without a memo, inside an ``inline_ir`` call, uses one
    memo for all blocks of the same scope (the blocks of one IR then share
    their copied scope); a copy of that copy (numba makes one to return an
    unmutated IR) has a scope of its own and so a memo of its own, and shares
    nothing with the first. Everything else is :func:`copy.deepcopy`.
    """

    copy = staticmethod(_copy.copy)
    Error = _copy.Error

    @staticmethod
    def deepcopy(x, memo=None, _nil=[]):  # noqa: B006 - copy.deepcopy's own signature
        memos = getattr(_state, "memos", None)
        if memo is None and memos is not None and isinstance(x, _ir.Block):
            memo = memos.setdefault(id(x.scope), {})
        return _copy.deepcopy(x, memo, _nil)


def _ours(func_ir) -> bool:
    func_id = getattr(func_ir, "func_id", None)
    return (getattr(func_id, "modname", "") or "").startswith("adaptid.")


def installed() -> bool:
    """Whether :func:`install` has patched numba's inliner in this process."""
    from numba.core import inline_closurecall as icc

    return getattr(icc.InlineWorker.inline_ir, "_adaptid", False)


def install() -> bool:
    """Share one deepcopy memo per inlined call site (see the module's text).

    Returns whether the patch is in place. It is not applied when
    ``ADAPTID_FAST_INLINE=0`` (or ``ADAPTID_NUMBA_PATCHES=0``) or when numba's inliner does not have the shape
    this was written for (``InlineWorker.inline_ir`` and a module-level
    ``copy`` in :mod:`numba.core.inline_closurecall`); numba then runs as it is.
    """
    if not enabled("fast-inline"):
        return False
    try:
        from numba.core import inline_closurecall as icc
    except ImportError:  # pragma: no cover - numba moved its inliner
        return False
    original = getattr(getattr(icc, "InlineWorker", None), "inline_ir", None)
    if original is None or getattr(icc, "copy", None) not in (_copy, _SharedMemoCopy):
        return False
    if getattr(original, "_adaptid", False):
        return True

    def inline_ir(self, caller_ir, *args, **kwargs):
        if not _ours(caller_ir) or getattr(_state, "memos", None) is not None:
            return original(self, caller_ir, *args, **kwargs)
        _state.memos = {}
        try:
            return original(self, caller_ir, *args, **kwargs)
        finally:
            _state.memos = None

    inline_ir._adaptid = True
    inline_ir.__wrapped__ = original
    inline_ir.__doc__ = original.__doc__
    icc.copy = _SharedMemoCopy
    icc.InlineWorker.inline_ir = inline_ir
    return True
