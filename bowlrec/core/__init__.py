"""Numerics on plain floats and arrays: equations of motion, integrator, events. No units, no I/O.

Importing this package compiles (or loads from the on-disk cache) the numba kernels.
"""
