"""Statistics of segmented runs (streams stored back to back)."""

from numba import prange

from ..._config import NJIT_INLINE, NJIT_PARALLEL, njit

#: partial sums per output: independent adds instead of one chain through every
#: sample (the chain and its branch made this pass 1/4 of run_segments at n = 4)
PARTS = 4


@njit(**NJIT_INLINE)
def _sse_one(E, skipped, a, z, j):
    """Σ εₖⱼ² over the used samples a ≤ k < z, in ``PARTS`` partial sums (k mod PARTS)
    added as a tree; the number of skipped samples."""
    s0 = s1 = s2 = s3 = 0.0
    c = 0
    k = a
    while k + PARTS <= z:
        e0, e1, e2, e3 = E[k, j], E[k + 1, j], E[k + 2, j], E[k + 3, j]
        k0, k1, k2, k3 = skipped[k], skipped[k + 1], skipped[k + 2], skipped[k + 3]
        s0 += 0.0 if k0 else e0 * e0
        s1 += 0.0 if k1 else e1 * e1
        s2 += 0.0 if k2 else e2 * e2
        s3 += 0.0 if k3 else e3 * e3
        c += int(k0) + int(k1) + int(k2) + int(k3)  # (NumPy adds bools as "or")
        k += PARTS
    while k < z:
        e0 = E[k, j]
        s0 += 0.0 if skipped[k] else e0 * e0
        c += int(skipped[k])
        k += 1
    return (s0 + s1) + (s2 + s3), c


@njit(**NJIT_PARALLEL)
def segment_stats(E, skipped, offsets, n_skip, sse):
    """Per segment: skipped samples and Σ ε² over the used ones (parallel over segments)."""
    for g in prange(offsets.shape[0] - 1):
        for j in range(E.shape[1]):
            sse[g, j], n_skip[g] = _sse_one(E, skipped, offsets[g], offsets[g + 1], j)
