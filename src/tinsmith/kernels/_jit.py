"""The jit decorators every kernel uses.

``jit`` is ``njit(cache=True, nogil=True)``: compiled once, cached on disk, no
fastmath (geometry needs exact IEEE arithmetic).  ``jit_inline`` adds
``forceinline=True``, for the helpers of the hot loops (row scans, in-circle
tests, heap moves, greedy insertion's scans and insertion path): LLVM's
``alwaysinline``, so that an out-of-line call does not pass every array of
the triangulation's tuples through the stack (and reference-count them) for
a helper's small work.  numba compiles such a helper once per signature and
LLVM inlines the machine code; numba's own ``inline="always"``, which this
used before, inlines at the level of numba's IR and types the callee again
at every call site, nested helpers within helpers, which made greedy
insertion's ``refine`` and ``flush`` take minutes each to compile for the
same machine code.  ``jit_no_refcount`` goes further for kernels that
allocate nothing.

Time a hot loop after factoring it: an inlined helper that returns a tuple
of counters the caller's loop carries can make that loop several times
slower.  The measurements behind these choices are in
``benchmarks/NOTES_jit.md``.

Every decorator hands its kernel to :func:`.portable.seed_on_first_load`,
so that the cache the package build compiled is used on a first run.
"""

import numba
from llvmlite import ir
from numba.core import cgutils
from numba.core.cpu import CPUTargetOptions
from numba.extending import intrinsic

from . import compiling, portable

compiling.install()


def _seeded(decorator):
    """``decorator``, and the kernel's entry of the package's compiled cache seeded into numba's (:mod:`.portable`)."""

    def decorate(func):
        dispatcher = decorator(func)
        portable.seed_on_first_load(dispatcher)
        return dispatcher

    return decorate


jit = _seeded(numba.njit(cache=True, nogil=True))
jit_inline = _seeded(numba.njit(cache=True, nogil=True, forceinline=True))

#: ``jit`` without numba's reference counting (its NRT) of the arrays a
#: kernel handles, for kernels that allocate nothing, down to every
#: function they call (which numba compiles with the same flags; scratch
#: space comes from :func:`stack_buffer`).  Every array a numba function
#: binds to a name or pulls out of a tuple costs an atomic increment and
#: decrement, which dominates greedy insertion's loops (rescan and
#: refinement).  Falls back to ``jit`` where numba has no such option.
jit_no_refcount = (
    _seeded(numba.njit(cache=True, nogil=True, _nrt=False)) if hasattr(CPUTargetOptions, "_nrt") else jit
)

#: ``jit_no_refcount`` with numpy's error model: no test for a zero divisor
#: before every division (Python's model raises ZeroDivisionError), for
#: kernels whose divisors are never zero (greedy insertion's ``refine``:
#: twice a triangle's area, the grid width).
jit_no_refcount_unchecked = (
    _seeded(numba.njit(cache=True, nogil=True, _nrt=False, error_model="numpy"))
    if hasattr(CPUTargetOptions, "_nrt")
    else _seeded(numba.njit(cache=True, nogil=True, error_model="numpy"))
)


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


@intrinsic
def stack_buffer(typingctx, n):
    """A float64 array of ``n`` (a literal) elements in the calling function's stack frame.

    No allocation and no reference count: usable where ``jit_no_refcount``
    forbids ``np.empty``.  The array lives as long as the function that
    holds the call (after inlining, the outermost one); it must not be
    returned from it.
    """
    if not isinstance(n, numba.types.IntegerLiteral):
        return None
    size = n.literal_value
    arrty = numba.types.Array(numba.types.float64, 1, "C")

    def codegen(context, builder, sig, args):
        from numba.np.arrayobj import populate_array

        data = cgutils.alloca_once(builder, ir.DoubleType(), size=size)
        ary = context.make_array(arrty)(context, builder)
        intp = numba.types.intp
        populate_array(
            ary, data=data, shape=[context.get_constant(intp, size)], strides=[context.get_constant(intp, 8)],
            itemsize=context.get_constant(intp, 8), meminfo=None,
        )
        return ary._getvalue()

    return arrty(n), codegen
