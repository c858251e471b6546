r"""LMS and normalised LMS (stochastic gradient): the estimators without a covariance.

Entry points share one signature with every other algorithm (see
:mod:`adaptid._kernels.recursions._rls`)::

    run(S, Phi, Y, lam, w, Th, E, skipped, Lk, St, opt, mat, ntag, ptag) -> code
    run_batched(S, Phi, Y, lam, w, Th, E, skipped, Lk, St, opt, mat, codes, ntag, ptag)
    run_segments(S0, Sout, Phi, Y, offsets, lam, w, Th, E, skipped, Lk, St, opt, mat,
                 codes, ntag, ptag)

with the prefix ``lms_`` (LMS) and ``nlms_`` (NLMS): the normalisation is a
compile-time constant of each set (a run-time flag made NLMS slower,
``benchmarks/bench_lms.py``).
State ``S = [ theta (n·p, row-major (n, p)) ]``: no covariance.
``opt = [windup threshold (unused), step μ, bias ε]``;
``lam``, ``mat``, ``Lk`` and ``St`` are unused (no forgetting). The code is the first
sample after which θ is no longer finite (the gradient diverged: step too
large: the first sample whose a-priori error is not finite, or the last
sample if only the final θ is not), or the first sample of finite data whose
NLMS normalisation ε + φᵀφ overflowed or fell below the smallest normal
float with φ ≠ 0 (data of size 1e300, or 1e-160 and 1e-300 with ε = 0: the
step is then 0 or meaningless), or −1. The overflow is found in the exact
re-check of a non-finite sum (off the fast path); the underflow test runs
only when ε < TINY (a loop-invariant branch: the default ε = eps(1) bounds
ε + φᵀφ below). Per sample (MATLAB
``recursiveLS``, EstimationMethod
``Gradient`` / ``NormalizedGradient``; padasip ``FilterLMS`` / ``FilterNLMS``):

.. math::

    \varepsilon_k = y_k - \varphi_k^T\theta_{k-1},\qquad
    \theta_k = \theta_{k-1} + g_k\,\varphi_k\,\varepsilon_k^T,\qquad
    g_k = \mu w_k \;\text{(LMS)},\quad
    g_k = \frac{\mu w_k}{\epsilon + \varphi_k^T\varphi_k} \;\text{(NLMS)}.

The increment is formed as padasip forms it, ``(g φᵢ) εⱼ``; the dot products
φᵀθ and φᵀφ are summed in four partial sums for n ≥ 8 (see :func:`_dot`). A sample with a
non-finite value is skipped (θ untouched, error NaN, ``skipped`` set).
"""

import numpy as np

from ..._config import NJIT, NJIT_INLINE, njit
from ..toolchain._dims import dim
from ..toolchain._scratch import scratch, small_scratch
from ._bierman import _finite_row
from ._entries import Entries
from ._parallel import batched, segments

#: the smallest normal float64: a φᵀφ below it has lost its precision (subnormal) or is 0
TINY = np.finfo(np.float64).tiny


@njit(**NJIT_INLINE)
def _dot(c, sign, A, k, b, off, stride, NP, square):
    """c + sign·Σᵢ A[k, i] b[off + i·stride] (sign ±1), or with ``square`` (a
    compile-time constant) c + Σᵢ A[k, i]²; for NP ≥ 8 in four interleaved sums.

    The error's dot product is the loop-carried critical path of LMS (θₖ needs
    εₖ needs θₖ₋₁): one chain of NP dependent FMAs left NLMS behind the C loop
    at n = 16; four chains cut its latency (``benchmarks/bench_lms.py``). The
    sum differs from the sequential one by rounding only.
    For NP < 8 it is the sequential sum started from c, as the C loop does.
    Φ's row k is read in place: a row view ``Phi[k]`` per sample cost a
    reference count increment and decrement, two calls that also pushed θ out
    of the registers at n = 16 (``benchmarks/bench_lms.py``).
    """
    if NP >= 8:
        s0 = c
        s1 = 0.0
        s2 = 0.0
        s3 = 0.0
        m = NP - NP % 4
        for i in range(0, m, 4):
            s0 += sign * A[k, i] * (A[k, i] if square else b[off + i * stride])
            s1 += sign * A[k, i + 1] * (A[k, i + 1] if square else b[off + (i + 1) * stride])
            s2 += sign * A[k, i + 2] * (A[k, i + 2] if square else b[off + (i + 2) * stride])
            s3 += sign * A[k, i + 3] * (A[k, i + 3] if square else b[off + (i + 3) * stride])
        for i in range(m, NP):
            s0 += sign * A[k, i] * (A[k, i] if square else b[off + i * stride])
        return (s0 + s1) + (s2 + s3)
    s = c
    for i in range(NP):
        s += sign * A[k, i] * (A[k, i] if square else b[off + i * stride])
    return s


@njit(**NJIT)  # a call, not inlined: the cold path stays out of the loop's code
def _lost_norm(q, Phi, k, NP):
    """Whether NLMS's ε + φᵀφ of finite data lost the sample: overflowed (the
    step μw/q is then 0) or fell below the smallest normal float with φ ≠ 0
    (ε < TINY only: the step is then 0 or wildly rounded). φ = 0 with ε = 0 is
    not. Called only off the fast path."""
    if not q < np.inf:
        return True
    if q >= TINY:
        return False
    nz = False
    for i in range(NP):
        nz |= Phi[k, i] != 0.0
    return nz


@njit(**NJIT_INLINE)
def _lms_stream(S, Phi, Y, w, Th, E, skipped, opt, NP, p, norm):
    # θ is worked on in a stack copy when p = 1 (see _scratch and _rls): LLVM
    # then knows that the stores to the trajectory cannot change it and keeps
    # it in registers instead of reloading it after each one.
    if p == 1:
        th = scratch(NP)
    else:
        th = np.empty(NP * p)
    for i in range(NP * p):
        th[i] = S[i]
    mu = opt[1]
    bias = opt[2]
    low = bias < TINY
    e = small_scratch(p)
    store = Th.shape[0] == Phi.shape[0]
    bad = -1
    for k in range(Phi.shape[0]):
        # Finiteness of the sample, cheaply: εⱼ = yⱼ − φᵀθ is finite only if
        # yⱼ and all of φ are (a NaN or ±inf φᵢ makes φᵢθᵢⱼ NaN or ±inf, θᵢⱼ = 0
        # included), and q = ε + φᵀφ (NLMS) only if φ is. All finite (the usual
        # case): use the sample. Otherwise (a NaN / inf in the data, φᵀφ
        # overflowing, or θ diverged) decide exactly on the values. This
        # replaced a test of every φᵢ that slowed NLMS (bench_lms.py); LMS forms
        # no φᵀφ (n more products per sample).
        if norm:
            q = _dot(bias, 1.0, Phi, k, th, 0, 0, NP, True)
            ok = q - q == 0.0
            if low:  # loop-invariant: only with ε < TINY can ε + φᵀφ fall below TINY
                ok &= q >= TINY
        else:
            q = 0.0
            ok = True
        for j in range(p):
            s = _dot(Y[k, j], -1.0, Phi, k, th, j, p, NP, False)
            e[j] = s
            ok &= s - s == 0.0
        if not ok:
            ok = _finite_row(Phi[k], Y[k], NP, p)
            if ok and bad < 0:
                for j in range(p):
                    if not (e[j] - e[j] == 0.0):  # finite data, non-finite error: diverged
                        bad = k
                if norm and _lost_norm(q, Phi, k, NP):
                    bad = k
        if ok:
            for j in range(p):
                E[k, j] = e[j]
            g = mu * w[k]
            if norm:
                g = g / q if q > 0.0 else 0.0  # φ = 0 with ε = 0: no step
            for i in range(NP):
                gi = g * Phi[k, i]
                for j in range(p):
                    th[i * p + j] += gi * e[j]
        else:
            skipped[k] = True
            for j in range(p):
                E[k, j] = np.nan
        if store:
            for i in range(NP):
                for j in range(p):
                    Th[k, i, j] = th[i * p + j]
    fin = True
    for i in range(NP * p):
        S[i] = th[i]
        fin &= th[i] - th[i] == 0.0
    if bad < 0 and not fin:
        bad = Phi.shape[0] - 1
    return bad


# ---------------------------------------------------------------- LMS
@njit(**NJIT)
def lms_run(S, Phi, Y, lam, w, Th, E, skipped, Lk, St, opt, mat, ntag, ptag):
    """N LMS steps; returns the first sample whose error is not finite (divergence), or -1."""
    return _lms_stream(S, Phi, Y, w, Th, E, skipped, opt, dim(ntag), dim(ptag), False)


lms_run_batched = batched(lms_run, "lms_run_batched")
lms_run_segments = segments(lms_run, "lms_run_segments")


# ---------------------------------------------------------------- NLMS
@njit(**NJIT)
def nlms_run(S, Phi, Y, lam, w, Th, E, skipped, Lk, St, opt, mat, ntag, ptag):
    """N NLMS steps; returns as :func:`lms_run`."""
    return _lms_stream(S, Phi, Y, w, Th, E, skipped, opt, dim(ntag), dim(ptag), True)


nlms_run_batched = batched(nlms_run, "nlms_run_batched")
nlms_run_segments = segments(nlms_run, "nlms_run_segments")


#: this module's entry points, by the name adaptid._kernels gives them
ENTRIES = {"LMS": Entries(lms_run, lms_run_batched, lms_run_segments),
           "NLMS": Entries(nlms_run, nlms_run_batched, nlms_run_segments)}
