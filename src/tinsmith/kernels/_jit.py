"""The jit decorators every kernel uses.

``jit`` is ``njit(cache=True, nogil=True)``: compiled once, cached on disk, no
fastmath (geometry needs exact IEEE arithmetic).  ``jit_inline`` is the same
with ``inline="always"``, for the helpers of the hot loops (row scans, flips,
in-circle tests, heap moves) and for the insertion path of greedy insertion
(insert, split, legalise): numba reference-counts every array an out-of-line
call passes, which costs more than such a helper's work.  Measured on
greedy insertion: the leaf helpers inlined, about 15% faster (Grand Canyon
tile, max_error 5); the insertion path inlined as well, with one
legalisation loop per split so that it is inlined twice rather than nine
times, 0.29 s -> 0.23 s on St. Helens at max_error 1 for a first compile of
the greedy kernels of 23 s instead of 16 s.  ``jit_no_refcount`` goes
further for kernels that allocate nothing.

Inlining costs compile time at every call site: numba inlines at the level
of its own IR and types the callee again each time.  Measured on this
project's 2-core machine, first compile of the README's first command
(greedy insertion on the St. Helens sample with its nodata outline, and
the metrics): 143 s with every helper inlined and three legalisation loops
per insertion; 105 s with one legalisation loop per insertion (the splits
return the stack top, :func:`.tin.insert_in_triangle` legalises once);
67-72 s with the triangulation's leaf helpers (``next_half``, ``_link``,
``set_triangle``, ``_put``, ...) compiled once as plain ``jit``, which LLVM
inlines anyway: greedy insertion on the sample at max_error 1 ran 0.36 s
against 0.41 s before (best of 3; noisy).  The same for greedy's scan
helpers and the heap gained no compile time and lost 10-20% of run time,
so those stay inlined.

A large kernel called out of line from a hot loop costs most through its
arguments: numba passes every array of the tuples a kernel takes as a
struct of seven words on the stack, so greedy insertion's ``flush`` (the
triangulation's ten arrays, the grid's, the heap's) and ``scan_triangle``
copied some hundred words per call, once an insertion and once a rescanned
triangle.  Inlined into ``refine`` (``_flush``; ``flush`` stays a kernel for
the engine's first scan from Python): greedy insertion 22-30% faster, the
same meshes bit for bit (St. Helens at max_error 0.5: 0.149 s -> 0.107 s,
Delft DTM at 0.0137: 0.131 -> 0.106 s, best of 7 in one process).  With the
scans inlined, the row prefetches ``flush`` issued for every dirty triangle
before scanning them pay only on grids beyond the cache: 6-7% faster on
2049 x 2049 grids, 5-10% slower on the real DEMs of the benchmark (median of
paired runs in one process, the two builds taking turns), hence
``greedy.PREFETCH_BYTES``.

The other way round, measured on the quadtree's extraction: an inlined
helper that takes several arrays and *returns a tuple of counters* the
caller's loop carries (``n, n_points = _write(...)``) made that loop four
times slower than writing its body in the loop; a helper returning one
value per call (``_vertex``) costs nothing.  Time a hot loop after
factoring it.
"""

import numba
from llvmlite import ir
from numba.core import cgutils
from numba.core.cpu import CPUTargetOptions
from numba.extending import intrinsic

from . import compiling, portable

compiling.install()


def _seeded(decorator):
    """``decorator``, then the kernel's shipped portable cache copied into numba's (:mod:`.portable`)."""

    def decorate(func):
        dispatcher = decorator(func)
        portable.seed(dispatcher)
        return dispatcher

    return decorate


jit = _seeded(numba.njit(cache=True, nogil=True))
jit_inline = _seeded(numba.njit(cache=True, nogil=True, inline="always"))

#: ``jit`` without numba's reference counting (its NRT) of the arrays a
#: kernel handles, for kernels that allocate nothing, down to every
#: function they call (which numba compiles with the same flags; scratch
#: space comes from :func:`stack_buffer`).  Every array a numba function
#: binds to a name or pulls out of a tuple costs an atomic increment and
#: decrement.  Greedy insertion's loops (rescan and refinement) without it:
#: 0.24 s -> 0.13 s on St. Helens at max_error 1, 2.21 s -> 1.75 s on a
#: 4097 x 4097 DEM.  Falls back to ``jit`` where numba has no such option.
jit_no_refcount = (
    _seeded(numba.njit(cache=True, nogil=True, _nrt=False)) if hasattr(CPUTargetOptions, "_nrt") else jit
)

#: ``jit_no_refcount`` with numpy's error model: no test for a zero divisor
#: before every division (Python's model raises ZeroDivisionError), for
#: kernels whose divisors are never zero (greedy insertion's ``refine``:
#: twice a triangle's area, the grid width).  Worth 2-4% of greedy insertion
#: on the real DEMs of its benchmark (paired runs in one process).
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
