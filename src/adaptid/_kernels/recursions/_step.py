r"""One sample through a narrow compiled entry: what ``update`` calls.

``run``'s entry takes fourteen arguments, eleven of them arrays; calling a
compiled numba function converts ("unboxes") every array argument, and for one
sample that conversion costs more than the arithmetic (``benchmarks/bench_update.py``
times both entries). A step entry takes two arrays and the two size tags::

    step(S, W, ntag, ptag) -> code

``S`` is the estimator's state vector, as for ``run``; ``W`` (shape
``(1, 1, K)``) packs everything else of one sample. Its row ``R = W[0, 0]`` holds,
with n = dim(ntag) and p = dim(ptag):

=====================  ===========================================
``R[0:n]``             φ
``R[n:n+p]``           y
``R[n+p]``             λ (the forgetting factor of this step)
``R[n+p+1]``           w (the sample weight)
``R[n+p+2:n+2p+2]``    ε, the a-priori error (written by the step)
``R[n+2p+2]``          the threshold ``opt[0]`` of ``run``
``R[n+2p+3]``          1.0 when the sample was skipped (written)
=====================  ===========================================

:func:`views` turns ``W`` into the one-sample arguments of a stream body
(Φ (1, n), y (1, p), λ, w, an empty trajectory, E (1, p), skipped), and a
module's ``*_step`` passes them to the same inlined body its ``run`` inlines.
So a step is bit for bit a step of ``run`` (the tests compare them after every
sample). It is a second compiled function per kernel and size, though, so
``update`` uses it only when it costs no compilation (:func:`entry_point`):
already compiled in this process, in numba's cache folder, or compiled when
adaptid was installed (:mod:`._installed`). Otherwise ``update`` is a run of
length 1 through ``run``'s compiled code, as before.
"""

from typing import NamedTuple

from ..._config import NJIT_INLINE, njit
from ..toolchain._dims import dim
from ..toolchain._dispatch import entry_point

__all__ = ["views", "layout", "Layout", "entry_point"]


class Layout(NamedTuple):
    """Offsets in the packed row (the table above) for n parameters and p outputs."""

    y: int
    lam: int
    w: int
    e: int
    threshold: int
    skipped: int
    width: int


@njit(**NJIT_INLINE)
def _offsets(n, p):
    """The one definition of the packed row's layout (compiled code and Python read it)."""
    return (n, n + p, n + p + 1, n + p + 2, n + 2 * p + 2, n + 2 * p + 3, n + 2 * p + 4)


def layout(n, p) -> Layout:
    """The packed row's :class:`Layout` (what ``update`` fills and reads)."""
    return Layout(*getattr(_offsets, "py_func", _offsets)(n, p))


@njit(**NJIT_INLINE)
def views(W, ntag, ptag):
    """The one-sample arguments of a stream body over the packed sample ``W``.

    Returns (Phi, Y, lam, w, Th, E, skipped, threshold): views of ``W`` (no
    allocation); ``Th`` has no rows, so the body stores no trajectory.
    """
    n = dim(ntag)
    iy, il, iw, ie, it, isk, _ = _offsets(n, dim(ptag))
    R = W[0]
    return (R[:, :iy], R[:, iy:il], R[0, il:il + 1], R[0, iw:iw + 1], W[:0], R[:, ie:it],
            R[0, isk:isk + 1], R[0, it])
