"""The stack scratch arrays of the specialised kernels (adaptid._kernels.toolchain._scratch).

The speed of the RLS kernel depends on these arrays really being on the stack
when n is a compile-time constant (benchmarks/bench_rls.py). numba picks the
overload by the argument's literal type, so a change in numba's literal
dispatch would silently fall back to the heap. These tests look at the
generated LLVM IR for a heap allocation.
"""

import numpy as np
import pytest
from numba import njit

from adaptid import _kernels
from adaptid._config import NJIT
from adaptid._kernels.toolchain._scratch import SMALL_MAX, scratch, scratch2, small_scratch


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


def test_rls_kernel_allocates_nothing_on_the_heap():
    """In the n = 4, p = 1 RLS run kernel (tuple tags: sizes known at compile
    time, adaptid._kernels.toolchain._dims) every work array -- the factor copy, the
    work vectors, the error vector -- is on the stack."""
    import adaptid
    from adaptid._kernels.recursions import _rls
    from numba import types

    est = adaptid.RLS(4, forgetting=0.99)
    est.run(np.ones((3, 4)), np.ones(3))
    cached = _rls.rls_run
    sig = [s for s in cached.signatures
           if isinstance(s[-2], types.UniTuple) and s[-2].count == 4][0]
    # a fresh, uncached compilation of the same kernel: numba does not keep
    # the IR of code loaded from its disk cache
    kern = njit(**{**NJIT, "cache": False})(cached.py_func)
    kern.compile(sig)
    ir = kern.inspect_llvm(sig)
    allocs = [line for line in ir.splitlines()
              if "NRT_MemInfo_alloc" in line and not line.lstrip().startswith("declare")]
    assert allocs == []


def _run_with_tags(est, Phi, y, ntag, ptag):
    """est.run through the kernels, with the given size tags."""
    est._ntag, est._ptag = ntag, ptag
    return est.run(Phi, y)


@pytest.mark.parametrize("make", [
    lambda n: __import__("adaptid").RLS(n, forgetting=0.98, P0=1e6),
    lambda n: __import__("adaptid").RLS(n, forgetting=__import__("adaptid").forgetting.Directional(0.97)),
    lambda n: __import__("adaptid").SlidingWindowRLS(n, 30, forgetting=0.99),
    lambda n: __import__("adaptid").KalmanRLS(n, process_cov=1e-4),
    # (form="covariance" is compiled for n <= 64 whatever the engine's tags, generic
    # kernels included: its generic build, for n > 64 only, is not bit for bit it)
    lambda n: __import__("adaptid").RLS(n, forgetting=0.98, form="sqrt"),
    lambda n: __import__("adaptid").RLS(n, forgetting=0.98, P0="diffuse"),
    lambda n: __import__("adaptid").SlidingWindowRLS(n, 30, P0="diffuse"),
    lambda n: __import__("adaptid").KalmanRLS(n, process_cov=1e-4, P0="diffuse"),
    lambda n: __import__("adaptid").LMS(n, step=0.01),
    lambda n: __import__("adaptid").NLMS(n, step=0.5, eps=1e-6),
], ids=["rls", "strategy", "window", "kalman", "sqrt", "rls-diffuse",
        "window-diffuse", "kalman-diffuse", "lms", "nlms"])
def test_specialised_and_generic_kernels_agree_bit_for_bit(make):
    """The same kernel source compiled with n as a compile-time constant (tuple
    tag) and as a run-time value (int tag) gives identical numbers.

    p = 1 keeps its tuple tag in both, as the engine tags a single output: the
    generic-n build is then the one that the files running on
    ``size_generic_kernels()`` compile anyway (see conftest), not one more
    signature per algorithm. A
    run-time p is compared with p = 1 bit for bit by
    ``test_recursive.py::test_multi_output_equals_single_outputs``."""
    rng = np.random.default_rng(3)
    n = 3
    Phi = rng.standard_normal((400, n))
    y = Phi @ rng.standard_normal(n) + 0.1 * rng.standard_normal(400)
    spec = _run_with_tags(make(n), Phi, y, (0,) * n, (0,))
    gen = _run_with_tags(make(n), Phi, y, n, (0,))
    np.testing.assert_array_equal(spec.theta, gen.theta)
    np.testing.assert_array_equal(spec.error, gen.error)


@pytest.mark.parametrize("make", [
    lambda n: __import__("adaptid").SlidingWindowRLS(n, 30, forgetting=0.99),
    lambda n: __import__("adaptid").SlidingWindowRLS(n, 30, P0="diffuse"),
    lambda n: __import__("adaptid").RLS(n, forgetting=0.98),
], ids=["window", "window-diffuse", "rls"])
def test_window_statistics_specialised_and_generic_agree_bit_for_bit(make):
    """The statistics hooks compiled with compile-time and run-time n agree (p = 1
    tagged as the engine tags it, as above)."""
    rng = np.random.default_rng(4)
    n = 3
    Phi = rng.standard_normal((300, n))
    y = Phi @ rng.standard_normal(n) + 0.1 * rng.standard_normal(300)
    runs = []
    for ntag, ptag in (((0,) * n, (0,)), (n, (0,))):
        est = make(n)
        est._ntag, est._ptag = ntag, ptag
        runs.append(est.run(Phi, y, stats=True))
    np.testing.assert_array_equal(runs[0].theta, runs[1].theta)
    for field in ("ssr", "sigma2", "stderr", "rsquared", "llf", "aic", "bic"):
        np.testing.assert_array_equal(getattr(runs[0].stats, field), getattr(runs[1].stats, field))
