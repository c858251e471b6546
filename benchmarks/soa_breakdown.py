"""Where the time of the structure-of-arrays RLS kernel goes (n = 4, B = 10 000, 260 samples).

Builds the block loop of ``adaptid._kernels.lanes._soa.rls_soa_batched`` (or, with
``--form covariance``, of ``cov_soa_batched``) from its own pieces four times,
inlined into one parallel loop: complete; without the lane steps (the gather
of Φ, y into lane-major scratch and the scatter of ε, skipped); the steps only
(on the block's first chunk of samples, gathered once and stepped on again and
again: no gather or scatter in the loop); the scatter only. Here each chunk is
gathered whole before its steps, as the kernel did before it gathered the next
chunk one sample per step (``_soa._chunk``): the pieces apart, not their
overlap. The library's kernel itself is timed in the same rounds ("the kernel
(_soa)"), and the same-round ratio of the two complete loops is printed.
Prints the best (and median) of ``--rounds`` rounds of each.
A diagnostic of issue 19 point 3, not a speed claim::

    NUMBA_NUM_THREADS=1 python benchmarks/soa_breakdown.py [--form ud|covariance] [--rounds 5]
"""
import argparse
import time

import numba
import numpy as np
from adaptid._kernels.lanes import _soa as S
from adaptid._kernels.toolchain._dims import dim
LANES, CHUNK = S.LANES, S.CHUNK
_PAR = dict(parallel=True, nogil=True, fastmath={"contract"}, error_model="numpy")

ap = argparse.ArgumentParser()
ap.add_argument("--form", choices=("ud", "covariance"), default="ud")
ap.add_argument("--rounds", type=int, default=5)
_args = ap.parse_args()
FORM = S.COV if _args.form == "covariance" else S.UD
ROUNDS = _args.rounds


def make(do_gather, do_steps, do_scatter):
    @numba.njit(**_PAR)
    def run(Sx, Phi, Y, lam, w, Th, E, skipped, codes, dthr, il0, r0, ntag):
        NP = dim(ntag)
        nb = (Phi.shape[0] + LANES - 1) // LANES
        for q in numba.prange(nb):
            s0 = q * LANES
            U, D, th, bad, X, Yc, Lc, Wc, Rc, Ec, Sk, Thc = S._block_scratch(NP)
            nl = min(LANES, Sx.shape[0] - s0)
            N = Phi.shape[1]
            for l in range(LANES):
                S.lane_load(FORM, Sx[s0 + min(l, nl - 1)], U, D, th, bad, l, NP)
            S._fill_constant(Lc, Wc, Rc, il0, 1.0, r0)
            # the block's first chunk of real samples, which the variants without the
            # gather step on again and again (a constant chunk, φ = 0.1 and y = 0, ran
            # the steps 20-25 % faster than real data, for a reason not found)
            S._batched_gather(FORM, Phi, Y, lam, w, s0, nl, 0, 0, CHUNK, X, Yc, Lc, Wc, Rc, il0, r0, NP)
            for k0 in range(0, N, CHUNK):
                T = min(CHUNK, N - k0)
                if do_gather:
                    S._batched_gather(FORM, Phi, Y, lam, w, s0, nl, k0, 0, T, X, Yc, Lc, Wc, Rc, il0, r0, NP)
                if do_steps:
                    S.lane_steps(FORM, U, D, th, bad, X, Yc, Lc, Wc, Rc, Ec, Sk, Thc, k0, 0, T, dthr, NP)
                if do_scatter:
                    S._batched_scatter(E, skipped, Ec, Sk, s0, nl, k0, 0, T)
            for l in range(nl):
                S.lane_store(FORM, Sx[s0 + l], U, D, th, l, NP)
    return run

n=4; B=10000; N=260
rng=np.random.default_rng(0)
Phi=rng.standard_normal((B,N,n)); Y=(Phi@rng.standard_normal(n)+0.1*rng.standard_normal((B,N)))[..., None]
lam=np.broadcast_to(0.99,(B,N)); w=np.broadcast_to(1.0,(B,N))
st = np.zeros((B, n + n*n + n))
if FORM == S.COV:  # [θ | P | 0]
    st[:, n:n + n * n] = (1e3 * np.eye(n)).ravel()
else:  # [θ | U | D]
    st[:, n + n * n:] = 1e3
variants = {"all, chunk gathered whole": (1, 1, 1), "gather + scatter": (1, 0, 1),
            "steps only": (0, 1, 0), "scatter only": (0, 0, 1)}
fns = {k: make(*v) for k, v in variants.items()}
_kernel = S.cov_soa_batched if FORM == S.COV else S.rls_soa_batched


def the_kernel(Sx, Phi, Y, lam, w, Th, E, skipped, codes, dthr, il0, r0, ntag):
    """The library's kernel (next chunk gathered one sample per step), same arguments."""
    _kernel(Sx, Phi, Y, lam, w, Th, E, skipped, np.empty((Sx.shape[0], 0)), np.array([dthr]),
            np.empty(0), codes, ntag, (0,))


fns = {"the kernel (_soa)": the_kernel, **fns}
for k, f in fns.items():
    E=np.empty((B,N,1)); sk=np.zeros((B,N),bool); f(st.copy(), Phi, Y, lam, w, np.empty((B,0,n,1)), E, sk, np.empty(B,np.int64), 1e300, 1/0.99, 1.0 if FORM == S.UD else 0.99, (0,)*n)
res = {k: [] for k in fns}
for r in range(ROUNDS):
    for k, f in fns.items():
        s2 = st.copy(); E=np.empty((B,N,1)); sk=np.zeros((B,N),bool)
        t=time.perf_counter(); f(s2, Phi, Y, lam, w, np.empty((B,0,n,1)), E, sk, np.empty(B,np.int64), 1e300, 1/0.99, 1.0 if FORM == S.UD else 0.99, (0,)*n); res[k].append(time.perf_counter()-t)
for k, v in res.items(): print("%-26s %.2f ms  %.0f M updates/s  (median %.2f ms)" % (k, 1e3*min(v), B*N/min(v)/1e6, 1e3*np.median(v)))
r = [a / b for a, b in zip(res["the kernel (_soa)"], res["all, chunk gathered whole"])]
print("the kernel / chunk gathered whole, same round: median %.3f (min %.3f, max %.3f)" % (np.median(r), min(r), max(r)))
