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
from numba.extending import intrinsic

from ._vecir import LANES, _ptr, _splat, loop_end, store_vecs, vector_blocks, vector_fmas


#: the largest n swept by this code; above it the scalar loops of _covariance,
#: which LLVM's loop vectoriser handles, were faster (bench_rls.py --forms at n = 64:
#: 0.87 against 0.70 x the C loop, with c in registers or reloaded per row alike)
VECTOR_SWEEP_MAX = 32


def _cov_sweep_ir(builder, P, u, x, s, il, n):
    """The IR of the sweep (module docstring); returns (lo, hi), the smallest and the
    largest bits (signed int64) of the new diagonal."""
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
    # the bits of the new diagonal, read once the sweep is done
    lo, hi = ir.Constant(i64, 0x7FF0000000000000), ir.Constant(i64, 0)
    for i in range(n):
        bits = builder.load(builder.bitcast(builder.gep(P, [ir.Constant(i64, i * (n + 1))]),
                                            i64.as_pointer()))
        lo = builder.select(builder.icmp_signed("<", bits, lo), bits, lo)
        hi = builder.select(builder.icmp_signed(">", bits, hi), bits, hi)
    return lo, hi


@intrinsic
def cov_sweep_n(typingctx, P, u, s, il, Phi, kn, NP):
    """The sweep for a compile-time n = NP ≤ ``VECTOR_SWEEP_MAX`` over P (n, n, C
    order), u (n), the next regressor ``Phi[kn]``; returns the (lo, hi) bits of
    the new diagonal."""
    if not isinstance(NP, types.IntegerLiteral) or not 0 < NP.literal_value <= VECTOR_SWEEP_MAX:
        return None
    n = NP.literal_value
    ret = types.UniTuple(types.int64, 2)

    def codegen(context, builder, signature, args):
        Pd, ud = (context.make_array(signature.args[k])(context, builder, args[k]).data
                  for k in range(2))
        phi = context.make_array(signature.args[4])(context, builder, args[4])
        kn_ = context.cast(builder, args[5], signature.args[5], types.intp)
        x = cgutils.get_item_pointer(context, builder, signature.args[4], phi,
                                     [kn_, context.get_constant(types.intp, 0)])
        lo, hi = _cov_sweep_ir(builder, Pd, ud, x, args[2], args[3], n)
        return context.make_tuple(builder, ret, [lo, hi])
    return ret(P, u, s, il, Phi, kn, NP), codegen
