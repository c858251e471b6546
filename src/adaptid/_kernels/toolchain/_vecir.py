"""Helpers that build LLVM vector IR for the sweeps of the square-root and
covariance forms (:mod:`._potter`, :mod:`._covsweep`): numba leaves LLVM's SLP
vectoriser off, so for a compile-time n these sweeps are written as vector IR.
"""

from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic, overload

from ._patches import enabled

#: patch ``vector-ir`` (:mod:`._patches`): the sweeps of a compile-time n are LLVM
#: vector code; off, they are the plain loops of a run-time n
VECTOR_IR = enabled("vector-ir")

#: doubles per vector. Also the fixed lane count of the square-root form's dot
#: products (part of its arithmetic: keep it).
LANES = 8


def target_cpu():
    """The CPU numba compiles for: ``NUMBA_CPU_NAME`` if set, else the host's, in
    LLVM's names (``"znver4"``, ``"sapphirerapids"``, ...). numba's disk cache keys
    its entries by this CPU too, so a choice made from it is made again on another."""
    from llvmlite import binding
    from numba.core import config
    return config.CPU_NAME or binding.get_host_cpu_name()


#: Whether the target is an AMD Zen core: Zen 4 runs a 512-bit operation as two
#: 256-bit halves, and there the long vector sweeps lost to LLVM's own loop
#: vectoriser (see :data:`._covsweep.VECTOR_SWEEP_MAX`).
ZEN = target_cpu().startswith("znver")


def _ptr(builder, base, off, ty):
    """&base[off] (doubles), as a pointer to ``ty`` (a vector or a double)."""
    return builder.bitcast(builder.gep(base, [ir.Constant(ir.IntType(64), off)]),
                           ty.as_pointer())


def _splat(builder, x, vec):
    u = ir.Constant(vec, ir.Undefined)
    for lane in range(vec.count):
        u = builder.insert_element(u, x, ir.Constant(ir.IntType(32), lane))
    return u


def _lanes(builder, v):
    return [builder.extract_element(v, ir.Constant(ir.IntType(32), k)) for k in range(v.type.count)]


def vector_blocks(n):
    """The vector types covering n doubles: n // LANES of LANES, and one of the rest."""
    dbl = ir.DoubleType()
    return [ir.VectorType(dbl, LANES)] * (n // LANES) + \
        ([ir.VectorType(dbl, n % LANES)] if n % LANES else [])


def vector_fmas(builder, vecs):
    """``llvm.fma`` declared for each vector width in ``vecs``, by width."""
    return {t.count: cgutils.get_or_insert_function(
        builder.module, ir.FunctionType(t, [t] * 3), f"llvm.fma.v{t.count}f64") for t in vecs}


def scalar_fma(builder):
    """``llvm.fma.f64`` declared in the builder's module."""
    dbl = ir.DoubleType()
    return cgutils.get_or_insert_function(builder.module, ir.FunctionType(dbl, [dbl] * 3),
                                          "llvm.fma.f64")


def lane_tree(builder, L):
    """The sum of eight lanes as the kernels' dot products add them:
    ((L0 + L4) + (L2 + L6)) + ((L1 + L5) + (L3 + L7))."""
    add = builder.fadd
    return add(add(add(L[0], L[4]), add(L[2], L[6])), add(add(L[1], L[5]), add(L[3], L[7])))


def loop_end(builder, pre, loop, done, j, n, phis):
    """Close a loop over j = 0..n−1 begun in ``loop`` after ``pre``: branch back while
    j + 1 < n, give j and the ``phis`` (phi, start, next) their incoming values, and
    continue in ``done``."""
    i64 = ir.IntType(64)
    j1 = builder.add(j, ir.Constant(i64, 1))
    builder.cbranch(builder.icmp_signed("<", j1, ir.Constant(i64, n)), loop, done)
    for phi, start, nxt in [(j, ir.Constant(i64, 0), j1)] + phis:
        phi.add_incoming(start, pre)
        phi.add_incoming(nxt, loop)
    builder.position_at_end(done)


def store_vecs(builder, base, vecs, values):
    """Store the vectors ``values`` (of the types ``vecs``) one after the other at base."""
    for b, (t, v) in enumerate(zip(vecs, values)):
        builder.store(v, _ptr(builder, base, LANES * b, t), align=8)


def fma(a, b, c):  # pragma: no cover - pure Python (NUMBA_DISABLE_JIT=1): rounded twice
    """a·b + c rounded once (``llvm.fma.f64``) in compiled code, whatever the
    contraction heuristics would make of ``a * b + c``: a kernel whose bits another
    kernel must reproduce writes its fused operations with it."""
    return a * b + c


@intrinsic
def _fma_ir(typingctx, a, b, c):
    if not all(t == types.float64 for t in (a, b, c)):
        return None

    def codegen(context, builder, signature, args):
        return builder.call(scalar_fma(builder), args)
    return types.float64(a, b, c), codegen


@overload(fma, inline="always")
def _fma(a, b, c):
    return lambda a, b, c: _fma_ir(a, b, c)

