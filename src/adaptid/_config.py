"""Numba flags and numerical thresholds, in one place.

Every compiled kernel takes its decorator options from here, so that the
whole library can be switched at once (e.g. ``NUMBA_DISABLE_JIT=1`` for
coverage of the kernels' Python source).
"""

import os

# fastmath={"contract"} lets LLVM fuse a*b + c into one FMA instruction (what
# gcc -O3 does for C by default) and nothing else: no reassociation, no
# assumption that values are finite, so NaN/inf checks and summation order stay
# as written. Results are deterministic on a given machine; on a CPU without FMA
# they differ in the last bits.

#: Options of every public kernel (compiled once, cached on disk).
NJIT = dict(cache=True, nogil=True, fastmath={"contract"})
#: Options of kernels that run over independent streams in parallel.
NJIT_PARALLEL = dict(cache=True, nogil=True, parallel=True, fastmath={"contract"})
#: Options of the small building blocks inlined into the kernels.
NJIT_INLINE = dict(cache=True, inline="always", fastmath={"contract"})

#: Largest number of parameters for which kernels are specialised (n as a
#: compile-time constant, loops unrolled). Larger n use the generic kernels.
MAX_SPECIALISED_N = int(os.environ.get("ADAPTID_MAX_SPECIALISED_N", "16"))

#: Removal of a sample from a sliding window is refused, and the window
#: re-solved from its buffer, when ``1 - c φᵀPφ`` (the ratio of the
#: determinants of the information matrix after and before the removal)
#: falls below this value: the downdate would cancel more than half the
#: digits in that direction.
DOWNDATE_RTOL = 1e-8
