"""The square-root (Potter) form's sweep for a compile-time n, as LLVM vector IR.

:func:`sweep_n` is :func:`adaptid._kernels.recursions._potter._sweep` for a
constant n, in vectors of LANES doubles: numba does not SLP-vectorise the
unrolled loops of a constant n. The recursion module picks it through
:func:`._specialise.by_constant_n` (patch ``vector-ir``).
"""

from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from ._vecir import LANES, _lanes, _ptr, _splat, lane_tree, loop_end, scalar_fma, store_vecs, \
    vector_blocks, vector_fmas

__all__ = ["LANES", "sweep_n"]


def _sweep_ir(builder, F, f, a, x, h, s, n):
    """The LLVM IR of :func:`_potter._sweep` for a compile-time n:
    a loop over the columns j, each in vectors of LANES doubles and one of the n % LANES
    rows left (their products summed one by one into lane 0, as ``_potter._coldot``), with
    h and q in registers across columns."""
    i64, dbl = ir.IntType(64), ir.DoubleType()
    vecs = vector_blocks(n)
    fmas = vector_fmas(builder, vecs)
    fma = scalar_fma(builder)
    pre, loop, done = builder.block, builder.append_basic_block(), builder.append_basic_block()
    svs = {t.count: _splat(builder, s, t) for t in vecs}
    builder.branch(loop)
    builder.position_at_end(loop)
    j, q = builder.phi(i64), builder.phi(dbl)
    hs = [builder.phi(t) for t in vecs]
    col = builder.gep(F, [builder.mul(j, ir.Constant(i64, n))])
    fj = builder.load(builder.gep(f, [j]))
    acc, vals = ir.Constant(ir.VectorType(dbl, LANES), [0.0] * LANES), []
    for b, t in enumerate(vecs):
        p = _ptr(builder, col, LANES * b, t)
        v = builder.load(p, align=8)
        prod = builder.fmul(builder.load(_ptr(builder, a, LANES * b, t), align=8),
                            _splat(builder, fj, t))
        v = builder.call(fmas[t.count], [svs[t.count], v, builder.fneg(prod)])
        builder.store(v, p, align=8)
        xv = builder.load(_ptr(builder, x, LANES * b, t), align=8)
        if t.count == LANES:
            acc = builder.call(fmas[LANES], [v, xv, acc])
        else:
            acc = _lanes(builder, acc)
            for vi, xi in zip(_lanes(builder, v), _lanes(builder, xv)):
                acc[0] = builder.call(fma, [vi, xi, acc[0]])
        vals.append(v)
    fn = lane_tree(builder, acc if isinstance(acc, list) else _lanes(builder, acc))  # as _potter._coldot
    builder.store(fn, builder.gep(f, [j]))
    hn = [builder.call(fmas[t.count], [v, _splat(builder, fn, t), hv])
          for t, v, hv in zip(vecs, vals, hs)]
    qn = builder.call(fma, [fn, fn, q])
    loop_end(builder, pre, loop, done, j, n, [(q, ir.Constant(dbl, 0.0), qn)] +
              [(ph, ir.Constant(t, [0.0] * t.count), v) for ph, t, v in zip(hs, vecs, hn)])
    store_vecs(builder, h, vecs, hn)
    return qn


@intrinsic
def sweep_n(typingctx, F, f, a, x, h, s, NP):
    """:func:`_potter._sweep` for a compile-time n = NP, in
    vectors of LANES doubles: numba does not SLP-vectorise the unrolled loops of a
    constant n. Returns q = fᵀf of the new f."""
    if not isinstance(NP, types.IntegerLiteral):
        return None
    n = NP.literal_value

    def codegen(context, builder, signature, args):
        data = [context.make_array(signature.args[k])(context, builder, args[k]).data
                for k in range(5)]
        return _sweep_ir(builder, *data, args[5], n)

    return types.float64(F, f, a, x, h, s, NP), codegen
