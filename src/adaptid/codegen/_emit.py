"""Text helpers of the C generator: literals, the float32 rewrite, the shared U-D blocks.

The C templates are written once, in double precision, with the scalar type
spelled ``real``. :func:`finish` turns them into the requested precision:
``real`` → ``double``/``float``, and for float32 every floating literal gets
an ``f`` suffix and ``exp``/``log`` become ``expf``/``logf`` (so no
expression is promoted to double, which a Cortex-M4F would emulate in
software). Comments are left untouched.
"""

from __future__ import annotations

import re

import numpy as np

_COMMENT = re.compile(r"/\*.*?\*/", re.DOTALL)
_FLOAT_LIT = re.compile(r"(?<![\w.])(\d+\.\d*(?:[eE][+-]?\d+)?|\d+[eE][+-]?\d+)(?![\w.])")
_REAL = re.compile(r"\breal\b")
_MATHF = re.compile(r"\b(exp|log|fma)\(")


def literal(x, dtype: str) -> str:
    """A C literal that reads back as ``x`` rounded to ``dtype`` (shortest round-trip form)."""
    x = float(x)
    if np.isnan(x):
        return "NAN"
    if np.isinf(x):
        return "INFINITY" if x > 0 else "(-INFINITY)"
    text = repr(x) if dtype == "float64" else str(np.float32(x))
    if "." not in text and "e" not in text and "inf" not in text:
        text += ".0"
    return text


def array(values, dtype: str, per_line: int = 4, indent: str = "    ") -> str:
    """The body of a C initializer list ``{ ... }`` for a flat sequence."""
    items = [literal(v, dtype) for v in np.asarray(values, dtype=float).ravel()]
    lines = []
    for k in range(0, len(items), per_line):
        lines.append(indent + ", ".join(items[k:k + per_line]))
    return "{\n" + ",\n".join(lines) + "\n}"


def matrix(M, dtype: str, indent: str = "    ") -> str:
    """A 2-D C initializer ``{ {..}, {..} }``, one row per line."""
    M = np.asarray(M, dtype=float)
    rows = [indent + "{" + ", ".join(literal(v, dtype) for v in row) + "}" for row in M]
    return "{\n" + ",\n".join(rows) + "\n}"


def finish(text: str, dtype: str) -> str:
    """Spell ``real`` as the C type and, for float32, suffix the literals (code only)."""
    ctype = "double" if dtype == "float64" else "float"
    out = []
    pos = 0
    for m in _COMMENT.finditer(text):
        out.append(_code(text[pos:m.start()], ctype))
        out.append(m.group(0))
        pos = m.end()
    out.append(_code(text[pos:], ctype))
    return "".join(out)


def _code(part: str, ctype: str) -> str:
    part = _REAL.sub(ctype, part)
    if ctype == "float":
        part = _FLOAT_LIT.sub(lambda m: m.group(1) + "f", part)
        part = _MATHF.sub(lambda m: m.group(1) + "f(", part)
    return part


# ---------------------------------------------------------------------------
# C blocks shared by the estimators. `P` is the name prefix, `T` the struct
# type; every block is a static function of NAME.c, emitted only when used
# (an unused static function is a warning, and the build uses -Werror).
# ---------------------------------------------------------------------------
FINITE = r"""
/* 1 when every entry of the sample is finite (a NaN or inf sample is skipped,
 * as with nan_policy="skip" in adaptid). */
static int finite_row(const real phi[$N], real y)
{
    int i;
    for (i = 0; i < $N; i++) {
        if (!isfinite(phi[i])) {
            return 0;
        }
    }
    return isfinite(y) ? 1 : 0;
}
"""

PRIOR_ERROR = r"""
/* A-priori error  eps = y - phi^T theta  (summed in index order). */
static real prior_error(const real theta[$N], const real phi[$N], real y)
{
    real s = y;
    int i;
    for (i = 0; i < $N; i++) {
        s = FMA(-phi[i], theta[i], s);
    }
    return s;
}
"""

BIERMAN = r"""
/* Bierman's U-D measurement update (Bierman 1977, ch. V), part 1:
 *   f = U^T phi,  v = D f;  returns  phi^T P phi = sum_j f_j v_j.          */
static real bierman_prep(const $T *s, const real phi[$N], real f[$N], real v[$N])
{
    real q = 0.0;
    int i, j;
    for (j = 0; j < $N; j++) {
        real sj = phi[j];
        for (i = 0; i < j; i++) {
            sj = FMA(s->U[i][j], phi[i], sj);
        }
        f[j] = sj;
        v[j] = s->D[j] * sj;
        q = FMA(sj, v[j], q);
    }
    return q;
}

/* Bierman's U-D measurement update (Bierman 1977, ch. V), part 2, for
 *   P <- P - P phi phi^T P / (r + phi^T P phi)
 * with weight r (r < 0 removes an observation). Stage j:
 *   alpha_j = alpha_{j-1} + f_j v_j            (alpha_{-1} = r)
 *   D_j    <- D_j alpha_{j-1} / alpha_j
 *   U_ij   <- U_ij - (f_j / alpha_{j-1}) b_i,   b_i <- b_i + U_ij(old) v_j   (i < j)
 *   b_j     = v_j
 * one division per stage. On return b = P(old) phi and the result is
 * alpha = r + phi^T P phi, so the gain is K = b / alpha.                 */
static real bierman_apply($T *s, real r, const real f[$N], const real v[$N], real b[$N])
{
    real a = FMA(f[0], v[0], r);
    real ia = 1.0 / a;
    int i, j;
    s->D[0] = s->D[0] * (r * ia);
    b[0] = v[0];
    for (j = 1; j < $N; j++) {
        real an = FMA(f[j], v[j], a);
        real ian = 1.0 / an;
        real pj = -f[j] * ia;
        real vj = v[j];
        s->D[j] = s->D[j] * (a * ian);
        for (i = 0; i < j; i++) {
            real u = s->U[i][j];
            s->U[i][j] = FMA(b[i], pj, u);
            b[i] = FMA(u, vj, b[i]);
        }
        b[j] = vj;
        a = an;
        ia = ian;
    }
    return a;
}

/* theta <- theta + K eps,  K = b / alpha. */
static void gain_step($T *s, const real b[$N], real a, real e)
{
    real ia = 1.0 / a;
    int i;
    for (i = 0; i < $N; i++) {
        real g = b[i] * ia;
        s->theta[i] = FMA(g, e, s->theta[i]);
    }
}
"""

UDU_FACTOR = r"""
/* Upper U-D factorisation W = U diag(D) U^T (only W's upper triangle is read;
 * Bierman 1977, ch. III), into s->U, s->D. Returns 0 if W is not positive
 * definite (s->U, s->D are then partly overwritten).                        */
static int udu_factor($T *s, real W[$N][$N])
{
    int i, j, k;
    for (j = $N - 1; j >= 0; j--) {
        real d = W[j][j];
        for (k = j + 1; k < $N; k++) {
            d = FMA(-(s->D[k] * s->U[j][k]), s->U[j][k], d);
        }
        if (!(d > 0.0)) {
            return 0;
        }
        s->D[j] = d;
        for (i = 0; i < j; i++) {
            real sij = W[i][j];
            for (k = j + 1; k < $N; k++) {
                sij = FMA(-(s->D[k] * s->U[i][k]), s->U[j][k], sij);
            }
            s->U[i][j] = sij / d;
        }
    }
    return 1;
}
"""

CHECK_PIVOTS = r"""
/* Flag windup: a pivot D_i of P = U D U^T outside (0, windup_threshold). */
static void check_pivots($T *s)
{
    int i;
    for (i = 0; i < $N; i++) {
        if (!(s->D[i] > 0.0 && s->D[i] < WINDUP_THRESHOLD)) {
            s->flags |= FLAG_WINDUP;
        }
    }
}
"""

PREDICT_THETA = r"""
real $P_predict(const $T *s, const real phi[$N])
{
    real yhat = 0.0;
    int i;
    for (i = 0; i < $N; i++) {
        yhat += phi[i] * s->theta[i];
    }
    return yhat;
}

void $P_theta(const $T *s, real theta[$N])
{
    memcpy(theta, s->theta, sizeof s->theta);
}
"""



def subst(text: str, name: str) -> str:
    """Fill the placeholders of a block: $N, $M (sizes), $T (struct type), $P (prefix)."""
    return (text.replace("$N", f"{name.upper()}_N").replace("$M", f"{name.upper()}_M")
            .replace("$T", f"{name}_t").replace("$P", name).replace("$R", "real"))
