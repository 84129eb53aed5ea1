"""Numba kernels: arrays and scalars in, arrays out, no validation.

Every kernel is compiled with :data:`jit` (``njit(cache=True, nogil=True)``,
no fastmath: geometry needs exact IEEE arithmetic) or, for the small helpers
of hot loops, :data:`jit_inline` (the same, inlined into its callers), and
cached on disk, so a second process does not compile again.
"""

from ._jit import jit, jit_inline

__all__ = ["jit", "jit_inline"]
