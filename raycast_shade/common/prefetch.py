"""A cache hint for kernels whose gathers miss the caches: :func:`prefetch` and when to use it.

The batched Phong kernel, the mirror kernel and the buffer kernel read, per pixel, a random
triangle's row and its vertices' rows. On a mesh larger than the caches each read is a miss the
processor cannot overlap with the next pixel's arithmetic; asking for the rows a few pixels (or a
pass) ahead lets the misses overlap. On a mesh that fits in the caches the hint costs a few percent,
so the kernels prefetch only beyond :data:`PREFETCH_BYTES`.
"""

from __future__ import annotations

from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

__all__ = ["PREFETCH_BYTES", "beyond_caches", "prefetch"]

# Kernels prefetch only when the gathered arrays (vertices, vertex normals, faces, face normals) exceed
# this: at 81,920 triangles (4.7 MiB) the hint cost 1-7% of the kernel, at 1.31 M (75 MiB) it saved
# 15-25% (docs/performance.md). The threshold lies between the two; it is not tuned finer.
PREFETCH_BYTES = 32 << 20


def beyond_caches(*arrays) -> bool:
    """Whether a kernel that gathers from ``arrays`` (the ones it reads per pixel: vertices,
    faces, normals) should prefetch: their bytes together exceed :data:`PREFETCH_BYTES`."""
    return sum(a.nbytes for a in arrays) > PREFETCH_BYTES


@intrinsic
def prefetch(typingctx, arr, i):
    """Hint the cache to load row ``i`` of ``arr`` (``llvm.prefetch``, for reading, kept in every
    level): no result, no fault whatever the address, so nothing computed depends on it."""
    if not isinstance(arr, types.Array) or not isinstance(i, types.Integer):
        return None

    def codegen(context, builder, signature, args):
        aryty, ity = signature.args
        ary = context.make_array(aryty)(context, builder, args[0])
        stride = cgutils.unpack_tuple(builder, ary.strides)[0]
        idx = context.cast(builder, args[1], ity, types.intp)
        addr = builder.add(builder.ptrtoint(ary.data, stride.type), builder.mul(idx, stride))
        ptr = builder.inttoptr(addr, ir.IntType(8).as_pointer())
        i32 = ir.IntType(32)
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ir.VoidType(), [ptr.type, i32, i32, i32]),
                                            "llvm.prefetch.p0")
        builder.call(fn, [ptr, i32(0), i32(3), i32(1)])
        return context.get_dummy_value()

    return types.void(arr, i), codegen
