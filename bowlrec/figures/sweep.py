"""A job's metric against one of its swept parameters (the web page of a job)."""

from __future__ import annotations

import math
from collections.abc import Sequence

from matplotlib.figure import Figure

from .render import new_figure

__all__ = ["sweep_figure"]


def sweep_figure(
    x: Sequence[float],
    y: Sequence[float | None],
    *,
    x_label: str,
    y_label: str,
    title: str | None = None,
) -> Figure:
    """A swept metric ``y`` against a swept parameter ``x`` (labels carry the units): the points
    marked and joined in increasing x; points whose y is None or NaN (or whose x is not
    finite) are left out. Raises ValueError if ``x`` and ``y`` differ in length."""
    if len(x) != len(y):
        raise ValueError(f"x has {len(x)} values but y has {len(y)}")
    points = sorted(
        (float(a), float(b))
        for a, b in zip(x, y, strict=True)
        if b is not None and math.isfinite(float(b)) and math.isfinite(float(a))
    )
    fig = new_figure(figsize=(6.4, 4.0), layout="constrained")
    ax = fig.subplots()
    if points:
        xs, ys = zip(*points, strict=True)
        ax.plot(xs, ys, "-o", color="#1f4e9c", lw=1.5, ms=4)
    else:
        ax.text(0.5, 0.5, "no values", transform=ax.transAxes, ha="center", va="center")
    ax.set_xlabel(x_label)
    ax.set_ylabel(y_label)
    ax.grid(True, color="#dddddd", lw=0.6)
    if title is not None:
        ax.set_title(title, fontsize=11)
    return fig
