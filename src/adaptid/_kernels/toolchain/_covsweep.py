r"""The covariance form's sweep as LLVM vector code, for a compile-time n.

One sweep of :mod:`._covariance` per sample, with :math:`c = u\,s`
(:math:`u = P\varphi_k`, :math:`s = 1/\sqrt d`):

.. math::

    P_{j,:} \leftarrow (P_{j,:} - c_j c)\,/\lambda \quad (j = 1..n),\qquad
    u \leftarrow P\varphi_{k+1} = \textstyle\sum_j \varphi_{k+1,j} P_{j,:},

and the bits of the new diagonal's smallest and largest entries, which the
definiteness monitor compares (:func:`._covariance._sweep`). numba leaves
LLVM's SLP vectoriser off (it miscompiled, numba PR #8852), so for a
compile-time n the unrolled scalar loops around the sweep stayed scalar: c
was formed in n scalar products and stored, and each row read it back.
Here c stays in vector registers, each row is updated in vectors of
``LANES`` doubles (one shorter vector for the n % LANES rest), and u
accumulates in registers across the rows. The arithmetic is the scalar
code's, operation for operation: ``cⱼ = uⱼ s`` and ``cᵢ = uᵢ s`` rounded
once each, ``v = fma(−cⱼ, cᵢ, Pⱼᵢ)·(1/λ)``, ``uᵢ ← fma(v, φⱼ, uᵢ)`` (the
contractions numba's ``fastmath={"contract"}`` gives the scalar loop).
"""

from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic, overload

from ..._config import NJIT_INLINE, njit
from ._vecir import LANES, VECTOR_IR, ZEN, _lanes, _ptr, _splat, lane_tree, loop_end, scalar_fma, store_vecs, \
    vector_blocks, vector_fmas


#: the bits of +inf as an int64 (the definiteness monitor compares bits, see _covariance._sweep)
BINF = 0x7FF0000000000000

#: the largest n swept by this code; above it the scalar loops of _covariance,
#: which LLVM's loop vectoriser handles. Which is faster depends on the core
#: (``benchmarks/bench_rls.py --forms``, the covariance form at n = 32 and 64):
#: on AMD Zen 4 (EPYC, 512-bit operations in two halves) the scalar loops (c in
#: registers or reloaded per row alike), so 32 there; on Intel (Emerald Rapids,
#: full-width AVX-512) this code, at n = 40, 48 and 64 too, so 64
#: (:data:`FORMS_SPECIALISED_N <adaptid.estimators._rlsforms.FORMS_SPECIALISED_N>`,
#: the largest compile-time n) elsewhere.
VECTOR_SWEEP_MAX = 32 if ZEN else 64


def _theta_step_ir(builder, th, u, idd, e, vecs, fmas):
    """θ ← θ + (u·(1/d))·ε for p = 1, in vectors: per entry ``fma(uᵢ·idd, ε, θᵢ)``,
    the scalar loop's operations (its contraction under ``fastmath={"contract"}``)."""
    for b, t in enumerate(vecs):
        g = builder.fmul(builder.load(_ptr(builder, u, LANES * b, t), align=8),
                         _splat(builder, idd, t))
        p = _ptr(builder, th, LANES * b, t)
        builder.store(builder.call(fmas[t.count], [g, _splat(builder, e, t),
                                                   builder.load(p, align=8)]), p, align=8)


def _cov_sweep_ir(builder, P, u, x, s, il, n):
    """The IR of the sweep (module docstring); returns (lo, hi), the smallest and the
    largest bits (signed int64) of the new diagonal, and q = φₖ₊₁ᵀu of the new u
    with :func:`quad_n`'s arithmetic (NaN for n < 8)."""
    i64 = ir.IntType(64)
    vecs = vector_blocks(n)
    fmas = vector_fmas(builder, vecs)
    c = [builder.fmul(builder.load(_ptr(builder, u, LANES * b, t), align=8), _splat(builder, s, t))
         for b, t in enumerate(vecs)]
    ils = {t.count: _splat(builder, il, t) for t in vecs}
    pre, loop, done = builder.block, builder.append_basic_block(), builder.append_basic_block()
    builder.branch(loop)
    builder.position_at_end(loop)
    j = builder.phi(i64)
    acc = [builder.phi(t) for t in vecs]
    row = builder.gep(P, [builder.mul(j, ir.Constant(i64, n))])
    cj = builder.fmul(builder.load(builder.gep(u, [j])), s)  # u is rewritten after the loop
    ncj = builder.fneg(cj)
    pj = builder.load(builder.gep(x, [j]))
    new = []
    for b, t in enumerate(vecs):
        p = _ptr(builder, row, LANES * b, t)
        v = builder.call(fmas[t.count], [_splat(builder, ncj, t), c[b], builder.load(p, align=8)])
        v = builder.fmul(v, ils[t.count])
        builder.store(v, p, align=8)
        new.append(builder.call(fmas[t.count], [v, _splat(builder, pj, t), acc[b]]))
    loop_end(builder, pre, loop, done, j, n,
              [(ph, ir.Constant(t, [0.0] * t.count), v) for ph, t, v in zip(acc, vecs, new)])
    store_vecs(builder, u, vecs, new)
    if n >= LANES:  # the next sample's φᵀu from the registers, as quad_n sums it
        q = _quad_ir(builder, new, [builder.load(_ptr(builder, x, LANES * b, t), align=8)
                                    for b, t in enumerate(vecs)], vecs, fmas)
    else:
        q = ir.Constant(ir.DoubleType(), float("nan"))
    # the bits of the new diagonal, read once the sweep is done
    lo, hi = ir.Constant(i64, 0x7FF0000000000000), ir.Constant(i64, 0)
    for i in range(n):
        bits = builder.load(builder.bitcast(builder.gep(P, [ir.Constant(i64, i * (n + 1))]),
                                            i64.as_pointer()))
        lo = builder.select(builder.icmp_signed("<", bits, lo), bits, lo)
        hi = builder.select(builder.icmp_signed(">", bits, hi), bits, hi)
    return lo, hi, q


def _quad_ir(builder, us, xs, vecs, fmas):
    """Σᵢ xᵢuᵢ in eight lanes: a product, then fused multiply-adds, the tree
    ((L0 + L4) + (L2 + L6)) + ((L1 + L5) + (L3 + L7)), the n % 8 rest added one by one."""
    full = [b for b, t in enumerate(vecs) if t.count == LANES]
    acc = builder.fmul(xs[0], us[0])
    for b in full[1:]:
        acc = builder.call(fmas[LANES], [xs[b], us[b], acc])
    q = lane_tree(builder, _lanes(builder, acc))
    if len(full) < len(vecs):
        fma = scalar_fma(builder)
        for xi, ui in zip(_lanes(builder, xs[-1]), _lanes(builder, us[-1])):
            q = builder.call(fma, [xi, ui, q])
    return q


def _vector_quad(NP, stride):
    """Whether :func:`quad_n` sums for these (compile-time) n and stride."""
    return (VECTOR_IR and isinstance(NP, types.IntegerLiteral)
            and LANES <= NP.literal_value <= VECTOR_SWEEP_MAX
            and isinstance(stride, types.IntegerLiteral) and stride.literal_value == 1)


def vector_quad(NP, stride):  # pragma: no cover - pure Python (NUMBA_DISABLE_JIT=1)
    """Whether :func:`quad_n` and :func:`cov_theta_step_n` run as vector code for this
    n and stride (one output): a compile-time constant in compiled code; False in
    pure Python, which takes the loops."""
    return False


@overload(vector_quad, inline="always", prefer_literal=True)
def _vector_quad_compiled(NP, stride):
    flag = _vector_quad(NP, stride)
    return lambda NP, stride: flag


def quad_n(Phi, k, u, off, NP):  # pragma: no cover - compiled code only
    """φₖᵀu[off:off + n] in the lanes and tree of :func:`_quad_ir` (LLVM vector code
    for a compile-time 8 ≤ n ≤ ``VECTOR_SWEEP_MAX``; NaN for any other n, a branch
    that :func:`vector_quad` rules out). Pure Python never calls it: there
    :func:`vector_quad` is False and :func:`._covariance._quad` takes its loops."""
    raise NotImplementedError("quad_n runs in compiled code only")


@overload(quad_n, inline="always", prefer_literal=True)
def _quad_n_compiled(Phi, k, u, off, NP):
    return lambda Phi, k, u, off, NP: _quad_n_ir(Phi, k, u, off, NP)


def _vector_n(NP):
    """n if the helpers here run as vector code for it (:func:`vector_quad`), else 0."""
    return NP.literal_value if _vector_quad(NP, types.IntegerLiteral(1)) else 0


@intrinsic(prefer_literal=True)
def _quad_n_ir(typingctx, Phi, k, u, off, NP):
    n = _vector_n(NP)

    def codegen(context, builder, signature, args):
        if not n:
            return context.get_constant(types.float64, float("nan"))
        phi = context.make_array(signature.args[0])(context, builder, args[0])
        k_ = context.cast(builder, args[1], signature.args[1], types.intp)
        x = cgutils.get_item_pointer(context, builder, signature.args[0], phi,
                                     [k_, context.get_constant(types.intp, 0)])
        ud = context.make_array(signature.args[2])(context, builder, args[2]).data
        ud = builder.gep(ud, [context.cast(builder, args[3], signature.args[3], types.intp)])
        vecs = vector_blocks(n)
        us = [builder.load(_ptr(builder, ud, LANES * b, t), align=8) for b, t in enumerate(vecs)]
        xs = [builder.load(_ptr(builder, x, LANES * b, t), align=8) for b, t in enumerate(vecs)]
        return _quad_ir(builder, us, xs, vecs, vector_fmas(builder, vecs))
    return types.float64(Phi, k, u, off, NP), codegen


def cov_theta_step_n(th, u, idd, e, NP):  # pragma: no cover - compiled code only
    """θ (n, flat) ← θ + (u/d)·ε for one output as LLVM vector code (the gain step of
    :func:`theta_step`, when :func:`vector_quad` holds; pure Python takes its loops)."""
    raise NotImplementedError("cov_theta_step_n runs in compiled code only")


@overload(cov_theta_step_n, inline="always", prefer_literal=True)
def _cov_theta_step_n_compiled(th, u, idd, e, NP):
    return lambda th, u, idd, e, NP: _theta_step_n_ir(th, u, idd, e, NP)


@intrinsic(prefer_literal=True)
def _theta_step_n_ir(typingctx, th, u, idd, e, NP):
    vecs = vector_blocks(_vector_n(NP))  # none: no code

    def codegen(context, builder, signature, args):
        thd, ud = (context.make_array(signature.args[k])(context, builder, args[k]).data
                   for k in range(2))
        _theta_step_ir(builder, thd, ud, args[2], args[3], vecs, vector_fmas(builder, vecs))
        return context.get_dummy_value()
    return types.none(th, u, idd, e, NP), codegen


@njit(**NJIT_INLINE)
def theta_step(theta, tflat, u, idd, e, NP, p):
    """Θ ← Θ + (u/d) εᵀ (``tflat``: Θ's storage); for one output and a compile-time
    8 ≤ n ≤ ``VECTOR_SWEEP_MAX`` as LLVM vector code (numba does not SLP-vectorise
    the unrolled loop), the same operations."""
    if vector_quad(NP, p):  # a compile-time constant: one branch is compiled
        cov_theta_step_n(tflat, u, idd, e[0], NP)
    else:
        for i in range(NP):
            g = u[i] * idd
            for j in range(p):
                theta[i, j] += g * e[j]


@intrinsic
def cov_sweep_n(typingctx, P, u, s, il, Phi, kn, NP):
    """The sweep for a compile-time n = NP ≤ ``VECTOR_SWEEP_MAX`` over P (n, n, C
    order), u (n), the next regressor ``Phi[kn]``; returns the (lo, hi) bits of
    the new diagonal and q = φᵀu of ``Phi[kn]`` and the new u (NaN for n < 8)."""
    if not isinstance(NP, types.IntegerLiteral) or not 0 < NP.literal_value <= VECTOR_SWEEP_MAX:
        return None
    n = NP.literal_value
    ret = types.Tuple((types.int64, types.int64, types.float64))

    def codegen(context, builder, signature, args):
        Pd, ud = (context.make_array(signature.args[k])(context, builder, args[k]).data
                  for k in range(2))
        phi = context.make_array(signature.args[4])(context, builder, args[4])
        kn_ = context.cast(builder, args[5], signature.args[5], types.intp)
        x = cgutils.get_item_pointer(context, builder, signature.args[4], phi,
                                     [kn_, context.get_constant(types.intp, 0)])
        lo, hi, q = _cov_sweep_ir(builder, Pd, ud, x, args[2], args[3], n)
        return context.make_tuple(builder, ret, [lo, hi, q])
    return ret(P, u, s, il, Phi, kn, NP), codegen


def sweep_scaled_n(P, c, u, sq, il, Phi, kn, bd, NP):
    """``_covariance._sweep_scaled`` for a compile-time n ≤ ``VECTOR_SWEEP_MAX``
    (:func:`cov_sweep_n`; chosen by :func:`._specialise.by_constant_n`)."""
    lo, hi, qn = cov_sweep_n(P, u, sq, il, Phi, kn, NP)
    return (lo > 0) & (hi < bd), (lo > 0) & (hi <= BINF), qn
