/*
 * Reference RLS loop for benchmarks/bench_rls.py: the textbook covariance
 * form with exponential forgetting, written plainly in C and compiled with
 * gcc -O3 -march=native at benchmark time.
 *
 *   e  = y - phi' theta                  (a-priori error)
 *   g  = P phi,  h = phi' P              (one pass over P)
 *   K  = g / (lambda + phi' g)
 *   theta += K e
 *   P  = (P - K h) / lambda              (P <- (P - K phi' P) / lambda)
 *
 * No symmetrisation, no definiteness check, no finiteness check: the plain
 * form adaptid's U-D (Bierman) kernel is measured against.
 *
 * h = phi' P is computed, not replaced by g' (P is symmetric only up to
 * rounding): the shortcut P <- (P - K g')/lambda saves a pass but is
 * numerically unstable for lambda < 1 -- the antisymmetric rounding error
 * of P is multiplied by 1/lambda every step, and at lambda = 0.99 theta is
 * wrong by O(1) after some thousands of samples.
 *
 * Compiled with -DRLS_SYM=1 the update is instead done on the upper
 * triangle and mirrored (P exactly symmetric; another common practical form).
 *
 * Compile with -DRLS_N=<n> to make n a compile-time constant (gcc then
 * unrolls / vectorises the fixed-size loops, as adaptid's kernels
 * specialised per n do); without it n is a run-time argument (n <= 256).
 *
 * Arrays are C-contiguous float64 (numpy through ctypes):
 *   Phi (N, n), y (N), theta (n) in/out, P (n, n) in/out,
 *   Th (N, n) or NULL (theta after every sample), E (N) or NULL (errors).
 * Batched: Phi (B, N, n), y (B, N), theta (B, n), P (B, n, n),
 *   Th (B, N, n) or NULL, E (B, N) or NULL; streams are independent.
 */
#include <stddef.h>

#ifdef RLS_N
#define NDIM RLS_N
#define NBUF RLS_N
#else
#define NDIM n
#define NBUF 256
#endif
#ifndef RLS_SYM
#define RLS_SYM 0
#endif

int rls_ref_symmetric(void)
{
    return RLS_SYM;
}

int rls_ref_fixed_n(void)
{
#ifdef RLS_N
    return RLS_N;
#else
    return 0;
#endif
}

static inline void rls_stream(int n, long N, const double *restrict Phi,
                              const double *restrict y, double lam,
                              double *restrict theta, double *restrict P,
                              double *restrict Th, double *restrict E)
{
    double g[NBUF], h[NBUF], K[NBUF];
    const double il = 1.0 / lam;
    (void)n;
    (void)h;
    for (long k = 0; k < N; ++k) {
        const double *phi = Phi + k * NDIM;
        double e = y[k];
        for (int i = 0; i < NDIM; ++i)
            e -= phi[i] * theta[i];
#if RLS_SYM
        for (int i = 0; i < NDIM; ++i) {
            double s = 0.0;
            for (int j = 0; j < NDIM; ++j)
                s += P[i * NDIM + j] * phi[j];
            g[i] = s;
        }
#else
        for (int j = 0; j < NDIM; ++j)
            h[j] = 0.0;
        for (int i = 0; i < NDIM; ++i) {
            double s = 0.0;
            const double fi = phi[i];
            for (int j = 0; j < NDIM; ++j) {
                const double pij = P[i * NDIM + j];
                s += pij * phi[j];
                h[j] += fi * pij;
            }
            g[i] = s;
        }
#endif
        double q = 0.0;
        for (int i = 0; i < NDIM; ++i)
            q += phi[i] * g[i];
        const double ia = 1.0 / (lam + q);
        for (int i = 0; i < NDIM; ++i) {
            K[i] = g[i] * ia;
            theta[i] += K[i] * e;
        }
#if RLS_SYM
        for (int i = 0; i < NDIM; ++i)
            for (int j = i; j < NDIM; ++j) {
                const double v = (P[i * NDIM + j] - K[i] * g[j]) * il;
                P[i * NDIM + j] = v;
                P[j * NDIM + i] = v;
            }
#else
        for (int i = 0; i < NDIM; ++i)
            for (int j = 0; j < NDIM; ++j)
                P[i * NDIM + j] = (P[i * NDIM + j] - K[i] * h[j]) * il;
#endif
        if (Th)
            for (int i = 0; i < NDIM; ++i)
                Th[k * NDIM + i] = theta[i];
        if (E)
            E[k] = e;
    }
}

/* One stream; returns 0, or -1 if n differs from the compile-time RLS_N (or exceeds the buffer). */
int rls_run(int n, long N, const double *Phi, const double *y, double lam,
            double *theta, double *P, double *Th, double *E)
{
#ifdef RLS_N
    if (n != RLS_N)
        return -1;
#else
    if (n > NBUF)
        return -1;
#endif
    rls_stream(n, N, Phi, y, lam, theta, P, Th, E);
    return 0;
}

/* B independent streams, the same loop; nthreads > 1 uses OpenMP if compiled with -fopenmp. */
int rls_run_batched(int n, long B, long N, const double *Phi, const double *y, double lam,
                    double *theta, double *P, double *Th, double *E, int nthreads)
{
#ifdef RLS_N
    if (n != RLS_N)
        return -1;
#else
    if (n > NBUF)
        return -1;
#endif
    (void)nthreads;
#pragma omp parallel for schedule(static) num_threads(nthreads)
    for (long b = 0; b < B; ++b)
        rls_stream(n, N, Phi + b * N * NDIM, y + b * N, lam,
                   theta + b * NDIM, P + b * NDIM * NDIM,
                   Th ? Th + b * N * NDIM : NULL, E ? E + b * N : NULL);
    return 0;
}
