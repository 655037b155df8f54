"""Numerics on plain floats and arrays: equations of motion, integrator, events. No units, no I/O.

Importing a kernel module compiles the numba kernels, or loads them from the on-disk cache in
``bowlrec/core/__pycache__`` (see ``_kernel_cache`` for how stale caches are dropped).
"""
