"""The stack scratch arrays of the specialised kernels (adaptid._kernels._scratch).

The speed of the RLS kernel depends on these arrays really being on the stack
when n is a compile-time constant (BENCHMARKS.md, run 5). numba picks the
overload by the argument's literal type, so a change in numba's literal
dispatch would silently fall back to the heap. These tests look at the
generated LLVM IR for a heap allocation.
"""

import numpy as np
import pytest
from numba import njit

from adaptid import _kernels
from adaptid._config import NJIT
from adaptid._kernels._scratch import SMALL_MAX, scratch, scratch2, small_scratch


def _heap_allocs(fn):
    ir = fn.inspect_llvm(fn.signatures[0])
    return [line for line in ir.splitlines()
            if "NRT_MemInfo_alloc" in line and not line.lstrip().startswith("declare")]


@njit(inline="always")
def _fill(NP):
    a = scratch(NP)
    U = scratch2(NP).T
    s = small_scratch(NP)
    for i in range(NP):
        a[i] = i
        s[i] = 2.0 * i
        for j in range(NP):
            U[i, j] = 10.0 * i + j
    return a.sum() + U.sum() + s.sum() + U[0, NP - 1]


@njit
def _literal4():
    NP = 4  # a constant, as in the specialised kernels
    return _fill(NP)


@njit
def _literal16():
    NP = 16
    return _fill(NP)


@njit
def _runtime(n):
    return _fill(n)


def _expected(n):
    i = np.arange(n, dtype=float)
    U = 10.0 * i[:, None] + i[None, :]
    return i.sum() + U.sum() + 2.0 * i.sum() + U[0, n - 1]


@pytest.mark.parametrize("fn, n", [(_literal4, 4), (_literal16, 16)])
def test_literal_size_is_on_the_stack(fn, n):
    assert fn() == _expected(n)
    allocs = _heap_allocs(fn)
    if n <= SMALL_MAX:
        assert allocs == []
    else:  # small_scratch goes to the heap above SMALL_MAX, the others stay on the stack
        assert len(allocs) == 1


def test_runtime_size_falls_back_to_the_heap():
    assert _runtime(3) == _expected(3)
    assert _runtime(20) == _expected(20)
    assert len(_heap_allocs(_runtime)) == 3


def test_rls_kernel_allocates_nothing_of_known_size_on_the_heap():
    """In the specialised n = 4 RLS run kernel every array whose size is known
    at compile time (the factor copy, the work vectors; p = 1) is on the stack.
    The one heap allocation left is the error vector of the multi-output path,
    whose length p is known only at run time."""
    import re

    import adaptid

    est = adaptid.RLS(4, forgetting=0.99)
    est.run(np.ones((3, 4)), np.ones(3))
    cached = _kernels.get(4).rls_run
    sig = [s for s in cached.signatures if s[1].ndim == 2][0]
    # a fresh, uncached compilation of the same kernel: numba does not keep
    # the IR of code loaded from its disk cache
    kern = njit(**{**NJIT, "cache": False})(cached.py_func)
    kern.compile(sig)
    ir = kern.inspect_llvm(sig)
    allocs = [line for line in ir.splitlines()
              if "NRT_MemInfo_alloc" in line and not line.lstrip().startswith("declare")]
    constant = [a for a in allocs if re.search(r"NRT_MemInfo_alloc\w*\(i64 \d+", a)]
    assert constant == []
    assert len(allocs) == 1
