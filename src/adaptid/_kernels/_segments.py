"""Statistics of segmented runs (streams stored back to back)."""

from numba import prange

from .._config import NJIT_PARALLEL, njit


@njit(**NJIT_PARALLEL)
def segment_stats(E, skipped, offsets, n_skip, sse):
    """Per segment: skipped samples and Σ ε² over the used ones (parallel over segments)."""
    p = E.shape[1]
    for g in prange(offsets.shape[0] - 1):
        c = 0
        for j in range(p):
            sse[g, j] = 0.0
        for k in range(offsets[g], offsets[g + 1]):
            if skipped[k]:
                c += 1
            else:
                for j in range(p):
                    sse[g, j] += E[k, j] * E[k, j]
        n_skip[g] = c

