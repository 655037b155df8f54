"""Numerics on plain floats and arrays: equations of motion, integrator, events. No units, no I/O.

Importing a kernel module compiles the numba kernels, or loads them from numba's on-disk cache
(``bowlrec/core/__pycache__``, or under ``NUMBA_CACHE_DIR``); ``_kernel_cache`` drops the cache
entries of kernels whose sources, or the sources of modules they import, changed, and ``warm``
loads the kernels a process needs ahead of its first delivery.
"""
