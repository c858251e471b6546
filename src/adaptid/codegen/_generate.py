"""Assemble NAME.h and NAME.c from an estimator's ``get_state()``."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from .._validation import check_choice, param_error
from ..forgetting import ConstantTrace, Directional, Variable, resolve
from .. import _config
from .._config import DOWNDATE_RTOL
from . import _emit
from . import _lms
from ._rls import kalman_update, rls_update, window_update

_C_KEYWORDS = frozenset("""auto break case char const continue default do double else enum extern
float for goto if inline int long register restrict return short signed sizeof static struct
switch typedef union unsigned void volatile while _Bool _Complex _Imaginary
_Alignas _Alignof _Atomic _Generic _Noreturn _Static_assert _Thread_local""".split())
#: names that collide with standard typedefs, macros and functions the generated code
#: (or a program including it) uses, or with common embedded typedefs
_C_RESERVED = frozenset("""real main size uint8 uint16 uint32 uint64 int8 int16 int32 int64
int8_t int16_t int32_t int64_t uint8_t uint16_t uint32_t uint64_t size_t ssize_t ptrdiff_t
intptr_t uintptr_t intmax_t uintmax_t wchar_t bool true false NULL errno
fma fmaf exp expf log logf sqrt sqrtf fabs fabsf isnan isinf isfinite memcpy memset
INFINITY NAN FMA""".split())
#: standard headers: NAME.h of that name would shadow <NAME.h> in the folder it is written to
_C_HEADERS = frozenset("""assert complex ctype errno fenv float inttypes iso646 limits locale math
setjmp signal stdalign stdarg stdatomic stdbool stddef stdint stdio stdlib stdnoreturn string
tgmath threads time uchar wchar wctype""".split())
_SUPPORTED = ("RLS", "SlidingWindowRLS", "KalmanRLS", "LMS", "NLMS")
_IDENT = re.compile(r"[A-Za-z_][A-Za-z0-9_]{0,30}\Z")
DTYPES = ("float64", "float32")


def check_name(name) -> str:
    """``name`` if it is a usable C prefix and file name, else a ValueError naming ``name``.

    The whole string must be an identifier of at most 31 characters (no
    trailing newline), not a C11 keyword, not a standard typedef, macro or
    function name the generated code relies on (``real``, ``uint32_t``,
    ``size_t``, ``main``, ``fma``, ...), and not the name of a standard header
    (``math``, ``string``, ``stdint``, ...; compared without case, for
    case-insensitive file systems), whose ``NAME.h`` would shadow it.
    """
    if not isinstance(name, str):
        raise param_error("name", "a C identifier (str)", name, exc=TypeError)
    if not _IDENT.fullmatch(name) or name in _C_KEYWORDS or name.startswith("__"):
        raise param_error("name", "a C identifier of at most 31 characters (letters, digits, "
                          "'_'; not a C keyword)", name)
    if name in _C_RESERVED:
        raise param_error("name", "a C identifier that is not a standard type, macro or "
                          "function name", name)
    if name.lower() in _C_HEADERS:
        raise param_error("name", "a name that is not a standard C header's (NAME.h would "
                          "shadow it)", name)
    return name


_F32_MAX = float(np.finfo(np.float32).max)


def check_values(state, info, dtype) -> None:
    """Refuse a state the C code cannot start from: non-finite θ, U or D (or window
    buffers), and for ``float32`` any finite value beyond float32's range (it
    would be written as ``inf``). The ValueError names the offending array."""
    if info["kind"] in _lms.KINDS:  # θ only, no covariance
        n = int(state["n_params"])
        S = np.asarray(state["state"], dtype=float)
        arrays = {"theta": S[:n * int(state["n_outputs"])]}
    else:
        n, S, theta, U, D = _layout(state)
        arrays = {"theta": theta, "U": U, "D": D}
        if info["kind"] == "SlidingWindowRLS":
            arrays["the window buffer"] = S[n * int(state["n_outputs"]) + n * n + n:]
    for label, values in arrays.items():
        values = np.asarray(values, dtype=float)
        if not np.all(np.isfinite(values)):
            raise param_error("est", f"a state with finite {label} (the C code would start "
                              "from NaN or inf)", f"<{label} with NaN or inf>")
    if dtype != "float32":
        return
    extra = {k: v for k, v in info.items()
             if k in ("threshold", "R1", "R2", "lam", "pmax", "c1", "c2", "sigma0", "step",
                      "eps") and v is not None}
    for label, values in {**arrays, "state": S, **extra}.items():
        values = np.asarray(values, dtype=float)
        finite = values[np.isfinite(values)]
        if finite.size and float(np.max(np.abs(finite))) > _F32_MAX:
            raise param_error("est", f"{label} within float32's range (|x| <= {_F32_MAX:.4g}) "
                              "for dtype='float32'",
                              f"<{label} with |x| = {float(np.max(np.abs(finite))):.4g}>")


def _layout(state):
    n, p = int(state["n_params"]), int(state["n_outputs"])
    S = np.asarray(state["state"], dtype=float)
    theta = S[:n * p]
    U = S[n * p:n * p + n * n].reshape(n, n).T  # stored by columns
    D = S[n * p + n * n:n * p + n * n + n]
    return n, S, theta, U, D


def describe(state) -> dict:
    """Validate the state and return what the generator needs (raises ValueError)."""
    if not isinstance(state, dict) or "estimator" not in state:
        raise param_error("est", "an adaptid RLS, SlidingWindowRLS, KalmanRLS, LMS or NLMS",
                          state, exc=TypeError)
    kind = state["estimator"]
    if kind not in _SUPPORTED:
        raise param_error("est", "an RLS, SlidingWindowRLS, KalmanRLS, LMS or NLMS (the "
                          "estimators with a C export)", f"<a {kind}>")
    if state.get("batch") is not None:
        raise param_error("est", "a single stream (not after run_batched)",
                          f"<{state['batch']} streams>")
    if int(state["n_outputs"]) != 1:
        raise param_error("est", "a single-output estimator (n_outputs=1) for the C export",
                          f"<n_outputs={state['n_outputs']}>")
    opts = state["options"]
    if kind == "RLS" and opts.get("form", "ud") != "ud":  # the C export runs the U-D form
        raise param_error("est", "an RLS in U-D form (est.to_c converts; or "
                          "RLS.from_state(est.get_state(), form='ud'))", f"<form={opts['form']!r}>")
    if kind in _lms.KINDS:
        return {"kind": kind, "step": float(opts["step"]), "eps": float(opts.get("eps", 0.0))}
    info = {"kind": kind, "threshold": float(opts["windup_threshold"])}
    if kind == "KalmanRLS":
        info["R1"] = np.asarray(opts["process_cov"], dtype=float)
        info["R2"] = float(opts["noise_var"])
        return info
    _, lam, strategy = resolve(opts["forgetting"], owner=kind)
    pmax = opts.get("P_max")
    info["pmax"] = None if pmax is None else float(pmax)
    if strategy is None:
        info.update(mode="exp", lam=float(lam))
    elif isinstance(strategy, Directional):
        info.update(mode="dir", lam=float(strategy.lam))
    elif isinstance(strategy, ConstantTrace):
        fp = strategy._params_n(int(state["n_params"]))  # the kernel's parameters, same floats
        info.update(mode="ct", lam=float(fp[0]), c1=float(fp[2]), c2=float(fp[3]))
    elif isinstance(strategy, Variable):
        fp = strategy._params()
        info.update(mode="var", lam=float(fp[0]), sigma0=float(fp[1]))
    else:
        raise param_error("est", "RLS with exponential, Directional, ConstantTrace or Variable "
                          "forgetting for the C export", f"<{type(strategy).__name__} forgetting>")
    if kind == "SlidingWindowRLS":
        info["M"] = int(opts["window"])
    return info


def _header(name, info, n, dtype, state):
    U = name.upper()
    M = info.get("M")
    real = "double" if dtype == "float64" else "float"
    what = {"RLS": "recursive least squares (U-D / Bierman)",
            "SlidingWindowRLS": "sliding-window least squares (TLSM, U-D)",
            "KalmanRLS": "Kalman filter for a random-walk parameter (U-D)",
            "LMS": "least mean squares (stochastic gradient)",
            "NLMS": "normalised least mean squares (stochastic gradient)"}[info["kind"]]
    window = ""
    if M is not None:
        window = f"""    /* the window: the last {U}_M samples, circular buffer */
    real L;                      /* sum of log(lambda) so far */
    int32_t pos;                 /* next slot of the buffer */
    int32_t count;               /* samples in the window (<= {U}_M) */
    real Bphi[{U}_M][{U}_N];     /* regressors in the window */
    real By[{U}_M];              /* outputs in the window */
    real Bw[{U}_M];              /* their weights */
    real BL[{U}_M];              /* L when each entered */
    real theta0[{U}_N];          /* the prior (theta0, P0 = U0 D0 U0^T), for a re-solve */
    real U0[{U}_N][{U}_N];
    real D0[{U}_N];
    uint32_t n_rebuilds;         /* removals replaced by a re-solve from the buffer */
"""
    if info["kind"] in _lms.KINDS:
        flags = f"""/* bits of {name}_t.flags (sticky; clear them yourself) */
/* theta or the a-priori error not finite on finite data: the step is too large
 * (Python's DivergenceWarning) */
#define {U}_FLAG_DIVERGED 4u
"""
        struct = _lms.header_struct(U, name)
    else:
        flags = f"""/* bits of {name}_t.flags (sticky; clear them yourself) */
#define {U}_FLAG_WINDUP 1u       /* a pivot of P = U D U^T left (0, windup_threshold) */
#define {U}_FLAG_REBUILT 2u      /* a window removal was replaced by a re-solve */
"""
        struct = f"""typedef struct {{
    real theta[{U}_N];           /* the estimate */
    real U[{U}_N][{U}_N];        /* P = U diag(D) U^T: U unit upper triangular, U[i][j], i < j */
    real D[{U}_N];
{window}    uint32_t n_updates;          /* samples used */
    uint32_t n_skipped;          /* samples skipped (NaN or inf) */
    uint32_t flags;
}} {name}_t;
"""
    text = f"""/* {name}.h: {what}, n = {n}{f', window M = {M}' if M else ''}, {real}.
 *
 * Generated by adaptid {_version()} (adaptid.codegen.to_c) from the state of a
 * {info['kind']} after {int(state['n_updates'])} samples; {name}_init() restores that state.
 * C99, no dynamic memory, no recursion; needs <math.h>, <stdint.h>, <string.h>.
 * Regenerate instead of editing.
 * Do not build with -ffast-math (or -ffinite-math-only): it lets the compiler
 * assume no NaN or inf, so the test that skips such samples is removed and
 * one NaN sample makes the state NaN for good.
 */
#ifndef {U}_H
#define {U}_H

#include <stdint.h>

#define {U}_N {n}                /* number of parameters */
{f'#define {U}_M {M}                /* window length */' + chr(10) if M else ''}
{flags}
{struct}
/* Set the state to the Python estimator's at export time. */
void {name}_init({name}_t *s);
/* One sample: returns the a-priori error y - phi^T theta (NaN if skipped). */
real {name}_update({name}_t *s, const real phi[{U}_N], real y);
/* The prediction phi^T theta. */
real {name}_predict(const {name}_t *s, const real phi[{U}_N]);
/* Copy the estimate. */
void {name}_theta(const {name}_t *s, real theta[{U}_N]);

#endif /* {U}_H */
"""
    return text


def _version():
    from .. import __version__
    return __version__


def _init(name, info, state, dtype):
    U = name.upper()
    arr = lambda a: _emit.array(a, dtype)  # noqa: E731
    if info["kind"] in _lms.KINDS:  # the state is theta only
        n = int(state["n_params"])
        theta = np.asarray(state["state"], dtype=float)[:n]
        lines = [f"static const real THETA_INIT[{U}_N] = {arr(theta)};"]
        body = ["    memset(s, 0, sizeof *s);",
                "    memcpy(s->theta, THETA_INIT, sizeof s->theta);"]
        return _init_text(name, state, lines, body)
    n, S, theta, Uf, D = _layout(state)
    lines = [f"static const real THETA_INIT[{U}_N] = {arr(theta)};",
             f"static const real U_INIT[{U}_N][{U}_N] = {_emit.matrix(Uf, dtype)};",
             f"static const real D_INIT[{U}_N] = {arr(D)};"]
    body = ["    memset(s, 0, sizeof *s);",
            "    memcpy(s->theta, THETA_INIT, sizeof s->theta);",
            "    memcpy(s->U, U_INIT, sizeof s->U);",
            "    memcpy(s->D, D_INIT, sizeof s->D);"]
    if info["kind"] == "SlidingWindowRLS":
        M = info["M"]
        o = n + n * n + n
        L, pos, count = S[o], int(S[o + 1]), int(S[o + 2])
        o += 3
        Bphi = S[o:o + M * n].reshape(M, n)
        o += M * n
        By = S[o:o + M]
        Bw = S[o + M:o + 2 * M]
        BL = S[o + 2 * M:o + 3 * M]
        o += 3 * M
        th0 = S[o:o + n]
        U0 = S[o + n:o + n + n * n].reshape(n, n).T
        D0 = S[o + n + n * n:o + n + n * n + n]
        lines += [f"static const real BPHI_INIT[{U}_M][{U}_N] = {_emit.matrix(Bphi, dtype)};",
                  f"static const real BY_INIT[{U}_M] = {arr(By)};",
                  f"static const real BW_INIT[{U}_M] = {arr(Bw)};",
                  f"static const real BL_INIT[{U}_M] = {arr(BL)};",
                  f"static const real THETA0[{U}_N] = {arr(th0)};",
                  f"static const real U0_INIT[{U}_N][{U}_N] = {_emit.matrix(U0, dtype)};",
                  f"static const real D0_INIT[{U}_N] = {arr(D0)};"]
        body += [f"    s->L = {_emit.literal(L, dtype)};",
                 f"    s->pos = {pos};",
                 f"    s->count = {count};",
                 "    memcpy(s->Bphi, BPHI_INIT, sizeof s->Bphi);",
                 "    memcpy(s->By, BY_INIT, sizeof s->By);",
                 "    memcpy(s->Bw, BW_INIT, sizeof s->Bw);",
                 "    memcpy(s->BL, BL_INIT, sizeof s->BL);",
                 "    memcpy(s->theta0, THETA0, sizeof s->theta0);",
                 "    memcpy(s->U0, U0_INIT, sizeof s->U0);",
                 "    memcpy(s->D0, D0_INIT, sizeof s->D0);"]
        info["uniform"] = info["lam"] == 1.0 and bool(np.all(BL == L))
    return _init_text(name, state, lines, body)


def _init_text(name, state, lines, body):
    body = body + [f"    s->n_updates = {int(state['n_updates']) & 0xFFFFFFFF}u;",
                   f"    s->n_skipped = {int(state['n_skipped']) & 0xFFFFFFFF}u;"]
    init = ("/* The state of the Python estimator at export time. */\n" + "\n".join(lines)
            + f"\n\nvoid {name}_init({name}_t *s)\n{{\n" + "\n".join(body) + "\n}\n")
    return init


def _defines(info, dtype):
    lit = lambda x: _emit.literal(x, dtype)  # noqa: E731
    if info["kind"] in _lms.KINDS:
        d = ["#define FLAG_DIVERGED 4u", f"#define STEP {lit(info['step'])}  /* mu */"]
        if info["kind"] == "NLMS":
            d.append(f"#define EPS0 {lit(info['eps'])}  /* the normalisation bias */")
        return d
    d = [f"#define WINDUP_THRESHOLD {lit(info['threshold'])}",
         "#define FLAG_WINDUP 1u", "#define FLAG_REBUILT 2u"]
    if info["kind"] == "KalmanRLS":
        d.append(f"#define R2 {lit(info['R2'])}  /* noise variance */")
        return d
    d.append(f"#define LAMBDA {lit(info['lam'])}")
    if info.get("pmax") is not None:
        d.append(f"#define P_MAX {lit(info['pmax'])}")
    if info["mode"] == "ct":
        d += [f"#define TRACE_C1 {lit(info['c1'])}", f"#define TRACE_C2 {lit(info['c2'])}"]
    if info["mode"] == "var":
        d.append(f"#define SIGMA0 {lit(info['sigma0'])}  /* sigma0^2 N0 */")
    if info["kind"] == "SlidingWindowRLS":
        # the Python threshold 1e-8 ~ sqrt(eps64): a removal may cancel at most half
        # the digits; in float32 half the digits is sqrt(eps32) = 3.5e-4
        rtol = DOWNDATE_RTOL if dtype == "float64" else float(np.sqrt(np.finfo(np.float32).eps))
        d.append(f"#define DOWNDATE_RTOL {lit(rtol)}")
        if info["lam"] != 1.0:
            # math.log is the C library's log, the one the compiled kernel calls
            d.append(f"#define LOG_LAMBDA {lit(math.log(info['lam']))}")
    return d


_FMA = r"""/* FMA(a, b, c) = a*b + c. adaptid's compiled kernels fuse each of these into
 * one fused multiply-add (numba's fastmath={"contract"}). Define @U@_USE_FMA
 * (-D@U@_USE_FMA) on a CPU with a hardware FMA (x86-64 with -mfma, ARMv8,
 * a Cortex-M4F for float32) to do the same: the results are then adaptid's
 * bit for bit. Without it the product is rounded first (build with
 * -ffp-contract=off, the default of -std=c99, for results that do not depend
 * on the compiler); the two differ by rounding only. */
#ifdef @U@_USE_FMA
#define FMA(a, b, c) fma((a), (b), (c))
#else
#define FMA(a, b, c) ((a) * (b) + (c))
#endif

"""


def generate(state, name="rls", dtype="float64"):
    """The texts of NAME.h and NAME.c for a ``get_state()`` dict."""
    if isinstance(state.get("options"), dict) and state["options"].get("P0") == "diffuse":
        raise param_error("est", "an estimator with a finite P0 (the generated C has no "
                          "exact diffuse start)", "<P0='diffuse'>")
    name = check_name(name)
    dtype = check_choice(dtype, "dtype", DTYPES)
    info = describe(state)
    check_values(state, info, dtype)
    n = int(state["n_params"])
    init = _init(name, info, state, dtype)  # also sets info["uniform"] for the window
    if info["kind"] == "RLS":
        helpers, update = rls_update(info["mode"], info["lam"], info.get("pmax"),
                                     unrolled=n <= _config.MAX_SPECIALISED_N)
    elif info["kind"] == "KalmanRLS":
        helpers, update = kalman_update()
    elif info["kind"] in _lms.KINDS:
        helpers, update = _lms.lms_update(info["kind"], n,
                                          unrolled=n <= _config.MAX_SPECIALISED_N)
    else:
        helpers, update = window_update(info["lam"], info["uniform"])
    blocks = [getattr(_emit, h) if h.isupper() else h for h in helpers]
    extra = ""
    if info["kind"] == "KalmanRLS":
        extra = (f"/* R1, the covariance of the random-walk increment */\n"
                 f"static const real R1[{name.upper()}_N][{name.upper()}_N] = "
                 f"{_emit.matrix(info['R1'], dtype)};\n")
    src = (f"/* {name}.c: generated by adaptid {_version()}; see {name}.h. */\n"
           f"#include <math.h>\n#include <string.h>\n\n#include \"{name}.h\"\n\n"
           + _FMA.replace("@U@", name.upper())
           + "\n".join(_defines(info, dtype)) + "\n\n" + extra + init
           + "".join(blocks) + update + _emit.PREDICT_THETA)
    src = _emit.subst(src, name)
    header = _emit.subst(_header(name, info, n, dtype, state), name)
    return _emit.finish(header, dtype), _emit.finish(src, dtype)


def write(state, directory, name="rls", dtype="float64"):
    """Write NAME.h and NAME.c as a pair or not at all.

    Both texts go to temporary files in ``directory`` first; only when both are
    written are they renamed over NAME.h and NAME.c. On any failure the
    temporary files are removed and existing files are left as they were.
    """
    return write_texts(generate(state, name, dtype), directory, name)


def write_texts(texts, directory, name):
    """Write ``texts`` = (header, source) as NAME.h and NAME.c, a pair or not at all."""
    import os
    import tempfile
    header, source = texts
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    h, c = out / f"{name}.h", out / f"{name}.c"
    temps = []
    try:
        for text, target in ((header, h), (source, c)):
            fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=out)
            temps.append(tmp)
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                fh.write(text)
            os.chmod(tmp, 0o666 & ~_umask())
        os.replace(temps[1], c)
        os.replace(temps[0], h)
        temps = []
    finally:
        for tmp in temps:
            try:
                os.unlink(tmp)
            except OSError:
                pass
    return h, c


def _umask() -> int:
    import os
    mask = os.umask(0)
    os.umask(mask)
    return mask
