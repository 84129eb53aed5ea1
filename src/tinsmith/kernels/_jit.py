"""The jit decorators every kernel uses.

``jit`` is ``njit(cache=True, nogil=True)``: compiled once, cached on disk, no
fastmath (geometry needs exact IEEE arithmetic).  ``jit_inline`` is the same
with ``inline="always"``, for the small leaf helpers of the hot loops (row
scans, flips, in-circle tests, heap moves): numba reference-counts every
array an out-of-line call passes, which costs more than such a helper's
work.  Measured on greedy insertion (Grand Canyon tile, max_error 5): about
15% faster with the leaf helpers inlined (first compile 44 s instead of
35 s); inlining the larger functions as well gained some 10% more but
doubled the first compile (97 s), so they stay out of line.
"""

import numba
from llvmlite import ir
from numba.core import cgutils
from numba.extending import intrinsic

jit = numba.njit(cache=True, nogil=True)
jit_inline = numba.njit(cache=True, nogil=True, inline="always")


@intrinsic
def prefetch(typingctx, arr, index):
    """Ask the CPU to fetch ``arr[index]`` into the cache (a hint: no effect on results, no fault if out of range)."""

    def codegen(context, builder, sig, args):
        aryty = sig.args[0]
        ary = context.make_array(aryty)(context, builder, args[0])
        ptr = cgutils.get_item_pointer(context, builder, aryty, ary, [args[1]], wraparound=False, boundscheck=False)
        i8p, i32 = ir.IntType(8).as_pointer(), ir.IntType(32)
        fn = cgutils.get_or_insert_function(
            builder.module, ir.FunctionType(ir.VoidType(), [i8p, i32, i32, i32]), "llvm.prefetch.p0"
        )
        builder.call(fn, [builder.bitcast(ptr, i8p), i32(0), i32(3), i32(1)])  # read, keep, data cache
        return context.get_dummy_value()

    return numba.types.void(arr, index), codegen
