"""The one jit decorator every kernel uses."""

import numba

#: ``njit(cache=True, nogil=True)``: compiled once, cached on disk, releases the GIL.
jit = numba.njit(cache=True, nogil=True)
