"""Prototype (not used by the library): a narrow compiled step entry for RLS.update.

    python benchmarks/proto_update_step.py

``update`` today is a run of length 1 through ``run``'s compiled entry, with its 14
arguments (11 arrays). numba unboxes each array argument (~55 ns each here). This
prototype compiles one more entry, ``rls_step(S, W, skipped, ntag, ptag)``, which
takes φ, y, λ, w, the windup threshold and ε in one work array W. It calls the same
inlined body (``adaptid._kernels._rls._rls_body``) on views of W.

It prints:

* the compile time of that entry (numba's cache folder: $NUMBA_CACHE_DIR);
* whether S and ε equal those of ``RLS.update`` bit for bit, after 1 and 1000 steps;
* per call, in the same rounds: ``RLS(4).update``, the narrow entry with the least
  Python around it (copy φ and y into W, call, read ε), and the narrow entry alone.

The gap between the first two figures bounds what a narrow entry plus a lean
Python path could save. The engine's rule (``adaptid._kernels.Entries``: no
single-step entry) is why the library does not do this.
"""
import time, timeit, itertools
import numpy as np
import numba
from adaptid._config import njit, NJIT
from adaptid._kernels._rls import _rls_body
from adaptid._kernels._dims import dim
import adaptid

@njit(**NJIT)
def rls_step(S, W, skipped, ntag, ptag):
    NP = dim(ntag)
    p = dim(ptag)
    Phi = W[:NP].reshape((1, NP))
    Y = W[NP:NP + p].reshape((1, p))
    lam = W[NP + p:NP + p + 1]
    w = W[NP + p + 1:NP + p + 2]
    E = W[NP + p + 3:NP + 2 * p + 3].reshape((1, p))
    Th = W[:0].reshape((0, NP, p))
    return _rls_body(S, Phi, Y, lam, w, Th, E, skipped, None, W[NP + p + 2], ntag, ptag)

n, p = 4, 1
rng = np.random.default_rng(1)
rows = list(rng.standard_normal((4096, n)))
ys = [float(v) for v in rng.standard_normal(4096)]
est = adaptid.RLS(n, forgetting=0.99)
est2 = adaptid.RLS(n, forgetting=0.99)
t = time.perf_counter()
est.update(rows[0], ys[0])
S = est2._S.copy(); S[:] = est2._S
W = np.zeros(n + 2 * p + 3); W[n + p] = 0.99; W[n + p + 1] = 1.0; W[n + p + 2] = est2._opt[0]
sk = np.zeros(1, np.bool_)
ntag, ptag = est2._ntag, est2._ptag
W[:n] = rows[0]; W[n] = ys[0]
t = time.perf_counter(); rls_step(S, W, sk, ntag, ptag); print(f"compile step {time.perf_counter()-t:.2f} s")
ep = rls_step.overloads[tuple(numba.typeof(a) for a in (S, W, sk, ntag, ptag))].entry_point
print("bits after 1 step equal:", np.array_equal(S, est._S), W[n + p + 3] == est._step.E[0, 0])
# 1000 steps each: compare bits
for k in range(1, 1000):
    est.update(rows[k], ys[k])
    W[:n] = rows[k]; W[n] = ys[k]; ep(S, W, sk, ntag, ptag)
print("bits after 1000 steps equal:", np.array_equal(S, est._S))
phi1 = W[:n]
def fast(phi, y):
    phi1[...] = phi
    W[4] = y
    code = ep(S, W, sk, ntag, ptag)
    return W.item(n + p + 3)
it = itertools.cycle(range(4096))
for r in range(4):
    u = min(timeit.repeat(lambda: est.update(rows[(k := next(it))], ys[k]), number=50000, repeat=5)) / 50000 * 1e9
    f = min(timeit.repeat(lambda: fast(rows[(k := next(it))], ys[k]), number=50000, repeat=5)) / 50000 * 1e9
    e = min(timeit.repeat(lambda: ep(S, W, sk, ntag, ptag), number=50000, repeat=5)) / 50000 * 1e9
    print(f"update {u:.0f} ns   narrow entry + minimal Python {f:.0f} ns   narrow entry alone {e:.0f} ns")
