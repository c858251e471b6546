r"""C update of the gradient estimators LMS and NLMS (no covariance).

Mirrors, operation for operation, ``_lms_stream`` of
:mod:`adaptid._kernels.recursions._lms` for one output and weight 1: the same dot
products (sequential for n < 8, four interleaved partial sums for n ≥ 8, as
its ``_dot``), the same cheap finiteness test with the exact check as the
fallback, the same gain ``μ`` (LMS) or ``μ / (ε₀ + φᵀφ)`` (NLMS, no step when
φᵀφ + ε₀ is not positive), the same increment ``θᵢ ← θᵢ + (g φᵢ) ε`` fused as
``FMA(g φᵢ, ε, θᵢ)``. Divergence (a non-finite a-priori error on finite data,
or a non-finite θ) sets a sticky flag, as the kernel's code makes Python warn
(``DivergenceWarning``).
"""

from __future__ import annotations

KINDS = ("LMS", "NLMS")

# the dot product of the kernel's _dot: c + sign * sum_i a_i b_i, where
# sign * a_i is exact (sign = +-1) and every product is fused into its sum
_DOT_SEQ = r"""
/* c + sign * sum_i a_i b_i (sign = +1 or -1), summed in index order as
 * adaptid's kernel sums it (adaptid/_kernels/recursions/_lms.py, _dot, n < 8). */
static real dot(real c, real sign, const real a[$N], const real b[$N])
{
    real s = c;
    int i;
    for (i = 0; i < $N; i++) {
        s = FMA(sign * a[i], b[i], s);
    }
    return s;
}
"""

_DOT_PARTIAL = r"""
/* c + sign * sum_i a_i b_i (sign = +1 or -1) in four interleaved partial sums,
 * as adaptid's kernel sums it for n >= 8 (adaptid/_kernels/recursions/_lms.py, _dot: it
 * shortens the loop-carried chain theta_k <- eps_k <- theta_{k-1}). */
static real dot(real c, real sign, const real a[$N], const real b[$N])
{
    real s0 = c, s1 = 0.0, s2 = 0.0, s3 = 0.0;
    int i;
    for (i = 0; i < $N - $N % 4; i += 4) {
        s0 = FMA(sign * a[i], b[i], s0);
        s1 = FMA(sign * a[i + 1], b[i + 1], s1);
        s2 = FMA(sign * a[i + 2], b[i + 2], s2);
        s3 = FMA(sign * a[i + 3], b[i + 3], s3);
    }
    for (; i < $N; i++) {
        s0 = FMA(sign * a[i], b[i], s0);
    }
    return (s0 + s1) + (s2 + s3);
}
"""

# phi^T phi for n >= 8 in the kernel specialised for n (unrolled): lanes 1-3 of
# the partial sums start at +0.0, and 0.0 + phi_l^2 is phi_l^2 (a square is
# never -0), so LLVM drops the addition; the lane's next sum then adds two
# products, and LLVM fuses the first: FMA(phi_l, phi_l, phi_{l+4}^2) (found
# by matching the kernel bit for bit; the error's products, phi_l theta_l, can
# be -0 and keep the 0.0 +). The generic kernel (a loop) sums as _DOT_PARTIAL.
_SUMSQ_UNROLLED = r"""
/* c + phi^T phi in four partial sums, fused as adaptid's kernel specialised
 * for n fuses them (adaptid/_kernels/recursions/_lms.py, _dot; see codegen/_lms.py). */
static real sumsq(real c, const real a[$N])
{
    real s0 = FMA(a[0], a[0], c);
    real s1 = FMA(a[1], a[1], a[5] * a[5]);
    real s2 = FMA(a[2], a[2], a[6] * a[6]);
    real s3 = FMA(a[3], a[3], a[7] * a[7]);
    int i;
    s0 = FMA(a[4], a[4], s0);
    for (i = 8; i < $N - $N % 4; i += 4) {
        s0 = FMA(a[i], a[i], s0);
        s1 = FMA(a[i + 1], a[i + 1], s1);
        s2 = FMA(a[i + 2], a[i + 2], s2);
        s3 = FMA(a[i + 3], a[i + 3], s3);
    }
    for (; i < $N; i++) {
        s0 = FMA(a[i], a[i], s0);
    }
    return (s0 + s1) + (s2 + s3);
}
"""

_UPDATE = r"""
$R $P_update($T *s, const $R phi[$N], $R y)
{
    real q, e, g;
    int i, finite = 1;

    /* a-priori error  eps_k = y_k - phi_k^T theta_{k-1} */
    e = dot(y, -1.0, phi, s->theta);
    /* Finiteness of the sample, cheaply (as adaptid's kernel): eps is finite
     * only if y and phi are (and theta is)@Q@. Otherwise decide on the values:
     * a sample with NaN or inf is skipped, theta unchanged, counted in
     * n_skipped (adaptid's nan_policy="skip"); finite data with a non-finite
     * error means theta diverged (the step is too large). */
@CHECK@
        if (!finite_row(phi, y)) {
            s->n_skipped++;
            return NAN;
        }
        if (!(e - e == 0.0)) {
            s->flags |= FLAG_DIVERGED;
        }
    }
@GAIN@
    for (i = 0; i < $N; i++) {
        real t = FMA(g * phi[i], e, s->theta[i]);
        s->theta[i] = t;
        finite &= t - t == 0.0;
    }
    if (!finite) {
        s->flags |= FLAG_DIVERGED;
    }
    s->n_updates++;
    return e;
}
"""

_GAIN_LMS = r"""    /* MATLAB recursiveLS "Gradient" (Widrow & Stearns 1985, eq. 6.3), weight 1:
     *   theta_k = theta_{k-1} + mu phi_k eps_k                                  */
    g = STEP;
"""

_GAIN_NLMS = r"""    /* MATLAB recursiveLS "NormalizedGradient" (Haykin 2002, eq. 6.44), weight 1:
     *   theta_k = theta_{k-1} + mu / (eps0 + phi_k^T phi_k) phi_k eps_k
     * (phi = 0 with eps0 = 0: no step) */
    g = q > 0.0 ? STEP / q : 0.0;
"""


def lms_update(kind: str, n: int, unrolled: bool = True):
    """``kind``: "LMS" or "NLMS"; returns (helpers, source) as :mod:`._rls` does.

    ``unrolled``: the Python estimator runs the kernel specialised for its n
    (n <= MAX_SPECIALISED_N), which fuses φᵀφ's first products differently.
    """
    norm = kind == "NLMS"
    special = n >= 8 and unrolled and norm
    if norm:  # q = eps0 + phi^T phi, the gain's denominator, checked too
        check = ("    q = " + ("sumsq(EPS0, phi)" if special else "dot(EPS0, 1.0, phi, phi)")
                 + ";\n    if (!(q - q == 0.0 && e - e == 0.0)) {")
    else:  # LMS forms no phi^T phi
        check = "    if (!(e - e == 0.0)) {"
    body = (_UPDATE.replace("@Q@", ", q = eps0 + phi^T phi only if phi is" if norm else "")
            .replace("@CHECK@", check)
            .replace("@GAIN@\n", _GAIN_NLMS if norm else _GAIN_LMS))
    if not norm:
        body = body.replace("real q, e, g;", "real e, g;")
    helpers = ["FINITE", _DOT_PARTIAL if n >= 8 else _DOT_SEQ]
    return helpers + ([_SUMSQ_UNROLLED] if special else []), body


def header_struct(U: str, name: str) -> str:
    """The state struct of NAME.h: θ, counters, flags (no covariance)."""
    return f"""typedef struct {{
    real theta[{U}_N];           /* the estimate */
    uint32_t n_updates;          /* samples used */
    uint32_t n_skipped;          /* samples skipped (NaN or inf) */
    uint32_t flags;
}} {name}_t;
"""
