"""Numba kernels: arrays and scalars in, arrays out, no validation.

Every kernel is compiled with a decorator of :mod:`._jit` (``njit(cache=True,
nogil=True)``, no fastmath: geometry needs exact IEEE arithmetic; inlined or
without reference counting where a hot loop needs it) and cached on disk, so
a second process does not compile again.  The package ships the compiled
kernels of its default job (:mod:`.portable`); a compilation says so
(:mod:`.compiling`).  Importing this package imports no kernel (and not
numba): each module is imported where it is used.
"""
