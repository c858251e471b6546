r"""RLS over many streams in SIMD: the streams laid out structure-of-arrays.

:func:`rls_soa_batched` and :func:`rls_soa_segments` compute, bit for bit per
stream, what :func:`._rls.rls_run_batched` / :func:`._rls.rls_run_segments`
do, and :func:`cov_soa_batched` / :func:`cov_soa_segments` what the
covariance form's :func:`._covariance.cov_run_batched` / ``cov_run_segments``
do, but run ``LANES`` streams in lock-step so that one vector instruction
serves several streams. A block's state lives in lane-major arrays (lane l
innermost); ``CHUNK`` samples of its Φ and y are transposed into lane-major
scratch, the steps run, and ε, the skipped flags and θ are scattered back. A
step is one loop over the lanes whose body is the scalar kernel's update of
lane l, the same operations in the same order, n a compile-time constant;
LLVM vectorises that loop (zmm with AVX-512), so each lane's bits equal the
scalar kernel's (tests/test_soa.py). The steps of each form:
:mod:`._soa_ud` (U-D), :mod:`._soa_cov` (covariance; a lane that needs the
scalar kernel's repair of P is rerun by it), chosen by :mod:`._soa_forms`.
Where the scalar kernel branches
(non-finite row: skipped; weight 0: forgetting only) every lane computes the
whole update and keeps what the scalar kernel keeps with a select
(:func:`._soa_lanes.blend`).

Batched: blocks of ``LANES`` consecutive streams; in the last block the lanes
past the last stream repeat it and are not written back. Segments: sorted by
length and dealt ``LANES`` to a block; past its segment's end a lane reads
NaN rows (skipped: its state stays). Parallel over blocks. Only p = 1 with
tuple size tags: the engine sends everything else to the scalar kernels.
"""

import numpy as np
from numba import prange

from ..._config import njit
from ..toolchain._dims import dim
from ._soa_cov import MAX_N as COV_MAX_N
from ._soa_forms import COV, UD, lane_load, lane_steps, lane_store, ratio, rerun
from ._soa_lanes import CHUNK, INL, LANES, PAR, lane_scratch

__all__ = ["LANES", "CHUNK", "MIN_STREAMS", "MAX_N", "COV_MAX_N", "rls_soa_batched",
           "rls_soa_segments", "cov_soa_batched", "cov_soa_segments"]

#: The engine uses these kernels from this many streams (or segments) on ...
MIN_STREAMS = 2 * LANES
#: ... and up to this many parameters (U-D; measured: benchmarks/bench_batched.py).
MAX_N = 8

_PAR = PAR
_INL = INL
_ONE = dict(INL, inline="never")
#: which gather a block uses (:func:`_gather`)
BATCHED = False
SEGMENTS = True


@njit(**_INL)
def _block_scratch(NP):
    """A block's lane-major arrays on the stack: the form's (n, n, L) and (1, n, L)
    state, θ (1, n, L), first bad sample (1, 1, L); a chunk of Φ (CHUNK, n, L), y,
    1/λ, w, Rc, ε, skipped, θ."""
    return (lane_scratch(NP, NP), lane_scratch(1, NP), lane_scratch(1, NP),
            lane_scratch(1, 1), lane_scratch(CHUNK, NP), lane_scratch(1, CHUNK),
            lane_scratch(1, CHUNK), lane_scratch(1, CHUNK), lane_scratch(1, CHUNK),
            lane_scratch(1, CHUNK), lane_scratch(1, CHUNK), lane_scratch(CHUNK, NP))


@njit(**_INL)
def _chunk_scratch(NP):
    """A second chunk of Φ, y, 1/λ, w, Rc: filled while the steps read the first."""
    return (lane_scratch(CHUNK, NP), lane_scratch(1, CHUNK), lane_scratch(1, CHUNK),
            lane_scratch(1, CHUNK), lane_scratch(1, CHUNK))


@njit(**_INL)
def _chunk(form, seg, U, D, th, bad, Ec, Sk, Thc, bufs, k0, T, N, dthr, Phi, Y, lam, w, a, b,
           il0, r0, NP):
    """The T steps of the chunk at k0 (of N samples) from one of the buffers ``bufs``
    while the next chunk is gathered into the other, one sample per step: the loads
    from the streams then overlap the arithmetic (gathering a whole chunk before its
    steps left them waiting on memory; ``benchmarks/bench_batched.py``). a, b: the
    block's streams (batched) or segments, as :func:`_gather`."""
    odd = (k0 // CHUNK) % 2 == 1
    (X, Yc, Lc, Wc, Rc), nxt = (bufs[1], bufs[0]) if odd else (bufs[0], bufs[1])
    T1 = min(CHUNK, N - k0 - CHUNK)
    for t in range(T):
        lane_steps(form, U, D, th, bad, X, Yc, Lc, Wc, Rc, Ec, Sk, Thc, k0, t, t + 1, dthr, NP)
        if t < T1:
            _gather(form, seg, Phi, Y, lam, w, a, b, k0 + CHUNK, t, t + 1, nxt, il0, r0, NP)


@njit(**_INL)
def _gather(form, seg, Phi, Y, lam, w, a, b, k0, t0, t1, buf, il0, r0, NP):
    """Samples k0 + t, t0 ≤ t < t1, into row t of the buffer: of the block's streams
    s0 = a, nl = b (``seg`` False: :func:`_batched_gather`), or of the lanes' segments
    sa = a, sn = b (``seg`` True: :func:`_segment_gather`; a global constant, so that
    numba removes the other branch)."""
    X, Yc, Lc, Wc, Rc = buf
    if seg:
        _segment_gather(form, Phi, Y, lam, w, a, b, k0, t0, t1, X, Yc, Lc, Wc, Rc, il0, r0, NP)
    else:
        _batched_gather(form, Phi, Y, lam, w, a, b, k0, t0, t1, X, Yc, Lc, Wc, Rc, il0, r0, NP)


# --- the per-sample λ and w, lane-major ---
@njit(**_INL)
def _constant(a, first):
    """a[first] if the per-sample array a is one broadcast value (strides 0), else NaN."""
    const = a.size > 0
    for st in a.strides:
        const &= st == 0
    return a[first] if const else np.nan


@njit(**_INL)
def _constants(form, lam, w, first):
    """1/λ and the steps' Rc (:func:`ratio`) if λ and w are constant, else NaN each."""
    lc = _constant(lam, first)
    return 1.0 / lc, ratio(form, lc, _constant(w, first))


@njit(**_INL)
def _fill_constant(Lc, Wc, Rc, il0, w0, r0):
    for t in range(CHUNK):
        for l in range(LANES):
            Lc[0, t, l] = il0
            Wc[0, t, l] = w0
            Rc[0, t, l] = r0


@njit(**_INL)
def _aux_lane(form, Lc, Wc, Rc, t, l, lk, wk, il0, r0):
    Wc[0, t, l] = wk
    Lc[0, t, l] = il0 if il0 == il0 else 1.0 / lk
    Rc[0, t, l] = r0 if r0 == r0 else ratio(form, lk, wk)


# --- batched: blocks of consecutive streams ---
@njit(**_INL)
def _batched_gather(form, Phi, Y, lam, w, s0, nl, k0, t0, t1, X, Yc, Lc, Wc, Rc, il0, r0, NP):
    """Samples k0 + t, t0 ≤ t < t1, of the block's streams into row t of the
    lane-major scratch.

    Lanes past the last stream (nl ≤ l) repeat stream nl − 1: they compute
    what its lane computes and are never written back. λ and w are read
    only when not constant (il0, r0 NaN; else Lc, Wc, Rc are filled once).
    """
    for t in range(t0, t1):  # t outer: the stores run along the lanes (no scatter)
        for l in range(LANES):
            s = s0 + min(l, nl - 1)
            for i in range(NP):
                X[t, i, l] = Phi[s, k0 + t, i]
            Yc[0, t, l] = Y[s, k0 + t, 0]
    if not (il0 == il0 and r0 == r0):
        for t in range(t0, t1):
            for l in range(LANES):
                s = s0 + min(l, nl - 1)
                _aux_lane(form, Lc, Wc, Rc, t, l, lam[s, k0 + t], w[s, k0 + t], il0, r0)


@njit(**_INL)
def _batched_scatter(E, skipped, Ec, Sk, s0, nl, k0, t0, t1):
    """ε and the skipped flags of samples k0 + t, t0 ≤ t < t1, back to the streams,
    t outer (faster than l outer; ``benchmarks/bench_batched.py``)."""
    for t in range(t0, t1):
        for l in range(LANES):
            if l < nl:
                E[s0 + l, k0 + t, 0] = Ec[0, t, l]
                skipped[s0 + l, k0 + t] = Sk[0, t, l] != 0.0


@njit(**_INL)
def _batched_block(form, S, Phi, Y, lam, w, Th, E, skipped, Lk, codes, s0, opt, mat, il0, r0,
                   ntag, NP):
    U, D, th, bad, X, Yc, Lc, Wc, Rc, Ec, Sk, Thc = _block_scratch(NP)
    X2, Yc2, Lc2, Wc2, Rc2 = _chunk_scratch(NP)
    nl = min(LANES, S.shape[0] - s0)
    N = Phi.shape[1]
    store = Th.shape[1] == N
    dthr = opt[0]
    for l in range(LANES):
        lane_load(form, S[s0 + min(l, nl - 1)], U, D, th, bad, l, NP)
    if il0 == il0 and r0 == r0 and N > 0:
        _fill_constant(Lc, Wc, Rc, il0, w[0, 0], r0)
        _fill_constant(Lc2, Wc2, Rc2, il0, w[0, 0], r0)
    bufs = ((X, Yc, Lc, Wc, Rc), (X2, Yc2, Lc2, Wc2, Rc2))
    _gather(form, BATCHED, Phi, Y, lam, w, s0, nl, 0, 0, min(CHUNK, N), bufs[0], il0, r0, NP)
    for k0 in range(0, N, CHUNK):
        T = min(CHUNK, N - k0)
        _chunk(form, BATCHED, U, D, th, bad, Ec, Sk, Thc, bufs, k0, T, N, dthr, Phi, Y, lam, w,
               s0, nl, il0, r0, NP)
        # (scattering the previous chunk's ε one sample per step too was slower:
        # benchmarks/bench_batched.py)
        _batched_scatter(E, skipped, Ec, Sk, s0, nl, k0, 0, T)
        for l in range(nl):
            s = s0 + l
            if store:
                for t in range(T):
                    for i in range(NP):
                        Th[s, k0 + t, i, 0] = Thc[t, i, l]
    for l in range(nl):
        s = s0 + l
        if bad[0, 0, l] != bad[0, 0, l]:  # the scalar kernel, from the stream's first state
            codes[s] = rerun(form, S[s], Phi[s], Y[s], lam[s], w[s], Th[s], E[s], skipped[s],
                             Lk[s], opt, mat, ntag)
        else:
            lane_store(form, S[s], U, D, th, l, NP)
            codes[s] = int(bad[0, 0, l])


@njit(**_INL)
def _soa_batched(form, S, Phi, Y, lam, w, Th, E, skipped, Lk, opt, mat, codes, ntag):
    nb = (Phi.shape[0] + LANES - 1) // LANES
    il0, r0 = _constants(form, lam, w, (0, 0))
    for q in prange(nb):
        if form == COV:
            _cov_batched_block(S, Phi, Y, lam, w, Th, E, skipped, Lk, codes, q * LANES, opt, mat,
                               il0, r0, ntag)
        else:
            _ud_batched_block(S, Phi, Y, lam, w, Th, E, skipped, Lk, codes, q * LANES, opt, mat,
                              il0, r0, ntag)


# A block is compiled on its own, not inlined into the parallel loop: numba's parfor
# passes then see a loop of one call instead of the whole inlined block (its fusion
# pass alone took a large part of the U-D lane kernel's compile time).
@njit(**_ONE)
def _ud_batched_block(S, Phi, Y, lam, w, Th, E, skipped, Lk, codes, s0, opt, mat, il0, r0, ntag):
    _batched_block(UD, S, Phi, Y, lam, w, Th, E, skipped, Lk, codes, s0, opt, mat, il0, r0,
                   ntag, dim(ntag))


@njit(**_ONE)
def _cov_batched_block(S, Phi, Y, lam, w, Th, E, skipped, Lk, codes, s0, opt, mat, il0, r0,
                       ntag):
    _batched_block(COV, S, Phi, Y, lam, w, Th, E, skipped, Lk, codes, s0, opt, mat, il0, r0,
                   ntag, dim(ntag))


@njit(**_PAR)
def rls_soa_batched(S, Phi, Y, lam, w, Th, E, skipped, Lk, opt, mat, codes, ntag, ptag):
    """:func:`._rls.rls_run_batched` with ``LANES`` streams per vector (p = 1)."""
    _soa_batched(UD, S, Phi, Y, lam, w, Th, E, skipped, Lk, opt, mat, codes, ntag)


@njit(**_PAR)
def cov_soa_batched(S, Phi, Y, lam, w, Th, E, skipped, Lk, opt, mat, codes, ntag, ptag):
    """:func:`._covariance.cov_run_batched` with ``LANES`` streams per vector (p = 1)."""
    _soa_batched(COV, S, Phi, Y, lam, w, Th, E, skipped, Lk, opt, mat, codes, ntag)


# --- segments: sorted by length, dealt to blocks ---
@njit(**_INL)
def _segment_gather(form, Phi, Y, lam, w, sa, sn, k0, t0, t1, X, Yc, Lc, Wc, Rc, il0, r0, NP):
    """Samples k0 + t, t0 ≤ t < t1, of the lanes' segments (rows sa[l] …, sn[l] of
    them) into row t; past the end of its segment a lane reads a row of NaN (skipped:
    state kept)."""
    for t in range(t0, t1):
        k = k0 + t
        for l in range(LANES):
            live = k < sn[l]
            row = sa[l] + max(min(k, sn[l] - 1), 0)
            for i in range(NP):
                X[t, i, l] = Phi[row, i] if live else np.nan
            Yc[0, t, l] = Y[row, 0] if live else np.nan
    if not (il0 == il0 and r0 == r0):
        for t in range(t0, t1):
            k = k0 + t
            for l in range(LANES):
                row = sa[l] + max(min(k, sn[l] - 1), 0)
                _aux_lane(form, Lc, Wc, Rc, t, l, lam[row], w[row], il0, r0)


@njit(**_INL)
def _segment_block(form, S0, Sout, Phi, Y, offsets, lam, w, Th, E, skipped, Lk, codes, seg,
                   opt, mat, il0, r0, ntag):
    NP = dim(ntag)
    U, D, th, bad, X, Yc, Lc, Wc, Rc, Ec, Sk, Thc = _block_scratch(NP)
    X2, Yc2, Lc2, Wc2, Rc2 = _chunk_scratch(NP)
    store = Th.shape[0] == Phi.shape[0]
    dthr = opt[0]
    sa = np.zeros(LANES, dtype=np.int64)  # first row and length of each lane's segment
    sn = np.zeros(LANES, dtype=np.int64)
    for l in range(LANES):
        lane_load(form, S0, U, D, th, bad, l, NP)
        g = seg[l]
        if g >= 0 and offsets[g + 1] > offsets[g]:
            sa[l] = offsets[g]
            sn[l] = offsets[g + 1] - offsets[g]
    M = sn.max()
    if il0 == il0 and r0 == r0 and M > 0:
        _fill_constant(Lc, Wc, Rc, il0, w[0], r0)
        _fill_constant(Lc2, Wc2, Rc2, il0, w[0], r0)
    bufs = ((X, Yc, Lc, Wc, Rc), (X2, Yc2, Lc2, Wc2, Rc2))
    _gather(form, SEGMENTS, Phi, Y, lam, w, sa, sn, 0, 0, min(CHUNK, M), bufs[0], il0, r0, NP)
    for k0 in range(0, M, CHUNK):
        T = min(CHUNK, M - k0)
        _chunk(form, SEGMENTS, U, D, th, bad, Ec, Sk, Thc, bufs, k0, T, M, dthr, Phi, Y, lam, w,
               sa, sn, il0, r0, NP)
        for t in range(T):  # t outer, as _batched_scatter
            for l in range(LANES):
                if k0 + t < sn[l]:
                    r = sa[l] + k0 + t
                    E[r, 0] = Ec[0, t, l]
                    skipped[r] = Sk[0, t, l] != 0.0
                    for i in range(NP if store else 0):
                        Th[r, i, 0] = Thc[t, i, l]
    for l in range(LANES):
        g = seg[l]
        if g < 0:
            continue
        Sout[g, :] = S0
        if bad[0, 0, l] != bad[0, 0, l]:  # the scalar kernel, from the prior
            a, z = offsets[g], offsets[g + 1]
            codes[g] = rerun(form, Sout[g], Phi[a:z], Y[a:z], lam[a:z], w[a:z], Th[a:z], E[a:z],
                             skipped[a:z], Lk[a:z], opt, mat, ntag)
        else:
            lane_store(form, Sout[g], U, D, th, l, NP)
            codes[g] = int(bad[0, 0, l])


@njit(**_INL)
def _soa_segments(form, S0, Sout, Phi, Y, offsets, lam, w, Th, E, skipped, Lk, opt, mat, codes,
                  ntag):
    """The segments are sorted by length and dealt ``LANES`` to a block; the
    blocks are taken longest and shortest alternately, so that the threads'
    equal shares of the blocks hold about equal work."""
    G = offsets.shape[0] - 1
    order = np.argsort(offsets[:-1] - offsets[1:], kind="mergesort")  # longest first
    nb = (G + LANES - 1) // LANES
    il0, r0 = _constants(form, lam, w, 0)
    for q in prange(nb):
        blk = q // 2 if q % 2 == 0 else nb - 1 - q // 2
        seg = np.full(LANES, -1, dtype=np.int64)
        for l in range(min(LANES, G - blk * LANES)):
            seg[l] = order[blk * LANES + l]
        if form == COV:
            _cov_segment_block(S0, Sout, Phi, Y, offsets, lam, w, Th, E, skipped, Lk, codes, seg,
                               opt, mat, il0, r0, ntag)
        else:
            _ud_segment_block(S0, Sout, Phi, Y, offsets, lam, w, Th, E, skipped, Lk, codes, seg,
                              opt, mat, il0, r0, ntag)


@njit(**_ONE)
def _ud_segment_block(S0, Sout, Phi, Y, offsets, lam, w, Th, E, skipped, Lk, codes, seg, opt,
                      mat, il0, r0, ntag):
    _segment_block(UD, S0, Sout, Phi, Y, offsets, lam, w, Th, E, skipped, Lk, codes, seg, opt,
                   mat, il0, r0, ntag)


@njit(**_ONE)
def _cov_segment_block(S0, Sout, Phi, Y, offsets, lam, w, Th, E, skipped, Lk, codes, seg, opt,
                       mat, il0, r0, ntag):
    _segment_block(COV, S0, Sout, Phi, Y, offsets, lam, w, Th, E, skipped, Lk, codes, seg, opt,
                   mat, il0, r0, ntag)


@njit(**_PAR)
def rls_soa_segments(S0, Sout, Phi, Y, offsets, lam, w, Th, E, skipped, Lk, opt, mat, codes,
                     ntag, ptag):
    """:func:`._rls.rls_run_segments` with ``LANES`` segments per vector (p = 1)."""
    _soa_segments(UD, S0, Sout, Phi, Y, offsets, lam, w, Th, E, skipped, Lk, opt, mat, codes,
                  ntag)


@njit(**_PAR)
def cov_soa_segments(S0, Sout, Phi, Y, offsets, lam, w, Th, E, skipped, Lk, opt, mat, codes,
                     ntag, ptag):
    """The covariance form's ``cov_run_segments`` with ``LANES`` segments per vector (p = 1)."""
    _soa_segments(COV, S0, Sout, Phi, Y, offsets, lam, w, Th, E, skipped, Lk, opt, mat, codes,
                  ntag)
