r"""C for a model: the lag buffers, the detrend offsets and ``NAME_step`` (issue 33, point 8).

:func:`adaptid.codegen.to_c` of a fitted :class:`~adaptid.models.ARX` /
:class:`~adaptid.models.AR` (θ fixed) or of a streaming
:class:`~adaptid.models.RecursiveARX` / :class:`~adaptid.models.RecursiveAR`
(θ and its estimator's state) comes here. The generated ``NAME_step(m, y,
u)`` takes raw measurements, removes the offsets, forms the regressor

.. math::

    \varphi_k = [-y_{k-1}, \dots, -y_{k-n_a},\;
                 u^{(i)}_{k-n_k^{(i)}}, \dots, u^{(i)}_{k-n_k^{(i)}-n_b^{(i)}+1}, \dots]^T

from its lag buffers (zeros before the first sample, as MATLAB's and the
Python objects' are), predicts :math:`\hat y_k = \varphi_k^T\hat\theta_{k-1}`
in the order NumPy's pairwise sum adds :math:`\varphi_k\circ\hat\theta_{k-1}`
(the formula of ``RecursiveARX.step``), updates θ with the estimator's own
generated ``NAME_update`` (streaming objects), shifts the buffers and returns
:math:`\hat y_k` plus the output offset.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validation import check_choice, param_error
from . import _emit
from ._generate import DTYPES, check_name, generate

__all__ = ["is_model", "generate_model", "model_offsets", "fit_offsets", "stream_of_fit"]

_F32_MAX = float(np.finfo(np.float32).max)
_BLOCK = 128   # numpy's PW_BLOCKSIZE: pairwise_sum splits longer sums in two


def is_model(obj) -> bool:
    """True for the objects this module exports (ARX, AR, RecursiveARX, RecursiveAR)."""
    from ..models import ARX, RecursiveARX
    return isinstance(obj, (ARX, RecursiveARX))


@dataclass
class _Spec:
    kind: str            # "ARX" or "AR" (the structure)
    source: str          # what it came from, for the header
    na: int
    nb: tuple            # per input (empty for AR)
    nk: tuple
    names: tuple
    y0: float
    u0: tuple            # per input
    ybuf: np.ndarray     # (na,) y(k-1) … y(k-na), offsets removed
    ubuf: np.ndarray     # (m, Lu) u(k-1) … u(k-Lu) per input
    count: int
    start: int           # samples without update ("filled"); 0 for start="zero" / fixed
    single: bool
    theta: np.ndarray | None = None    # fixed model
    inner: dict | None = None          # streaming: the estimator's get_state()

    @property
    def m(self):
        return len(self.nb)

    @property
    def n(self):
        return len(self.names)

    @property
    def Lu(self):
        return int(self.ubuf.shape[1]) if self.ubuf.ndim == 2 else 0


# ---------------------------------------------------------------------- offsets
def model_offsets(data, n_inputs):
    """``(y0, u0)`` of a record whose removed trends are constant (``detrend("constant")``).

    ``data`` is an :class:`~adaptid.models.IDData` (its ``y_trend``, ``u_trend``)
    or None (no offsets). A trend that varies over the record (``"linear"``)
    cannot be applied to samples after it: a ValueError naming ``offsets``.
    """
    if data is None or not hasattr(data, "y_trend"):
        return 0.0, (0.0,) * n_inputs
    ty = np.asarray(data.y_trend, dtype=float).reshape(len(data), -1)
    tu = np.asarray(data.u_trend, dtype=float).reshape(len(data), -1)[:, :n_inputs]
    for label, tr in (("the output", ty), ("the inputs", tu)):
        if tr.size and not np.all(tr == tr[:1]):
            raise param_error("offsets", "given (y0, u0) for a model fitted on data with a "
                              "non-constant trend (detrend('linear') removes a line the "
                              "firmware cannot continue)", f"<a varying trend of {label}>")
    y0 = float(ty[0, 0]) if ty.size else 0.0
    u0 = tuple(float(v) for v in tu[0]) if tu.size else (0.0,) * n_inputs
    return y0, u0 + (0.0,) * (n_inputs - len(u0))


def fit_offsets(data, n_inputs):
    """:func:`model_offsets` as ``to_c``'s ``offsets``: y0 alone without inputs."""
    y0, u0 = model_offsets(data, n_inputs)
    return y0 if n_inputs == 0 else (y0, u0)


def _check_offsets(offsets, m):
    """``offsets``: y0, or (y0, u0) with u0 a number (one input) or one per input."""
    want = ("a number y0 or a pair (y0, u0), u0 a number or one per input"
            if m else "a number y0 (the model has no input)")
    if isinstance(offsets, (tuple, list)) and len(offsets) == 2 and m:
        y0, u0 = offsets
    elif not isinstance(offsets, (tuple, list)) and np.ndim(offsets) == 0:
        y0, u0 = offsets, 0.0
    else:
        raise param_error("offsets", want, offsets)
    try:
        y0 = float(y0)
        u0 = np.broadcast_to(np.asarray(u0, dtype=float).reshape(-1), (m,))
    except (TypeError, ValueError):
        raise param_error("offsets", want + f" ({m} input(s))", offsets) from None
    if not (np.isfinite(y0) and np.all(np.isfinite(u0))):
        raise param_error("offsets", "finite numbers", offsets)
    return y0, tuple(float(v) for v in u0)


# ---------------------------------------------------------------------- spec
def _spec(obj, offsets) -> _Spec:
    from ..models import AR, ARX, RecursiveAR, RecursiveARX
    from ..models.mimo import MIMOARX

    if isinstance(obj, MIMOARX):
        raise param_error("model", "a single-output ARX (the C export of a MIMO ARX is not "
                          "available)", "<a MIMOARX>")
    if isinstance(obj, RecursiveARX):
        st = obj.get_state()
        o = st["options"]
        ar = isinstance(obj, RecursiveAR)
        nb, nk = (() if ar else tuple(o["nb"])), (() if ar else tuple(o["nk"]))
        est = obj.estimator
        inner = est.get_state()
        if getattr(est, "form", "ud") != "ud":  # the C code runs the U-D form
            inner = type(est).from_state(inner, form="ud").get_state()
        y0, u0 = (0.0, (0.0,) * len(nb)) if offsets is None else _check_offsets(offsets, len(nb))
        s = max([o["na"]] + [k + b - 1 for k, b in zip(nk, nb) if b])
        return _Spec("AR" if ar else "ARX", type(obj).__name__, o["na"], nb, nk, obj.names,
                     y0, u0, np.asarray(st["ybuf"], dtype=float).reshape(-1),
                     np.asarray(st["ubuf"], dtype=float).reshape(len(nb), -1) if nb
                     else np.zeros((0, 0)), int(o.get("since", o["count"])),  # buffers' age
                     s if o["start"] == "filled" else 0, bool(o["single"]), inner=inner)
    if not isinstance(obj, ARX):
        raise param_error("model", "an ARX or AR model or a RecursiveARX / RecursiveAR",
                          obj, exc=TypeError)
    obj._check_fitted()
    ar = isinstance(obj, AR)
    nb, nk = (() if ar else tuple(obj._nb)), (() if ar else tuple(obj._nk))
    if offsets is None:
        y0, u0 = model_offsets(getattr(obj, "_fit_data", None), len(nb))
    else:
        y0, u0 = _check_offsets(offsets, len(nb))
    Lu = max([k + b - 1 for k, b in zip(nk, nb) if b] or [0])
    return _Spec("AR" if ar else "ARX", type(obj).__name__, obj.na, nb, nk, tuple(obj.names),
                 y0, u0, np.zeros(obj.na), np.zeros((len(nb), Lu)), 0, 0,
                 bool(getattr(obj, "_single", True)),
                 theta=np.asarray(obj.theta, dtype=float).reshape(-1))


def _check_values(spec, dtype):
    values = {"theta": spec.theta if spec.theta is not None else np.zeros(0),
              "the offsets": np.array([spec.y0, *spec.u0]),
              "the lag buffers": np.concatenate([spec.ybuf, spec.ubuf.ravel()])}
    for label, v in values.items():
        if not np.all(np.isfinite(v)):
            raise param_error("model", f"finite {label} (the C code would start from NaN or "
                              "inf)", f"<{label} with NaN or inf>")
        if dtype == "float32" and v.size and float(np.max(np.abs(v))) > _F32_MAX:
            raise param_error("model", f"{label} within float32's range for dtype='float32'",
                              f"<{label} with |x| = {float(np.max(np.abs(v))):.4g}>")


# ---------------------------------------------------------------------- regressor
def _entries(spec):
    """One (index, name, C expression, description) per regressor entry."""
    rows = []
    for j in range(1, spec.na + 1):
        rows.append((len(rows), spec.names[len(rows)], f"-m->ybuf[{j - 1}]",
                     f"-(y(k-{j}) - $U_Y0)"))
    for i, (b, k0) in enumerate(zip(spec.nb, spec.nk)):
        for j in range(b):
            lag = k0 + j
            expr = f"ud{i}" if lag == 0 else f"m->ubuf[{i}][{lag - 1}]"
            lab = "u" if spec.single else f"u{i}"
            rows.append((len(rows), spec.names[len(rows)], expr,
                         f"+({lab}(k{'' if lag == 0 else f'-{lag}'}) - $U_U0_{i})"))
    return rows


def _pairwise_expr(n, off=0):
    """The C expression of numpy's pairwise sum of p[off .. off+n-1] (pairwise_sum)."""
    if n <= _BLOCK:
        return f"pairwise_sum(p + {off}, {n})" if off else f"pairwise_sum(p, {n})"
    n2 = n // 2
    n2 -= n2 % 8
    return f"({_pairwise_expr(n2, off)} + {_pairwise_expr(n - n2, off + n2)})"


_PAIRWISE = r"""
/* The sum of a[0 .. n-1], n <= 128, in the order of numpy's pairwise_sum
 * (numpy/_core/src/umath/loops_utils.h): sequential below 8 terms, else eight
 * interleaved partial sums added as ((r0+r1)+(r2+r3))+((r4+r5)+(r6+r7)) and
 * the remainder. Longer sums are split in two by the caller (as numpy does). */
static real pairwise_sum(const real *a, int n)
{
    real res = 0.0;
    int i, j;
    if (n < 8) {
        for (i = 0; i < n; i++) {
            res += a[i];
        }
        return res;
    } else {
        real r[8];
        for (j = 0; j < 8; j++) {
            r[j] = a[j];
        }
        for (i = 8; i < n - n % 8; i += 8) {
            for (j = 0; j < 8; j++) {
                r[j] += a[i + j];
            }
        }
        res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
        for (; i < n; i++) {
            res += a[i];
        }
        return res;
    }
}
"""


# ---------------------------------------------------------------------- header
def _u_param(spec):
    if spec.m == 0:
        return ""
    return ", real u" if spec.single else ", const real u[$U_NU]"


def _doc(spec, streaming, lit):
    what = (f"{spec.kind} model na = {spec.na}" + ("" if spec.kind == "AR" else
            f", nb = {list(spec.nb) if not spec.single else spec.nb[0]}, "
            f"nk = {list(spec.nk) if not spec.single else spec.nk[0]}"))
    art = "an" if spec.source[0] in "AEIOU" else "a"
    lines = [f" * {what} (MATLAB's arx / recursiveARX convention), from {art} {spec.source}:",
             " *   y(k) = phi(k)^T theta + e(k),  theta = ["
             + ", ".join(spec.names) + "]",
             " * with the regressor, in this order (offsets removed, lag buffers zero before",
             " * the first sample):"]
    for idx, name, _, desc in _entries(spec):
        lines.append(f" *   phi[{idx}] = {desc:<26} {name}")
    lines += [" *",
              " * $P_step(m, y" + ("" if spec.m == 0 else ", u") + ") at sample k, with the raw "
              "measurements y(k)" + ("" if spec.m == 0 else " and u(k)") + ":",
              " *   1. removes the offsets $U_Y0" + ("" if spec.m == 0 else " and $U_U0_i") + ";",
              " *   2. forms phi(k) as above from the lag buffers;",
              " *   3. predicts yhat(k) = phi(k)^T theta, theta before y(k) is used (summed",
              " *      in the order of numpy's pairwise sum, as Python's step() does);"]
    if streaming:
        lines += [" *   4. updates theta and P with (phi(k), y(k) - $U_Y0) by $P_update();"]
    else:
        lines += [" *   4. (theta is fixed: the fitted model's);"]
    lines += [" *   5. shifts y(k)" + ("" if spec.m == 0 else " and u(k)") + ", offsets removed, "
              "into the buffers;",
              " * and returns yhat(k) + $U_Y0, the one-step prediction of the raw y(k)."]
    if spec.start:
        lines += [" * start=\"filled\": the first $U_START samples after a reset only fill the "
                  "buffers", " * (NAN returned, no update), as Python's start=\"filled\"."]
    lines += [" * A NaN or inf measurement enters the buffers: the estimator skips every",
              " * sample whose regressor holds it (theta unchanged), yhat is NaN meanwhile."
              ] if streaming else [" * A NaN or inf measurement enters the buffers: yhat is "
                                   "NaN while a regressor holds it."]
    return "\n".join(lines)


def _constants(spec, streaming, lit):
    d = [f"#define $U_NA {spec.na}                /* output lags: phi[j-1] = -(y(k-j) - "
         "$U_Y0), j = 1..NA */"]
    if spec.m:
        d.append(f"#define $U_NU {spec.m}                /* inputs */")
    pos = spec.na
    for i, (b, k0) in enumerate(zip(spec.nb, spec.nk)):
        d += [f"#define $U_NB_{i} {b}              /* input {i}: number of b coefficients */",
              f"#define $U_NK_{i} {k0}              /* input {i}: delay; phi[PHI_U_{i} + j] = "
              f"u_{i}(k - NK_{i} - j) - U0_{i} */",
              f"#define $U_PHI_U_{i} {pos}           /* input {i}: index of its first entry "
              "in phi */"]
        pos += b
    if spec.m and spec.Lu:
        d.append(f"#define $U_LU {spec.Lu}                /* input lags held per input */")
    if spec.start:
        d.append(f"#define $U_START {spec.start}             /* samples before the first update "
                 "(start=\"filled\") */")
    d.append(f"#define $U_Y0 {lit(spec.y0)}        /* output offset (removed mean) */")
    for i, v in enumerate(spec.u0):
        d.append(f"#define $U_U0_{i} {lit(v)}      /* input {i} offset (removed mean) */")
    if not streaming:
        d.insert(0, f"#define $U_N {spec.n}                 /* number of parameters */")
    return "\n".join(d)


def _struct(spec, streaming):
    f = ["typedef struct {"]
    if streaming:
        f.append("    $T est;                 /* the estimator: theta, P ($P_update) */")
    if spec.na:
        f.append("    real ybuf[$U_NA];          /* y(k-1) ... y(k-NA), offset removed */")
    if spec.m and spec.Lu:
        f.append("    real ubuf[$U_NU][$U_LU];   /* per input u(k-1) ... u(k-LU), offset "
                 "removed */")
    f += ["    uint32_t count;              /* samples stepped (saturates at 2^32 - 1) */",
          "} $P_model_t;"]
    return "\n".join(f)


def _declarations(spec):
    return (f"""/* The model's state at export time (estimator, lag buffers, count). */
void $P_model_init($P_model_t *m);
/* One sample of raw measurements: returns the one-step prediction of y (see above). */
real $P_step($P_model_t *m, real y{_u_param(spec)});
/* Copy theta. */
void $P_model_theta(const $P_model_t *m, real theta[$U_N]);
""")


# ---------------------------------------------------------------------- source
def _init_src(spec, dtype):
    arr = lambda a: _emit.array(a, dtype)  # noqa: E731
    lines, body = [], ["    memset(m, 0, sizeof *m);"]
    if spec.inner is not None:
        body.append("    $P_init(&m->est);")
    else:
        lines.append(f"static const real THETA[$U_N] = {arr(spec.theta)};")
    if spec.na:
        lines.append(f"static const real YBUF_INIT[$U_NA] = {arr(spec.ybuf)};")
        body.append("    memcpy(m->ybuf, YBUF_INIT, sizeof m->ybuf);")
    if spec.m and spec.Lu:
        lines.append(f"static const real UBUF_INIT[$U_NU][$U_LU] = "
                     f"{_emit.matrix(spec.ubuf, dtype)};")
        body.append("    memcpy(m->ubuf, UBUF_INIT, sizeof m->ubuf);")
    body.append(f"    m->count = {min(spec.count, 0xFFFFFFFF)}u;")
    return ("\n/* ---- the model (see $P.h): its state at export time ---- */\n"
            + "\n".join(lines) + "\n\nvoid $P_model_init($P_model_t *m)\n{\n"
            + "\n".join(body) + "\n}\n")


def _step_src(spec):
    th = "m->est.theta" if spec.inner is not None else "THETA"
    used = [i for i, b in enumerate(spec.nb) if b]
    head = ["real $P_step($P_model_t *m, real y" + _u_param(spec) + ")", "{",
            "    real phi[$U_N], p[$U_N];", "    real yhat;", "    real yd = y - $U_Y0;"]
    for i in range(spec.m):
        ui = "u" if spec.single else f"u[{i}]"
        head.append(f"    real ud{i} = {ui} - $U_U0_{i};")
    head.append("    int i;")
    body = ["    /* the regressor (see $P.h) */"]
    for idx, name, expr, _ in _entries(spec):
        body.append(f"    phi[{idx}] = {expr};  /* {name} */")
    pred = ["        for (i = 0; i < $U_N; i++) {",
            f"            p[i] = phi[i] * {th}[i];",
            "        }",
            f"        yhat = {_pairwise_expr(spec.n)};"]
    if spec.inner is not None:
        pred.append("        (void)$P_update(&m->est, phi, yd);")
    if spec.start:
        body += ["    if (m->count < $U_START) {  /* start=\"filled\": the buffers fill first */",
                 "        yhat = NAN;", "    } else {"] + pred + ["    }"]
    else:
        body += [line[4:] for line in pred]
    body.append("    /* shift the new samples into the lag buffers */")
    if spec.na > 1:
        body += ["    for (i = $U_NA - 1; i > 0; i--) {", "        m->ybuf[i] = m->ybuf[i - 1];",
                 "    }"]
    if spec.na:
        body.append("    m->ybuf[0] = yd;")
    if spec.m and spec.Lu:
        for i in range(spec.m):
            if spec.Lu > 1:
                body += ["    for (i = $U_LU - 1; i > 0; i--) {",
                         f"        m->ubuf[{i}][i] = m->ubuf[{i}][i - 1];", "    }"]
            body.append(f"    m->ubuf[{i}][0] = ud{i};")
    else:
        body += [f"    (void)ud{i};" for i in range(spec.m) if i not in used]
    body += ["    if (m->count < 0xFFFFFFFFu) {", "        m->count++;", "    }",
             "    return yhat + $U_Y0;", "}"]
    theta = ["", "void $P_model_theta(const $P_model_t *m, real theta[$U_N])", "{",
             (f"    memcpy(theta, m->est.theta, sizeof m->est.theta);" if spec.inner is not None
              else "    (void)m;\n    memcpy(theta, THETA, sizeof THETA);"), "}", ""]
    return _PAIRWISE + "\n" + "\n".join(head + body + theta)


def _fill(text, name):
    return _emit.subst(text.replace("$U_", name.upper() + "_"), name)


def generate_model(obj, *, name="model", dtype="float64", offsets=None):
    """The texts ``(header, source)`` of :func:`adaptid.codegen.to_c` for a model."""
    name = check_name(name)
    dtype = check_choice(dtype, "dtype", DTYPES)
    spec = _spec(obj, offsets)
    _check_values(spec, dtype)
    if spec.n == 0:
        raise param_error("model", "a model with at least one parameter", 0)
    lit = lambda x: _emit.literal(x, dtype)  # noqa: E731
    streaming = spec.inner is not None
    U = name.upper()
    doc = _doc(spec, streaming, lit)
    model_h = ("\n/* ---- the model: $P_step ------------------------------------------------\n"
               + doc + "\n */\n" + _constants(spec, streaming, lit) + "\n\n"
               + _struct(spec, streaming) + "\n\n" + _declarations(spec))
    model_h = _emit.finish(_fill(model_h, name), dtype)
    model_c = _emit.finish(_fill(_init_src(spec, dtype) + _step_src(spec), name), dtype)
    if streaming:
        head, src = generate(spec.inner, name=name, dtype=dtype)
        end = f"#endif /* {U}_H */"
        head = head.replace(f"/* {name}.h: ", f"/* {name}.h: {spec.kind} model ({name}_step) "
                            "over ", 1)
        head = head.replace(end, model_h + "\n" + end)
        return head, src + model_c
    ctype = "double" if dtype == "float64" else "float"
    head = (f"""/* {name}.h: {spec.kind} model ({name}_step), theta fixed, n = {spec.n}, {ctype}.
 *
 * Generated by adaptid {_version()} (adaptid.codegen.to_c) from a fitted {spec.source}.
 * C99, no dynamic memory, no recursion; needs <math.h>, <stdint.h>, <string.h>.
 * Regenerate instead of editing. Build without -ffast-math and with
 * -ffp-contract=off (the default of -std=c99) for Python's results bit for bit.
 */
#ifndef {U}_H
#define {U}_H

#include <stdint.h>
""" + model_h + f"\n#endif /* {U}_H */\n")
    src = (f"/* {name}.c: generated by adaptid {_version()}; see {name}.h. */\n"
           f"#include <math.h>\n#include <string.h>\n\n#include \"{name}.h\"\n" + model_c)
    return head, src


def _version():
    from .. import __version__
    return __version__


# ---------------------------------------------------------------------- the CLI's fit
def stream_of_fit(estimator, *, na, nb=0, nk=1, n_inputs=1):
    """The streaming object of an ARX / AR / FIR fit by a core estimator (``adaptid fit``).

    ``start="filled"`` with empty lag buffers (as the fit's regression, whose
    rows begin where every lag is measured) and ``estimator``'s state (a copy):
    its C code continues the fit's θ and P on new data. ``n_inputs=0`` is AR.
    """
    from ..models import RecursiveAR, RecursiveARX

    if n_inputs == 0:
        obj = RecursiveAR(na, start="filled")
    elif n_inputs == 1:
        obj = RecursiveARX(na, nb, nk, start="filled")
    else:
        obj = RecursiveARX(na, [nb] * n_inputs, [nk] * n_inputs, start="filled")
    state = obj.get_state()
    state["inner"] = estimator.get_state()
    return type(obj).from_state(state)
