"""Numba kernels: arrays and scalars in, arrays out, no validation.

Every kernel is compiled with :data:`jit` (``njit(cache=True, nogil=True)``,
no fastmath: geometry needs exact IEEE arithmetic) and cached on disk, so a
second process does not compile again.
"""

from ._jit import jit

__all__ = ["jit"]
