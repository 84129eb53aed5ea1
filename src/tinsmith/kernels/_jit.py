"""The jit decorators every kernel uses.

``jit`` is ``njit(cache=True, nogil=True)``: compiled once, cached on disk, no
fastmath (geometry needs exact IEEE arithmetic).  ``jit_inline`` is the same
with ``inline="always"``, for the small helpers of the hot loops (triangle
scans, flips, heap moves): numba reference-counts every array an
out-of-line call passes, which cost more than the helpers' work (measured:
greedy insertion 15-30% faster inlined, at some 13 s more first compile).
"""

import numba

jit = numba.njit(cache=True, nogil=True)
jit_inline = numba.njit(cache=True, nogil=True, inline="always")
