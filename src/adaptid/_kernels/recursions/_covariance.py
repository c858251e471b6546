r"""RLS with exponential forgetting in covariance form: ``RLS(form="covariance")``.

Same entry points and signature as :mod:`._rls`; the covariance block of the
state is ``[theta (n·p) | P (n·n, full, exactly symmetric) | 0 (n)]``. The
arithmetic is that of MATLAB's ``recursiveLS`` and of the C loop
``rls_fu_nN`` of ``rls_ref.c`` (r = λ/w):

.. math::

    u = P\varphi,\quad d = r + \varphi^T u,\quad
    \theta \leftarrow \theta + u\,\varepsilon/d,\quad c = u/\sqrt d,\quad
    P_{ij} \leftarrow (P_{ij} - c_i c_j)/\lambda,

where :math:`c_i c_j = c_j c_i` bit for bit keeps P exactly symmetric
(Ljung & Söderström 1983, eq. 2.19, with the symmetric rank-one form). For
n ≤ ``SQRT_FREE_N`` (4) the rank-one term is formed as
:math:`(u_i u_j)\cdot(1/d)` instead, in one fused multiply-add with
:math:`P_{ij}` (as symmetric, bit for bit, and the same in exact arithmetic):
at these sizes the update is bound by the latency of one
sample's chain of dependent operations, and this takes the square root off it.
The P update of sample k is fused with :math:`u = P\varphi_{k+1}` of the next
(``u += P[j, :] φⱼ``, an axpy LLVM vectorises); one sweep over P per sample.
For a compile-time 4 < n ≤ ``VECTOR_SWEEP_MAX`` (32 on AMD Zen, 64 elsewhere)
the sweep, with c = u/√d, is hand-written LLVM
vector code (:mod:`._covsweep`: numba leaves the SLP vectoriser off, and the
unrolled loops of c and of the sweep stayed scalar); the same operations.
From n = 8 on, :math:`\varphi^T u` is summed in 8 partial sums added as a
tree (a chain of n/8 + 3 dependent adds instead of n).

Per sample the kernel adds to the C loop only what the semantics need: a
non-finite prior error ε triggers the exact check of φ and y (ε finite ⇒ φ, y
finite); 1/λ is recomputed only when λ changes; the diagonal is checked on its
bits (:func:`_sweep`); θ and P live in stack copies (P 64-byte aligned).

Definiteness monitor and repair
-------------------------------
Rounding can make this form indefinite (e.g. λ ≪ 1 with a direction that is
not excited: P's eigenvalues then differ by more than 1/ε). When
:math:`\varphi^T P\varphi \le 0` for a nonzero φ (checked before the update)
or a diagonal entry of P is not positive (after it), P is **repaired**: a
modified LDLᵀ factorisation (Gill & Murray 1974) :math:`P = U\,\mathrm{diag}(D)\,U^T`
is formed with each pivot raised to at least ``ε·max|Pᵢᵢ|``, and P is set to
:math:`U\,\mathrm{diag}(D)\,U^T` (symmetric, positive definite; directions
with positive pivots are unchanged). We chose this repair over restoring the
last good P (a copy of P per sample would cost a second sweep) and over an
eigen-decomposition (LAPACK inside the kernel, no better here).

Return code: the first sample after which a diagonal entry of P passed the
windup threshold ``opt[0]`` or was not finite (≥ 0); else ``−2 − k`` if P was
repaired, k the first repaired sample; else −1 (``update``, a run of length 1 or
:func:`cov_step`, reads the same code).
"""

import numpy as np

from ..._config import NJIT, NJIT_INLINE, njit
from ..toolchain._covsweep import BINF, VECTOR_SWEEP_MAX, quad_n, sweep_scaled_n, theta_step, \
    vector_quad
from ..toolchain._dims import dim
from ..toolchain._scratch import scratch, scratch2_lines
from ..toolchain._specialise import by_constant_n
from ..toolchain._vecir import fma
from ._bierman import _views
from ._entries import Entries
from ._parallel import batched, segments
from ._step import views

EPS = 2.220446049250313e-16
#: up to this n the rank-one term is (u uᵀ)/d, no square root on the critical path
SQRT_FREE_N = 4
#: from this n on the prior error is summed in 8 lanes and a tree (see _prior_error)
TREE_ERROR_N = 16
_OPTS = {"fastmath": NJIT["fastmath"]}


@njit(**NJIT)
def cov_repair(P):
    """P ← U diag(D) Uᵀ of a modified upper LDLᵀ of P (pivots ≥ ε·max|Pᵢᵢ|).

    Only reached when the monitor fired; allocates. Returns the number of
    pivots that were raised.
    """
    n = P.shape[0]
    m = 0.0
    for i in range(n):
        if np.isfinite(P[i, i]) and abs(P[i, i]) > m:
            m = abs(P[i, i])
    floor = EPS * m if m > 0.0 else 1e-300
    U = np.zeros((n, n))
    D = np.empty(n)
    raised = 0
    for j in range(n - 1, -1, -1):
        d = P[j, j]
        for k in range(j + 1, n):
            d -= D[k] * U[j, k] * U[j, k]
        if not d > floor:
            d = floor
            raised += 1
        D[j] = d
        U[j, j] = 1.0
        for i in range(j):
            s = P[i, j]
            for k in range(j + 1, n):
                s -= D[k] * U[i, k] * U[j, k]
            U[i, j] = s / d
    for i in range(n):
        for j in range(i, n):
            s = 0.0
            for k in range(j, n):
                s += U[i, k] * D[k] * U[j, k]
            P[i, j] = s
            P[j, i] = s
    return raised


@njit(**NJIT_INLINE)
def _matvec(P, Phi, k, u, NP):
    """u = Pφₖ as Σⱼ φⱼ P[j, :] (P symmetric): the sweep's arithmetic."""
    for i in range(NP):
        u[i] = 0.0
    for j in range(NP):
        pj = Phi[k, j]
        for i in range(NP):
            u[i] += P[j, i] * pj


@njit(**NJIT_INLINE)
def _sweep(P, c, u, s, il, Phi, kn, bd, NP):
    """P ← (P − c cᵀ·s)/λ row by row (s = 1/d when n ≤ SQRT_FREE_N, else c is
    already u/√d), u ← P φ_next; returns (diag in (0, dthr), diag > 0, NaN: the next
    sample's φᵀu is summed by the caller).

    The diagonal is checked on its bits (int64): for a double x and a
    positive threshold with bits ``bd``, ``0 < x < thr`` ⇔ ``0 < bits(x) < bd``
    and ``x > 0`` ⇔ ``0 < bits(x) ≤ bits(+inf)`` (NaN and negatives fail).
    """
    for i in range(NP):
        u[i] = 0.0
    Pb = P.view(np.int64)
    ns = -s
    lo = BINF
    hi = 0
    for j in range(NP):
        cj = c[j]
        pj = Phi[kn, j]
        if NP <= SQRT_FREE_N:
            for i in range(NP):
                # one fma per entry, written out: left to LLVM, ``P - (cⱼcᵢ)·s`` was fused
                # only where the product had one use (the diagonal), which the lanes of
                # _soa_cov could not reproduce (there, every product has one use)
                v = fma(cj * c[i], ns, P[j, i]) * il
                P[j, i] = v
                u[i] += v * pj
        else:
            for i in range(NP):
                v = (P[j, i] - cj * c[i]) * il
                P[j, i] = v
                u[i] += v * pj
        b = Pb[j, j]
        lo = min(lo, b)
        hi = max(hi, b)
    return (lo > 0) & (hi < bd), (lo > 0) & (hi <= BINF), np.nan


@njit(**NJIT_INLINE)
def _prior_error(theta, tflat, Phi, Y, k, e, NP, p):
    """e = y − Θᵀφ; whether every eⱼ is finite. From n = ``TREE_ERROR_N`` on,
    Θᵀφ is summed as :func:`_quad` sums (8 lanes and a tree; ``tflat`` is Θ's
    storage, row-major): the sequential chain of n multiply-adds is the
    loop-carried path θₖ → εₖ₊₁ → θₖ₊₁, and it could not overlap the sweep
    before it (faster at n = 32 and 64: ``benchmarks/bench_rls.py --forms``).

    With θ finite, a finite eⱼ means φ and y are finite (a non-finite φᵢ or yⱼ
    makes its term, and then the sum, non-finite: ∞·0 is NaN); a non-finite θ
    makes every e non-finite, and the caller then checks the sample itself.
    """
    fin = True
    for j in range(p):
        if NP >= TREE_ERROR_N:
            s = Y[k, j] - _quad(Phi, k, tflat, j, p, NP)
        else:
            s = Y[k, j]
            for i in range(NP):
                s -= Phi[k, i] * theta[i, j]
        e[j] = s
        fin &= s - s == 0.0
    return fin


@njit(**NJIT_INLINE)
def _finite_sample(Phi, Y, k, NP, p):
    ok = True
    for i in range(NP):
        ok &= Phi[k, i] - Phi[k, i] == 0.0
    for j in range(p):
        ok &= Y[k, j] - Y[k, j] == 0.0
    return ok


@njit(**NJIT_INLINE)
def _quad(Phi, k, u, off, stride, NP):
    """Σᵢ φᵢ u[off + i·stride] (φᵀu: off 0, stride 1); from n = 8 on in 8 partial
    sums added as a tree (a short chain). For a compile-time 8 ≤ n ≤
    ``VECTOR_SWEEP_MAX`` and stride 1, the same lanes and tree as LLVM vector code
    (:func:`._covsweep.quad_n`; numba does not SLP-vectorise the unrolled loops)."""
    if vector_quad(NP, stride):  # a compile-time constant: one branch is compiled
        return quad_n(Phi, k, u, off, NP)
    if NP < 8:
        q = 0.0
        for i in range(NP):
            q += Phi[k, i] * u[off + i * stride]
        return q
    a = scratch(8)
    for m in range(8):
        a[m] = Phi[k, m] * u[off + m * stride]
    top = NP - NP % 8
    for i in range(8, top, 8):
        for m in range(8):
            a[m] += Phi[k, i + m] * u[off + (i + m) * stride]
    for m in range(4):
        a[m] += a[m + 4]
    for m in range(2):
        a[m] += a[m + 2]
    q = a[0] + a[1]
    for i in range(top, NP):
        q += Phi[k, i] * u[off + i * stride]
    return q


@njit(**NJIT_INLINE)
def _nonzero(Phi, k, NP):
    nz = False
    for i in range(NP):
        nz |= Phi[k, i] != 0.0
    return nz


@njit(**NJIT_INLINE)
def _local_copies(S, dthr, NP, p):
    """θ (as (n, p) and as its flat storage) and P copied out of the state (stack
    arrays for compile-time n), and the bits of the windup threshold for
    :func:`_sweep` (1 if it is not positive)."""
    theta_s, Ps, _ = _views(S, NP, p)
    P = scratch2_lines(NP)
    for j in range(NP):
        for i in range(NP):
            P[j, i] = Ps[i, j]  # symmetric: the transpose is P itself
    tflat = scratch(NP) if p == 1 else np.empty(NP * p)
    theta = tflat.reshape((NP, p))
    for i in range(NP):
        for j in range(p):
            theta[i, j] = theta_s[i, j]
    t = scratch(1)
    t[0] = dthr
    bd = t.view(np.int64)[0] if dthr > 0.0 else 1
    return theta_s, Ps, theta, tflat, P, bd


@njit(**NJIT_INLINE)
def _measure(P, theta, tflat, u, c, e, Phi, k, kn, q, r, il, bd, NP, p):
    """The update by a sample of weight > 0 (u = Pφₖ, q = φᵀu given); the fused sweep."""
    d = r + q
    idd = 1.0 / d
    theta_step(theta, tflat, u, idd, e, NP, p)
    if NP <= SQRT_FREE_N:
        for i in range(NP):
            c[i] = u[i]
        return _sweep(P, c, u, idd, il, Phi, kn, bd, NP)
    return _sweep_scaled(P, c, u, idd * np.sqrt(d), il, Phi, kn, bd, NP)


def _sweep_scaled(P, c, u, sq, il, Phi, kn, bd, NP):
    """:func:`_sweep` with c = u·sq (n > SQRT_FREE_N); for a compile-time n ≤
    ``VECTOR_SWEEP_MAX`` LLVM vector code (``toolchain/_covsweep.py``), the same operations."""
    for i in range(NP):
        c[i] = u[i] * sq
    return _sweep(P, c, u, 1.0, il, Phi, kn, bd, NP)


by_constant_n(_sweep_scaled, sweep_scaled_n, _sweep_scaled, largest=VECTOR_SWEEP_MAX,
              jit_options=_OPTS)


@njit(**NJIT_INLINE)
def _cov_stream(S, Phi, Y, lam, w, Th, E, skipped, dthr, NP, p):
    theta_s, Ps, theta, tflat, P, bd = _local_copies(S, dthr, NP, p)
    u = scratch(NP)
    c = scratch(NP)
    e = scratch(p)
    N = Phi.shape[0]
    store = Th.shape[0] == N
    fresh = False  # u = P Phi[k]
    qn = np.nan  # and φₖᵀu, when the vector sweep formed it (u still in its registers)
    bad = -1
    repaired = -1
    lprev = np.nan
    il = np.nan
    for k in range(N):
        ok = _prior_error(theta, tflat, Phi, Y, k, e, NP, p) or _finite_sample(Phi, Y, k, NP, p)
        wk = w[k]
        lk = lam[k]
        if lk != lprev:  # 1/λ once per value of λ
            lprev = lk
            il = 1.0 / lk
        inside = True
        if ok and wk > 0.0:
            if not fresh:
                _matvec(P, Phi, k, u, NP)
            # the sweep's q is quad_n's, bit for bit (a compile-time choice of branch)
            q = qn if fresh and vector_quad(NP, 1) else _quad(Phi, k, u, 0, 1, NP)
            if not q > 0.0 and _nonzero(Phi, k, NP):
                cov_repair(P)
                repaired = k if repaired < 0 else repaired
                _matvec(P, Phi, k, u, NP)
                q = _quad(Phi, k, u, 0, 1, NP)
            for j in range(p):
                E[k, j] = e[j]
            inside, pos, qn = _measure(P, theta, tflat, u, c, e, Phi, k, k + 1 if k + 1 < N else k, q,
                                   lk if wk == 1.0 else lk / wk, il, bd, NP, p)
            fresh = True
            if not pos:
                cov_repair(P)
                repaired = k if repaired < 0 else repaired
                fresh = False
                inside = _diag_inside(P, dthr, NP)
        elif ok:  # weight 0: the sample only advances the forgetting
            for j in range(p):
                E[k, j] = e[j]
            for j in range(NP):
                for i in range(NP):
                    P[j, i] *= il
            inside = _diag_inside(P, dthr, NP)
            fresh = False
        else:
            skipped[k] = True
            for j in range(p):
                E[k, j] = np.nan
            fresh = False
        if bad < 0 and not inside:
            bad = k
        if store:
            for i in range(NP):
                for j in range(p):
                    Th[k, i, j] = theta[i, j]
    for j in range(NP):
        for i in range(NP):
            Ps[i, j] = P[j, i]
    for i in range(NP):
        for j in range(p):
            theta_s[i, j] = theta[i, j]
    return bad if bad >= 0 else (-2 - repaired if repaired >= 0 else -1)


@njit(**NJIT_INLINE)
def _diag_inside(P, dthr, NP):
    inside = True
    for i in range(NP):
        inside &= (P[i, i] > 0.0) & (P[i, i] < dthr)
    return inside


@njit(**NJIT)
def cov_run(S, Phi, Y, lam, w, Th, E, skipped, Lk, St, opt, mat, ntag, ptag):
    """N steps; returns the code described in the module docstring."""
    return _cov_stream(S, Phi, Y, lam, w, Th, E, skipped, opt[0], dim(ntag), dim(ptag))


@njit(**NJIT)
def cov_step(S, W, ntag, ptag):
    """One step on the packed sample ``W`` (:mod:`._step`), bit for bit a step of
    :func:`cov_run`; returns its code."""
    Phi, Y, lam, w, Th, E, skipped, dthr = views(W, ntag, ptag)
    return _cov_stream(S, Phi, Y, lam, w, Th, E, skipped, dthr, dim(ntag), dim(ptag))


cov_run_batched = batched(cov_run, "cov_run_batched")
cov_run_segments = segments(cov_run, "cov_run_segments")


#: this module's entry points, by the name adaptid._kernels gives them
ENTRIES = {"COVARIANCE": Entries(cov_run, cov_run_batched, cov_run_segments, step=cov_step)}
