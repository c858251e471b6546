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
 * Compile with -DLMS_SPLIT4=1 to sum the dot products phi' theta and phi' phi
 * in four interleaved partial sums when n >= 8, as adaptid's kernel does (the
 * error's dot product is the loop-carried critical path; gcc may not
 * reassociate the plain sum by itself without -ffast-math).
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

#ifndef LMS_SPLIT4
#define LMS_SPLIT4 0
#endif

/* c + sign * sum_i a[i] b[i] */
static inline double dot(double c, double sign, const double *restrict a,
                         const double *restrict b, int n)
{
    if (LMS_SPLIT4 && n >= 8) {
        double s0 = c, s1 = 0.0, s2 = 0.0, s3 = 0.0;
        int m = n - n % 4;
        for (int i = 0; i < m; i += 4) {
            s0 += sign * a[i] * b[i];
            s1 += sign * a[i + 1] * b[i + 1];
            s2 += sign * a[i + 2] * b[i + 2];
            s3 += sign * a[i + 3] * b[i + 3];
        }
        for (int i = m; i < n; ++i) s0 += sign * a[i] * b[i];
        return (s0 + s1) + (s2 + s3);
    }
    double s = c;
    for (int i = 0; i < n; ++i) s += sign * a[i] * b[i];
    return s;
}

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
        double e = dot(y[k], -1.0, phi, theta, NDIM);
        double g = mu;
        if (normalised) g = mu / dot(eps, 1.0, phi, phi, NDIM);
        for (int i = 0; i < NDIM; ++i) theta[i] += (g * phi[i]) * e;
        if (E) E[k] = e;
        if (Th) {
            double *t = Th + k * NDIM;
            for (int i = 0; i < NDIM; ++i) t[i] = theta[i];
        }
    }
    return 0;
}
