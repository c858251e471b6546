"""Tests of adaptid._kernels: the compiled kernels, their cache and the numba toolchain."""
