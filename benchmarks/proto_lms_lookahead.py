"""Prototype (not used by the library): LMS with the error's dot product off the critical path.

    python benchmarks/proto_lms_lookahead.py

Issue 16 asks LMS ``run`` to reach the fastest C loop (it is at parity within the
host's noise). The hypothesis tested here: the loop is bound by the latency of the
chain θₖ₋₁ → εₖ = yₖ − φₖᵀθₖ₋₁ → θₖ. Rewriting εₖ = (yₖ − φₖᵀθₖ₋₂) − cₖ₋₁(φₖᵀφₖ₋₁),
with cₖ₋₁ = μεₖ₋₁, takes φₖᵀθₖ₋₂ off the chain (it is known a step early), at the
price of a second dot product and a state twice as large (θₖ₋₂, φₖ₋₁, cₖ₋₁: update
could then still equal run bit for bit). It prints the two loops (n = 8, p = 1,
10⁶ samples, store=False) and adaptid's LMS for scale, in ns per sample.

Result (2026-11-28, 2-vCPU Xeon, numba 0.68.1): direct 12.2–13.7, look-ahead
15.4–16.1, adaptid 12.9–14.8 ns: the rewrite is slower, so the loop is bound by
its throughput, not by that chain. Not pursued.
"""
import time, numpy as np, numba
from numba import njit
import adaptid

@njit(cache=False, fastmath={"contract"})
def lms_direct(th0, Phi, y, mu, E):
    n = 8
    th = np.empty(n)
    for i in range(n): th[i] = th0[i]
    for k in range(Phi.shape[0]):
        s0 = y[k]; s1 = 0.0; s2 = 0.0; s3 = 0.0
        for i in range(0, n, 4):
            s0 -= Phi[k, i] * th[i]; s1 -= Phi[k, i+1] * th[i+1]; s2 -= Phi[k, i+2] * th[i+2]; s3 -= Phi[k, i+3] * th[i+3]
        e = (s0 + s1) + (s2 + s3)
        E[k] = e
        for i in range(n):
            th[i] += (mu * Phi[k, i]) * e
    for i in range(n): th0[i] = th[i]

@njit(cache=False, fastmath={"contract"})
def dot4(a, k, b):
    s0 = a[k, 0] * b[0]; s1 = a[k, 1] * b[1]; s2 = a[k, 2] * b[2]; s3 = a[k, 3] * b[3]
    for i in range(4, 8, 4):
        s0 += a[k, i] * b[i]; s1 += a[k, i+1] * b[i+1]; s2 += a[k, i+2] * b[i+2]; s3 += a[k, i+3] * b[i+3]
    return (s0 + s1) + (s2 + s3)

@njit(cache=False, fastmath={"contract"})
def lms_ahead(th0, Phi, y, mu, E):
    # state: th (theta_{k-1}), tp (theta_{k-2}), pprev (phi_{k-1}), cprev
    n = 8
    th = np.empty(n); tp = np.empty(n); pp = np.zeros(n)
    for i in range(n): th[i] = th0[i]; tp[i] = th0[i]
    c = 0.0
    N = Phi.shape[0]
    for k in range(N):
        b = dot4(Phi, k, tp)          # phi_k' theta_{k-2}: off the chain
        r = 0.0
        for i in range(n): r += Phi[k, i] * pp[i]   # phi_k' phi_{k-1}: data only
        e = (y[k] - b) - c * r
        E[k] = e
        c = mu * e
        for i in range(n):
            tp[i] = th[i]
            th[i] += c * Phi[k, i]
            pp[i] = Phi[k, i]
    for i in range(n): th0[i] = th[i]

n, N = 8, 1_000_000
rng = np.random.default_rng(0)
Phi = rng.standard_normal((N, n)); y = Phi @ rng.standard_normal(n) + 0.1 * rng.standard_normal(N)
E1 = np.empty(N); E2 = np.empty(N)
t1 = np.zeros(n); t2 = np.zeros(n)
lms_direct(t1, Phi[:10], y[:10], 0.01, E1); lms_ahead(t2, Phi[:10], y[:10], 0.01, E2)
t1 = np.zeros(n); t2 = np.zeros(n)
lms_direct(t1, Phi, y, 0.01, E1); lms_ahead(t2, Phi, y, 0.01, E2)
print("max rel diff theta", np.max(np.abs(t1 - t2) / np.abs(t1)), "E", np.max(np.abs(E1 - E2)))
est = adaptid.LMS(n, step=0.01)
for r in range(5):
    ts = []
    for f in (lms_direct, lms_ahead):
        th = np.zeros(n); t = time.perf_counter(); f(th, Phi, y, 0.01, E1); ts.append(time.perf_counter() - t)
    est.reset(); t = time.perf_counter(); est.run(Phi, y, store=False); ts.append(time.perf_counter() - t)
    print(" ".join(f"{x*1e9/N:.2f}" for x in ts), "ns/sample (direct, ahead, adaptid store=False)")
