/*
 * The cost floor of one stage of the QR lattice (benchmarks/bench_fastrls.py
 * --floor), the same loops as the numba versions timed beside them, compiled
 * with gcc -O3 -march=native at benchmark time:
 *
 *   sqrt_recip   r_i = sqrt(q_i), v_i = 1 / r_i over n independent values
 *                (vectorised): the square root and division of one rotation;
 *                the lattice does this twice per stage per sample;
 *   rot_chain    f <- c_i f - s_i (lambda^(1/2) x_i), x_i <- s_i f + c_i x_i:
 *                one rotation per stage, each waiting for the previous
 *                multiply-add (the forward and joint-process passes);
 *   givens_chain the rotation chain as the lattice had it before:
 *                r = sqrt(t^2 + x_i^2), c = t/r, s = x_i/r, t = r (square
 *                root and two divisions on the chain).
 *
 * Each runs `reps` times over n stages; the caller divides the time by
 * reps * n. Arrays are float64 (numpy through ctypes).
 */
#include <math.h>

void sqrt_recip(const double *q, double *r, double *v, int n, long reps)
{
    long k;
    int i;
    for (k = 0; k < reps; k++) {
        for (i = 0; i < n; i++) r[i] = sqrt(q[i]);
        for (i = 0; i < n; i++) v[i] = 1.0 / r[i];
        __asm__ volatile("" : : "r"(r), "r"(v) : "memory");
    }
}

double rot_chain(const double *c, const double *s, double *x, int n, long reps, double ls)
{
    double f, t, acc = 0.0;
    long k;
    int i;
    for (k = 0; k < reps; k++) {
        f = 0.25;
        for (i = 0; i < n; i++) {
            t = x[i] * ls;
            x[i] = s[i] * f + c[i] * t;
            f = c[i] * f - s[i] * t;
        }
        acc += f;
    }
    return acc;
}

double givens_chain(const double *x, double *e, int n, long reps)
{
    double t, f, h, cc, ss, a, acc = 0.0;
    long k;
    int i;
    for (k = 0; k < reps; k++) {
        t = 1.0;
        f = 0.1;
        for (i = n - 1; i >= 0; i--) {
            h = sqrt(t * t + x[i] * x[i]);
            cc = t / h;
            ss = x[i] / h;
            a = e[i];
            e[i] = cc * a - ss * f;
            f = cc * f + ss * a;
            t = h;
        }
        acc += f + t;
    }
    return acc;
}
