r"""RLS over many streams in SIMD: the streams laid out structure-of-arrays.

:func:`rls_soa_batched` and :func:`rls_soa_segments` compute, bit for bit per
stream, what :func:`._rls.rls_run_batched` / :func:`._rls.rls_run_segments`
do, but run ``LANES`` streams in lock-step so that one vector instruction
serves several streams. A block's state lives in lane-major arrays
(``U[i, j, l]``, ``D[0, i, l]``, ``θ[0, i, l]``, lane l innermost); ``CHUNK``
samples of its Φ and y are transposed into lane-major scratch, the steps run,
and ε, the skipped flags and θ are scattered back. A step is one loop over the
lanes whose body is :func:`._rls._rls_body`'s update of lane l, the same
operations in the same order (Bierman stages two at a time, as
:func:`._bierman._bierman_apply_pairs`), n a compile-time constant; LLVM
vectorises that loop (zmm with AVX-512), so each lane's bits equal the scalar
kernel's (tests/test_soa.py). Where the scalar kernel branches (non-finite
row: skipped; weight 0: forgetting only) every lane computes the whole update
and keeps what the scalar kernel keeps with a select (:func:`blend`).
``error_model="numpy"``: a division by zero in a discarded lane (w = 0:
r = 1/w = inf) raises nothing and puts no branch in the loop.

Batched: blocks of ``LANES`` consecutive streams; in the last block the lanes
past the last stream repeat it and are not written back. Segments: sorted by
length and dealt ``LANES`` to a block; past its segment's end a lane reads
NaN rows (skipped: its state stays). Parallel over blocks. Only p = 1 with
tuple size tags: the engine sends everything else to :mod:`._rls`.
"""

import numba
import numpy as np
from numba import prange, types
from numba.extending import intrinsic, overload

from .._config import NJIT_INLINE, NJIT_PARALLEL, njit
from ._dims import dim
from ._scratch import _stack_ptr

#: Streams advanced together by one vector instruction (4 doubles with AVX2, 8
#: with AVX-512). Measured at n = 4 on AVX-512 (Zen 4): 4 lanes 1.5 x, 16 lanes
#: 1.3 x the time of 8 (steps ~40 % of it, gathering and scattering the rest).
LANES = 8
#: Time steps transposed into the lane-major scratch at once.
CHUNK = 32
#: The engine uses these kernels from this many streams (or segments) on ...
MIN_STREAMS = 2 * LANES
#: ... and up to this many parameters (measured: benchmarks/bench_batched.py).
MAX_N = 8

_PAR = dict(NJIT_PARALLEL, error_model="numpy")
_INL = dict(NJIT_INLINE, error_model="numpy")


def lane_scratch(a, b):  # pragma: no cover - replaced by the overload in compiled code
    """``np.empty((a, b, LANES))``; on the stack when a and b are compile-time constants."""
    return np.empty((a, b, LANES))


@overload(lane_scratch, inline="always", prefer_literal=True)
def _lane_scratch(a, b):
    if isinstance(a, types.IntegerLiteral) and isinstance(b, types.IntegerLiteral) \
            and a.literal_value > 0 and b.literal_value > 0:
        m = a.literal_value * b.literal_value * LANES

        def impl(a, b):
            return numba.carray(_stack_ptr(m), (a, b, LANES))
        return impl
    return lambda a, b: np.empty((a, b, LANES))


# --- the lane-wise update ---
def blend(c, a, b):  # pragma: no cover - replaced by the overload in compiled code
    """``a if c else b`` without a branch (an LLVM ``select``)."""
    return a if c else b


@intrinsic
def _select(typingctx, c, a, b):
    if not isinstance(c, types.Boolean) or a != b:
        return None

    def codegen(context, builder, signature, args):
        return builder.select(args[0], args[1], args[2])
    return a(c, a, b), codegen


@overload(blend, inline="always")
def _blend(c, a, b):
    # Not a branch: LLVM made masked stores of those, and a load after a masked
    # store waits for it to retire (no forwarding): the step ran 5-10 x slower.
    return lambda c, a, b: _select(c, a, b)


@njit(**_INL)
def _lane_bierman(U, D, f, v, b, r, il, ok, upd, l, NP):
    """:func:`._bierman._bierman_apply_pairs` for lane l on the pivots D/λ.

    U and D take the updated values where ``upd``, D the forgotten ones
    D/λ where only ``ok``, and keep theirs elsewhere. Returns α.
    """
    a = r + f[0, 0, l] * v[0, 0, l]
    ia = 1.0 / a
    d0 = D[0, 0, l]
    dd = d0 * il
    D[0, 0, l] = blend(ok, blend(upd, dd * (r * ia), dd), d0)
    b[0, 0, l] = v[0, 0, l]
    for j in range(1, NP - 1, 2):
        an = a + f[0, j, l] * v[0, j, l]
        ian = 1.0 / an
        d0 = D[0, j, l]
        dd = d0 * il
        D[0, j, l] = blend(ok, blend(upd, dd * (a * ian), dd), d0)
        pj = -f[0, j, l] * ia
        vj = v[0, j, l]
        a2 = an + f[0, j + 1, l] * v[0, j + 1, l]
        ia2 = 1.0 / a2
        d0 = D[0, j + 1, l]
        dd = d0 * il
        D[0, j + 1, l] = blend(ok, blend(upd, dd * (an * ia2), dd), d0)
        pj2 = -f[0, j + 1, l] * ian
        vj2 = v[0, j + 1, l]
        for i in range(j):
            u = U[i, j, l]
            bi = b[0, i, l]
            U[i, j, l] = blend(upd, u + bi * pj, u)
            bi += u * vj
            u2 = U[i, j + 1, l]
            U[i, j + 1, l] = blend(upd, u2 + bi * pj2, u2)
            b[0, i, l] = bi + u2 * vj2
        u2 = U[j, j + 1, l]
        U[j, j + 1, l] = blend(upd, u2 + vj * pj2, u2)
        b[0, j, l] = vj + u2 * vj2
        b[0, j + 1, l] = vj2
        a = a2
        ia = ia2
    j = NP - 1
    if NP % 2 == 0 and NP > 1:  # the last column alone
        an = a + f[0, j, l] * v[0, j, l]
        ian = 1.0 / an
        d0 = D[0, j, l]
        dd = d0 * il
        D[0, j, l] = blend(ok, blend(upd, dd * (a * ian), dd), d0)
        pj = -f[0, j, l] * ia
        vj = v[0, j, l]
        for i in range(j):
            u = U[i, j, l]
            U[i, j, l] = blend(upd, u + b[0, i, l] * pj, u)
            b[0, i, l] += u * vj
        b[0, j, l] = vj
        a = an
    return a


@njit(**_INL)
def _lane_steps(U, D, th, bad, X, Yc, Lc, Wc, Rc, Ec, Sk, Thc, k0, T, dthr, NP):
    """T time steps of every lane: the body of :func:`._rls._rls_body` per lane.

    X (Φ), Yc (y), Lc (1/λ), Wc (w), Rc (1/w) hold the samples k0 … k0+T−1
    lane-major; Ec, Sk and Thc receive ε, the skipped flags and θ.
    """
    f = lane_scratch(1, NP)
    v = lane_scratch(1, NP)
    b = lane_scratch(1, NP)
    for t in range(T):
        for l in range(LANES):
            ok = True
            for i in range(NP):
                ok &= X[t, i, l] - X[t, i, l] == 0.0
            yk = Yc[0, t, l]
            ok &= yk - yk == 0.0
            upd = ok & (Wc[0, t, l] > 0.0)
            e = yk
            for i in range(NP):
                e -= X[t, i, l] * th[0, i, l]
            il = Lc[0, t, l]
            for j in range(NP):  # _bierman_prep on D/λ
                s = X[t, j, l]
                for i in range(j):
                    s += U[i, j, l] * X[t, i, l]
                f[0, j, l] = s
                v[0, j, l] = (D[0, j, l] * il) * s
            a = _lane_bierman(U, D, f, v, b, Rc[0, t, l], il, ok, upd, l, NP)
            ia = 1.0 / a
            inside = True
            for i in range(NP):
                g = b[0, i, l] * ia
                t1 = th[0, i, l]
                t1 = blend(upd, t1 + g * e, t1)
                th[0, i, l] = t1
                Thc[t, i, l] = t1
                d = D[0, i, l]
                inside &= (d > 0.0) & (d < dthr)
            inside |= not ok
            bk = bad[0, 0, l]
            bad[0, 0, l] = blend((bk < 0.0) & (not inside), float(k0 + t), bk)
            Ec[0, t, l] = blend(ok, e, np.nan)
            Sk[0, t, l] = blend(ok, 0.0, 1.0)


@njit(**_INL)
def _block_scratch(NP):
    """A block's lane-major arrays on the stack: U (n, n, L), D, θ (1, n, L), first bad
    sample (1, 1, L); a chunk of Φ (CHUNK, n, L), y, 1/λ, w, 1/w, ε, skipped, θ."""
    return (lane_scratch(NP, NP), lane_scratch(1, NP), lane_scratch(1, NP),
            lane_scratch(1, 1), lane_scratch(CHUNK, NP), lane_scratch(1, CHUNK),
            lane_scratch(1, CHUNK), lane_scratch(1, CHUNK), lane_scratch(1, CHUNK),
            lane_scratch(1, CHUNK), lane_scratch(1, CHUNK), lane_scratch(CHUNK, NP))


# --- state in and out of the lanes ---
@njit(**_INL)
def _lane_load(Sv, U, D, th, bad, l, NP):
    """Lane l ← the flat state Sv = [θ | U by columns | D] (p = 1)."""
    for j in range(NP):
        th[0, j, l] = Sv[j]
        D[0, j, l] = Sv[NP + NP * NP + j]
        for i in range(j):
            U[i, j, l] = Sv[NP + j * NP + i]
    bad[0, 0, l] = -1.0


@njit(**_INL)
def _lane_store(Sv, U, D, th, l, NP):
    """The flat state Sv ← lane l (θ, the strict upper triangle of U, D)."""
    for j in range(NP):
        Sv[j] = th[0, j, l]
        Sv[NP + NP * NP + j] = D[0, j, l]
        for i in range(j):
            Sv[NP + j * NP + i] = U[i, j, l]


# --- the per-sample λ and w, lane-major ---
@njit(**_INL)
def _reciprocal(a, first):
    """1/a[first] if the per-sample array a is one broadcast value (strides 0), else NaN."""
    const = a.size > 0
    for st in a.strides:
        const &= st == 0
    return 1.0 / a[first] if const else np.nan


@njit(**_INL)
def _fill_constant(Lc, Wc, Rc, il0, w0, r0):
    for t in range(CHUNK):
        for l in range(LANES):
            Lc[0, t, l] = il0
            Wc[0, t, l] = w0
            Rc[0, t, l] = r0


@njit(**_INL)
def _aux_lane(Lc, Wc, Rc, t, l, lk, wk, il0, r0):
    Wc[0, t, l] = wk
    Lc[0, t, l] = il0 if il0 == il0 else 1.0 / lk
    Rc[0, t, l] = r0 if r0 == r0 else 1.0 / wk


# --- batched: blocks of consecutive streams ---
@njit(**_INL)
def _batched_gather(Phi, Y, lam, w, s0, nl, k0, T, X, Yc, Lc, Wc, Rc, il0, r0, NP):
    """Samples k0 … k0+T−1 of the block's streams into the lane-major scratch.

    Lanes past the last stream (nl ≤ l) repeat stream nl − 1: they compute
    what its lane computes and are never written back. λ and w are read
    only when not constant (il0, r0 NaN; else Lc, Wc, Rc are filled once).
    """
    for t in range(T):  # t outer: the stores run along the lanes (no scatter)
        for l in range(LANES):
            s = s0 + min(l, nl - 1)
            for i in range(NP):
                X[t, i, l] = Phi[s, k0 + t, i]
            Yc[0, t, l] = Y[s, k0 + t, 0]
    if not (il0 == il0 and r0 == r0):
        for t in range(T):
            for l in range(LANES):
                s = s0 + min(l, nl - 1)
                _aux_lane(Lc, Wc, Rc, t, l, lam[s, k0 + t], w[s, k0 + t], il0, r0)


@njit(**_INL)
def _batched_scatter(E, skipped, Ec, Sk, s0, nl, k0, T):
    """ε and the skipped flags back to the streams, t outer (~30 % faster than l outer)."""
    for t in range(T):
        for l in range(LANES):
            if l < nl:
                E[s0 + l, k0 + t, 0] = Ec[0, t, l]
                skipped[s0 + l, k0 + t] = Sk[0, t, l] != 0.0


@njit(**_INL)
def _batched_block(S, Phi, Y, lam, w, Th, E, skipped, codes, s0, dthr, il0, r0, NP):
    U, D, th, bad, X, Yc, Lc, Wc, Rc, Ec, Sk, Thc = _block_scratch(NP)
    nl = min(LANES, S.shape[0] - s0)
    N = Phi.shape[1]
    store = Th.shape[1] == N
    for l in range(LANES):
        _lane_load(S[s0 + min(l, nl - 1)], U, D, th, bad, l, NP)
    if il0 == il0 and r0 == r0 and N > 0:
        _fill_constant(Lc, Wc, Rc, il0, w[0, 0], r0)
    for k0 in range(0, N, CHUNK):
        T = min(CHUNK, N - k0)
        _batched_gather(Phi, Y, lam, w, s0, nl, k0, T, X, Yc, Lc, Wc, Rc, il0, r0, NP)
        _lane_steps(U, D, th, bad, X, Yc, Lc, Wc, Rc, Ec, Sk, Thc, k0, T, dthr, NP)
        _batched_scatter(E, skipped, Ec, Sk, s0, nl, k0, T)
        for l in range(nl):
            s = s0 + l
            if store:
                for t in range(T):
                    for i in range(NP):
                        Th[s, k0 + t, i, 0] = Thc[t, i, l]
    for l in range(nl):
        _lane_store(S[s0 + l], U, D, th, l, NP)
        codes[s0 + l] = int(bad[0, 0, l])


@njit(**_PAR)
def rls_soa_batched(S, Phi, Y, lam, w, Th, E, skipped, Lk, opt, mat, codes, ntag, ptag):
    """:func:`._rls.rls_run_batched` with ``LANES`` streams per vector (p = 1)."""
    NP = dim(ntag)
    nb = (Phi.shape[0] + LANES - 1) // LANES
    il0 = _reciprocal(lam, (0, 0))
    r0 = _reciprocal(w, (0, 0))
    for q in prange(nb):
        _batched_block(S, Phi, Y, lam, w, Th, E, skipped, codes, q * LANES, opt[0], il0, r0,
                       NP)


# --- segments: sorted by length, dealt to blocks ---
@njit(**_INL)
def _segment_gather(Phi, Y, lam, w, sa, sn, k0, T, X, Yc, Lc, Wc, Rc, il0, r0, NP):
    """Samples k0 … k0+T−1 of the lanes' segments (rows sa[l] …, sn[l] of them);
    past the end of its segment a lane reads a row of NaN (skipped: state kept)."""
    for t in range(T):
        k = k0 + t
        for l in range(LANES):
            live = k < sn[l]
            row = sa[l] + max(min(k, sn[l] - 1), 0)
            for i in range(NP):
                X[t, i, l] = Phi[row, i] if live else np.nan
            Yc[0, t, l] = Y[row, 0] if live else np.nan
            if not (il0 == il0 and r0 == r0):
                _aux_lane(Lc, Wc, Rc, t, l, lam[row], w[row], il0, r0)


@njit(**_INL)
def _segment_block(S0, Sout, Phi, Y, offsets, lam, w, Th, E, skipped, codes, seg, dthr, il0,
                   r0, NP):
    U, D, th, bad, X, Yc, Lc, Wc, Rc, Ec, Sk, Thc = _block_scratch(NP)
    store = Th.shape[0] == Phi.shape[0]
    sa = np.zeros(LANES, dtype=np.int64)  # first row and length of each lane's segment
    sn = np.zeros(LANES, dtype=np.int64)
    for l in range(LANES):
        _lane_load(S0, U, D, th, bad, l, NP)
        g = seg[l]
        if g >= 0 and offsets[g + 1] > offsets[g]:
            sa[l] = offsets[g]
            sn[l] = offsets[g + 1] - offsets[g]
    M = sn.max()
    if il0 == il0 and r0 == r0 and M > 0:
        _fill_constant(Lc, Wc, Rc, il0, w[0], r0)
    for k0 in range(0, M, CHUNK):
        T = min(CHUNK, M - k0)
        _segment_gather(Phi, Y, lam, w, sa, sn, k0, T, X, Yc, Lc, Wc, Rc, il0, r0, NP)
        _lane_steps(U, D, th, bad, X, Yc, Lc, Wc, Rc, Ec, Sk, Thc, k0, T, dthr, NP)
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
        if g >= 0:
            Sout[g, :] = S0
            _lane_store(Sout[g], U, D, th, l, NP)
            codes[g] = int(bad[0, 0, l])


@njit(**_PAR)
def rls_soa_segments(S0, Sout, Phi, Y, offsets, lam, w, Th, E, skipped, Lk, opt, mat, codes,
                     ntag, ptag):
    """:func:`._rls.rls_run_segments` with ``LANES`` segments per vector (p = 1).

    The segments are sorted by length and dealt ``LANES`` to a block; the
    blocks are taken longest and shortest alternately, so that the threads'
    equal shares of the blocks hold about equal work.
    """
    NP = dim(ntag)
    G = offsets.shape[0] - 1
    order = np.argsort(offsets[:-1] - offsets[1:], kind="mergesort")  # longest first
    nb = (G + LANES - 1) // LANES
    il0 = _reciprocal(lam, 0)
    r0 = _reciprocal(w, 0)
    for q in prange(nb):
        blk = q // 2 if q % 2 == 0 else nb - 1 - q // 2
        seg = np.full(LANES, -1, dtype=np.int64)
        for l in range(min(LANES, G - blk * LANES)):
            seg[l] = order[blk * LANES + l]
        _segment_block(S0, Sout, Phi, Y, offsets, lam, w, Th, E, skipped, codes, seg,
                       opt[0], il0, r0, NP)
