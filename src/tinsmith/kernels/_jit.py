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

jit = numba.njit(cache=True, nogil=True)
jit_inline = numba.njit(cache=True, nogil=True, inline="always")
