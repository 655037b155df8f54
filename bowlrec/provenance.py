"""Provenance: what produced a segment's runs (package versions, platform), computed once per
process and stored once per segment as root attributes."""

from __future__ import annotations

import functools
import platform
import sys
from importlib.metadata import PackageNotFoundError, version
from typing import Any

from bowlrec.versions import BOWLER_LAYER_VERSION, PHYSICS_VERSION, __version__

__all__ = ["bowler_layer_warning", "environment", "physics_version_warning"]


def _version(module: str) -> str:

    try:
        return version(module)
    except PackageNotFoundError:
        return "unknown"


@functools.cache
def _environment() -> tuple[tuple[str, str], ...]:
    import h5py

    return (
        ("bowlrec_version", __version__),
        ("physics_version", PHYSICS_VERSION),
        ("bowler_layer_version", str(BOWLER_LAYER_VERSION)),
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


def bowler_layer_warning(provenance: dict[str, Any]) -> str | None:
    """A warning for a run made before the current bowlers' layer (no or an older
    ``bowler_layer_version`` in its provenance), else None."""
    made_with = provenance.get("bowler_layer_version")
    try:
        current = made_with is not None and int(made_with) >= BOWLER_LAYER_VERSION
    except (TypeError, ValueError):
        current = False
    if current:
        return None
    try:
        version = int(made_with) if made_with is not None else 1
    except (TypeError, ValueError):
        version = 1
    changes = []
    if version < 2:
        changes.append(
            "its PAP was placed at the other end of the spin axis, so the layout and "
            "side-weight labels of that scene describe the mirror-side ball"
        )
    changes.append(
        "its oil became friction at the paper's 0.04 / 0.20 rather than the calibrated levels, "
        "and its drilled holes removed whole cylinders"
    )
    return (
        f"made with bowler layer {made_with or '1'} (current: {BOWLER_LAYER_VERSION}): if this "
        f"run came from a bowler scene, {'; '.join(changes)}; the physics of the stored scene "
        "is unaffected"
    )


def physics_version_warning(provenance: dict[str, Any]) -> str | None:
    """A note for a run made by another physics version than this one (its run ID is that
    version's: simulating its scene now gives a new run ID and results that differ within the
    old version's tolerance, CHANGELOG.md "Physics versions"), else None."""
    made_with = provenance.get("physics_version")
    if made_with is None or made_with == PHYSICS_VERSION:
        return None
    return (
        f"made with physics {made_with} (current: {PHYSICS_VERSION}): simulating this scene "
        "again gives a new run ID and may differ from it within the tolerance"
    )
