"""C update functions of RLS (exponential forgetting, P_max, Directional,
ConstantTrace, Variable), SlidingWindowRLS and KalmanRLS.

Each mirrors, operation for operation, the compiled stream of
:mod:`adaptid._kernels` (``_bierman``, ``_rls``, ``_strategy``, ``_window``, ``_kalman``) that the Python estimator's ``run`` uses
(``_rls_body``, ``_strategy_step``, ``_window_core``,
``_kalman_core``), so that the C code continues the Python estimator's
state with the same rounding (see docs/embedded.md on FMA contraction).
Every function returns ``(blocks, update_source)``: the names of the shared
blocks of :mod:`._emit` it needs and the text of ``NAME_update``.
"""

from __future__ import annotations

import re

_HEAD = r"""
$R $P_update($T *s, const $R phi[$N], $R y)
{
    real f[$N], v[$N], b[$N];
    real e, a;
    int i;

    /* A sample with NaN or inf is skipped: theta and P unchanged, no
     * forgetting, counted in n_skipped (adaptid's nan_policy="skip"). */
    if (!finite_row(phi, y)) {
        s->n_skipped++;
        return NAN;
    }
    /* a-priori error  eps_k = y_k - phi_k^T theta_{k-1} */
    e = prior_error(s->theta, phi, y);
"""

_MEASUREMENT = r"""
    /* Measurement update (Ljung & Soderstrom 1983, eqs. 2.19-2.20; Bierman 1977, ch. V):
     *   K_k = P phi_k / (1 + phi_k^T P phi_k),  theta_k = theta_{k-1} + K_k eps_k,
     *   P_k = P - K_k phi_k^T P                 (on the U-D factors of P)       */
    bierman_prep(s, phi, f, v);
    a = bierman_apply(s, 1.0, f, v, b);
    gain_step(s, b, a, e);
"""

_TAIL = r"""
    s->n_updates++;
    check_pivots(s);
    return e;
}
"""

_FORGET_CONST = r"""
    /* Exponential forgetting before the measurement update: P <- P / lambda,
     * i.e. D <- D (1/lambda) (U unchanged). */
    for (i = 0; i < $N; i++) {
        s->D[i] *= 1.0 / LAMBDA;
    }
"""

_FORGET_PMAX = r"""
    /* Forgetting bounded by P_max, pivot by pivot: D_i <- D_i / lambda_i with
     * lambda_i = min(1, max(lambda, D_i / P_max)) when D_i > lambda P_max, so an
     * unexcited pivot stops growing while the others keep forgetting. */
    for (i = 0; i < $N; i++) {
        real li = lk;
        if (s->D[i] > li * P_MAX) {
            li = s->D[i] / P_MAX;
            if (!(li > lk)) {
                li = lk;
            }
            if (li > 1.0) {
                li = 1.0;
            }
        }
        s->D[i] /= li;
    }
"""

_FORGET_LK = r"""
    /* Forgetting before the measurement update: D <- D (1/lambda_k). */
    if (lk != 1.0) {
        real il = 1.0 / lk;
        for (i = 0; i < $N; i++) {
            s->D[i] *= il;
        }
    }
"""

_VARIABLE = r"""
    /* Variable forgetting (Fortescue, Kershenbaum & Ydstie 1981): keep the
     * a-posteriori error sum at Sigma0 = sigma0^2 N0,
     *   lambda_k = max(lambda_min, 1 - eps^2 / ((1 + phi^T P phi) Sigma0)). */
    r = bierman_prep(s, phi, f, v);
    lk = 1.0 - (e * e) / ((1.0 + r) * SIGMA0);
    if (!(lk >= LAMBDA)) {
        lk = LAMBDA;
    }
"""

_DIRECTIONAL = r"""
    /* Directional forgetting (Kulhavy 1987): the information R = P^-1 loses
     * (1 - lambda) phi phi^T / (phi^T P phi), i.e. a Bierman step of weight
     * -r / (1 - lambda) with r = phi^T P phi (definite: 1 - c r = lambda > 0). */
    r = bierman_prep(s, phi, f, v);
    lk = LAMBDA;
"""

_DIRECTIONAL_PMAX = r"""    /* with P_max: no forgetting in a step where max_i P_ii > lambda P_max */
    if (max_diag_P(s) > LAMBDA * P_MAX) {
        lk = 1.0;
    }
"""

_DIRECTIONAL_APPLY = r"""    if (lk < 1.0 && r > 0.0) {
        bierman_apply(s, -r / (1.0 - lk), f, v, b);
    }
"""

_MAX_DIAG = r"""
/* max_i P_ii,  P_ii = D_i + sum_{j > i} U_ij^2 D_j */
static real max_diag_P(const $T *s)
{
    real m = 0.0;
    int i, j;
    for (i = 0; i < $N; i++) {
        real d = s->D[i];
        for (j = i + 1; j < $N; j++) {
            d = FMA(s->U[i][j] * s->U[i][j], s->D[j], d);
        }
        if (d > m) {
            m = d;
        }
    }
    return m;
}
"""

_TRACE = r"""
/* trace P = sum_j D_j (1 + sum_{i < j} U_ij^2) */
static real trace_P(const $T *s)
{
    real t = 0.0;
    int i, j;
    for (j = 0; j < $N; j++) {
        real c = 1.0;
        for (i = 0; i < j; i++) {
            c = FMA(s->U[i][j], s->U[i][j], c);
        }
        t = FMA(s->D[j], c, t);
    }
    return t;
}
"""

_CONSTANT_TRACE = r"""
    /* Regularised constant trace (Goodwin & Sin 1984, sec. 3.7):
     *   P_k = g Pbar_k + c2 I,  g = min(c1 / tr Pbar_k, 1 / lambda_min),
     * formed and re-factorised as U D U^T. */
    {
        real W[$N][$N];
        int j, q;
        real g = TRACE_C1 / trace_P(s);
        if (!(g <= 1.0 / LAMBDA)) {
            g = 1.0 / LAMBDA;
        }
        for (i = 0; i < $N; i++) {
            for (j = i; j < $N; j++) {
@SIJ@
                for (; q < $N; q++) {
                    sij = FMA(s->U[i][q] * s->D[q], s->U[j][q], sij);
                }
@WIJ@
            }
        }
        if (!udu_factor(s, W)) {
            for (i = 0; i < $N; i++) {
                s->D[i] = NAN;
            }
        }
    }
"""


# P_ij = D_j U_ij + sum_{q > j} U_iq D_q U_jq. The kernel specialised for n
# (loops unrolled, n <= MAX_SPECIALISED_N) has LLVM fuse the first product
# into the first addition, D_j U_ij + (U_iq D_q U_jq) -> fma; the generic one
# (a loop) fuses the second, as everywhere else, and does not fuse
# g P_ij + c2 (unrolled, it does).
_SIJ_UNROLLED = r"""                /* Pbar_ij = D_j U_ij + sum_{q > j} U_iq D_q U_jq; the first two
                 * terms are fused as adaptid's compiled kernel fuses them */
                real sij;
                q = j + 1;
                if (i < j && q < $N) {
                    sij = FMA(s->D[j], s->U[i][j], s->U[i][q] * s->D[q] * s->U[j][q]);
                    q++;
                } else {
                    sij = i < j ? s->D[j] * s->U[i][j] : s->D[j];
                }"""
_SIJ_LOOP = r"""                /* Pbar_ij = D_j U_ij + sum_{q > j} U_iq D_q U_jq */
                real sij = i < j ? s->D[j] * s->U[i][j] : s->D[j];
                q = j + 1;"""


def rls_update(kind: str, lam: float, pmax: float | None, unrolled: bool = True):
    """``kind``: "exp", "dir", "ct" or "var"; returns (helpers, source).

    ``unrolled``: the Python estimator runs a kernel specialised for its n
    (see :mod:`adaptid._kernels`), which fuses one product differently.
    """
    helpers = ["FINITE", "PRIOR_ERROR", "BIERMAN", "CHECK_PIVOTS"]
    local = []
    body = _HEAD
    if kind == "exp" and pmax is None:
        if lam != 1.0:
            body += _FORGET_CONST
        body += _MEASUREMENT
    elif kind in ("exp", "var"):
        local.append("    real lk, r;\n" if kind == "var" else "    real lk = LAMBDA;\n")
        if kind == "var":
            body += _VARIABLE
        body += _FORGET_PMAX if pmax is not None else _FORGET_LK
        body += _MEASUREMENT
    elif kind == "dir":
        local.append("    real lk, r;\n")
        body += _DIRECTIONAL
        if pmax is not None:
            body += _DIRECTIONAL_PMAX
            helpers.append(_MAX_DIAG)
        body += _DIRECTIONAL_APPLY + _MEASUREMENT
    elif kind == "ct":
        body += _MEASUREMENT + _CONSTANT_TRACE.replace(
            "@SIJ@", _SIJ_UNROLLED if unrolled else _SIJ_LOOP).replace(
            "@WIJ@", "                W[i][j] = " + (
                "FMA(g, sij, i == j ? TRACE_C2 : 0.0);" if unrolled
                else "g * sij + (i == j ? TRACE_C2 : 0.0);"))
        helpers += [_TRACE, "UDU_FACTOR"]
    else:  # pragma: no cover - guarded by the caller
        raise ValueError(kind)
    body = body.replace("    int i;\n", "    int i;\n" + "".join(local), 1)
    code = re.sub(r"/\*.*?\*/", "", body, flags=re.DOTALL)
    if len(re.findall(r"\bi\b", code)) == 1:  # no loop over i: an unused variable is an error
        body = body.replace("    int i;\n", "", 1)
    return helpers, body + _TAIL


# ---------------------------------------------------------------------------
# Kalman filter for a random-walk parameter
# ---------------------------------------------------------------------------
_TIME_UPDATE = r"""
/* Time update of the random walk: U D U^T <- U D U^T + R1, formed and
 * re-factorised (Ljung & Soderstrom 1983, eq. 2.114: P_k = ... + R1). */
static void time_update($T *s)
{
    real W[$N][$N];
    int i, j, k;
    for (i = 0; i < $N; i++) {
        for (j = i; j < $N; j++) {
            real sij = i < j ? FMA(s->D[j], s->U[i][j], R1[i][j]) : R1[i][j] + s->D[j];
            for (k = j + 1; k < $N; k++) {
                sij = FMA(s->U[i][k] * s->D[k], s->U[j][k], sij);
            }
            W[i][j] = sij;
        }
    }
    if (!udu_factor(s, W)) {
        s->flags |= FLAG_WINDUP;
    }
}
"""

_KALMAN = r"""
$R $P_update($T *s, const $R phi[$N], $R y)
{
    real f[$N], v[$N], b[$N];
    real e, a;

    /* A sample with NaN or inf gets the time update only (P grows by R1,
     * theta unchanged), as with nan_policy="skip"; counted in n_skipped. */
    if (!finite_row(phi, y)) {
        s->n_skipped++;
        time_update(s);
        check_pivots(s);
        return NAN;
    }
    /* a-priori error  eps_k = y_k - phi_k^T theta_{k-1} */
    e = prior_error(s->theta, phi, y);
    /* Measurement update (Ljung & Soderstrom 1983, eq. 2.114; Bierman 1977, ch. V):
     *   K_k = P phi_k / (R2 + phi_k^T P phi_k),  theta_k = theta_{k-1} + K_k eps_k,
     *   P <- P - K_k phi_k^T P                                                  */
    bierman_prep(s, phi, f, v);
    a = bierman_apply(s, R2, f, v, b);
    gain_step(s, b, a, e);
    /* then the time update  P_k = P + R1 */
    time_update(s);
    s->n_updates++;
    check_pivots(s);
    return e;
}
"""


def kalman_update():
    return ["FINITE", "PRIOR_ERROR", "BIERMAN", "UDU_FACTOR", _TIME_UPDATE, "CHECK_PIVOTS"], _KALMAN


# ---------------------------------------------------------------------------
# Sliding window (TLSM)
# ---------------------------------------------------------------------------
_REBUILD = r"""
/* Re-solve the window exactly from its buffer and the decayed prior
 * (theta0, P0 / prod lambda): used when a removal would lose definiteness. */
static void window_rebuild($T *s)
{
    real f[$N], v[$N], b[$N];
    real L = s->L;
    real scale = exp(-L < 600.0 ? -L : 600.0);
    int i, t;
    int start = s->pos - s->count + $M;
    memcpy(s->U, s->U0, sizeof s->U);
    memcpy(s->theta, s->theta0, sizeof s->theta);
    for (i = 0; i < $N; i++) {
        s->D[i] = s->D0[i] * scale;
    }
    for (t = 0; t < s->count; t++) {
        int k = (start + t) % $M;
        real c = s->Bw[k] * exp(L - s->BL[k]);
        if (c > 0.0) {
            real e = prior_error(s->theta, s->Bphi[k], s->By[k]);
            real a;
            bierman_prep(s, s->Bphi[k], f, v);
            a = bierman_apply(s, 1.0 / c, f, v, b);
            gain_step(s, b, a, e);
        }
    }
}
"""

_WINDOW = r"""
$R $P_update($T *s, const $R phi[$N], $R y)
{
    real f[$N], v[$N], b[$N];
    real e, a, L;
    int i, pos, count;
    int rebuild = 0;

    /* A sample with NaN or inf is skipped: the state is unchanged (adaptid's
     * nan_policy="skip"); counted in n_skipped. */
    if (!finite_row(phi, y)) {
        s->n_skipped++;
        return NAN;
    }
    /* a-priori error  eps_k = y_k - phi_k^T theta_{k-1} */
    e = prior_error(s->theta, phi, y);
@FORGET@
    /* Yamamoto (1991), eqs. 62-65:
     *   R_k = lambda R_{k-1} + phi_k phi_k^T - c_k phi_{k-M} phi_{k-M}^T,
     *   c_k = w_{k-M} prod_{i=k-M+1..k} lambda_i,
     * on the U-D factors of P = R^-1: first add the new sample (Bierman,
     * weight 1) ... */
    bierman_prep(s, phi, f, v);
    a = bierman_apply(s, 1.0, f, v, b);
    gain_step(s, b, a, e);
    /* ... then remove the one leaving the window (Bierman, weight -1/c). A
     * removal with 1 - c phi^T P phi < DOWNDATE_RTOL would lose definiteness:
     * the window is re-solved from its buffer instead. */
    pos = s->pos;
    count = s->count;
    if (count == $M) {
        real c = @C@;
        if (c > 0.0) {
            real q = bierman_prep(s, s->Bphi[pos], f, v);
            if (FMA(-c, q, 1.0) < DOWNDATE_RTOL) {
                rebuild = 1;
            } else {
                real e2 = prior_error(s->theta, s->Bphi[pos], s->By[pos]);
                a = bierman_apply(s, -1.0 / c, f, v, b);
                gain_step(s, b, a, e2);
            }
        }
    }
    /* the new sample enters the circular buffer */
    for (i = 0; i < $N; i++) {
        s->Bphi[pos][i] = phi[i];
    }
    s->By[pos] = y;
    s->Bw[pos] = 1.0;
    s->BL[pos] = L;
    pos++;
    if (pos == $M) {
        pos = 0;
    }
    s->pos = pos;
    if (count < $M) {
        s->count = count + 1;
    }
    if (rebuild) {
        s->n_rebuilds++;
        s->flags |= FLAG_REBUILT;
        window_rebuild(s);
    }
    s->n_updates++;
    check_pivots(s);
    return e;
}
"""


def window_update(lam: float, uniform: bool):
    """``uniform``: λ = 1 and every buffered log-λ sum equals L, so c = w (exp(0) = 1)."""
    if lam != 1.0:
        forget = ("    /* Forgetting: P <- P / lambda (D <- D (1/lambda)); L = sum log lambda. */\n"
                  "    for (i = 0; i < $N; i++) {\n        s->D[i] *= 1.0 / LAMBDA;\n    }\n"
                  "    L = s->L + LOG_LAMBDA;\n    s->L = L;\n")
    else:
        forget = "    L = s->L;  /* sum of log lambda: lambda = 1, unchanged */\n"
    c = "s->Bw[pos]" if uniform else "s->Bw[pos] * exp(L - s->BL[pos])"
    body = _WINDOW.replace("@FORGET@\n", forget).replace("@C@", c)
    return ["FINITE", "PRIOR_ERROR", "BIERMAN", _REBUILD, "CHECK_PIVOTS"], body
