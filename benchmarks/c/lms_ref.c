/*
 * Reference LMS / NLMS loop for benchmarks/bench_lms.py, written plainly in C
 * and compiled with gcc -O3 -march=native at benchmark time.
 *
 *   e      = y - phi' theta                          (a-priori error)
 *   g      = mu                  (LMS)
 *   g      = mu / (eps + phi' phi)   (NLMS)
 *   theta += (g phi) e
 *
 * No finiteness check and no weights: the plain form adaptid's kernel
 * (which also checks every sample for NaN/inf and scales the step by a
 * weight) is measured against.
 *
 * Compile with -DLMS_N=<n> to make n a compile-time constant (gcc then
 * unrolls / vectorises the fixed-size loops, as adaptid's kernels
 * specialised per n do); without it n is a run-time argument.
 *
 * Arrays are C-contiguous float64 (numpy through ctypes):
 *   Phi (N, n), y (N), theta (n) in/out,
 *   Th (N, n) or NULL (theta after every sample), E (N) or NULL (errors).
 */
#include <stddef.h>

#ifdef LMS_N
#define NDIM LMS_N
#else
#define NDIM n
#endif

int lms_run(int n, long N, const double *restrict Phi, const double *restrict y,
            double mu, double eps, int normalised, double *restrict theta,
            double *restrict Th, double *restrict E)
{
#ifdef LMS_N
    if (n != LMS_N) return 1;
#endif
    for (long k = 0; k < N; ++k) {
        const double *phi = Phi + k * NDIM;
        double e = y[k];
        for (int i = 0; i < NDIM; ++i) e -= phi[i] * theta[i];
        double g = mu;
        if (normalised) {
            double q = eps;
            for (int i = 0; i < NDIM; ++i) q += phi[i] * phi[i];
            g = mu / q;
        }
        for (int i = 0; i < NDIM; ++i) theta[i] += (g * phi[i]) * e;
        if (E) E[k] = e;
        if (Th) {
            double *t = Th + k * NDIM;
            for (int i = 0; i < NDIM; ++i) t[i] = theta[i];
        }
    }
    return 0;
}
