"""Provenance: what produced a segment's runs (package versions, platform), computed once per
process and stored once per segment as root attributes."""

from __future__ import annotations

import functools
import platform
import sys
from importlib.metadata import PackageNotFoundError, version
from typing import Any

import bowlrec

__all__ = ["environment"]


def _version(module: str) -> str:

    try:
        return version(module)
    except PackageNotFoundError:
        return "unknown"


@functools.cache
def _environment() -> tuple[tuple[str, str], ...]:
    import h5py

    return (
        ("bowlrec_version", bowlrec.__version__),
        ("physics_version", bowlrec.PHYSICS_VERSION),
        ("python_version", sys.version.split()[0]),
        ("platform", platform.platform()),
        ("numpy_version", _version("numpy")),
        ("numba_version", _version("numba")),
        ("h5py_version", h5py.version.version),
        ("hdf5_version", h5py.version.hdf5_version),
    )


def environment() -> dict[str, Any]:
    """This process's versions and platform (cached: package metadata is read once)."""
    return dict(_environment())
