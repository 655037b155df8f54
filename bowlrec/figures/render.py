"""Make a Figure and write it as PNG or SVG: the one place bowlrec touches matplotlib's canvas.

:func:`new_figure` makes a :class:`~matplotlib.figure.Figure` on an Agg canvas through the object
API: no pyplot, so no global backend switch, no figure registry and nothing to close, and threads
may draw figures at once. :func:`figure_bytes` renders a figure as PNG or SVG bytes and
:func:`save_figure` writes them to a file atomically (a temporary file beside it, then renamed).

SVG output is reproducible: the ids matplotlib writes are salted with :data:`SVG_HASHSALT`, no
date or creator is written and text is drawn as paths, so the same figure gives the same bytes.
PNG output carries no software tag. Rendering holds a lock for the moment matplotlib's SVG
settings are in force (they are read from its global ``rcParams``), so renders in other threads
never see them half set.
"""

from __future__ import annotations

import io
import os
import threading
from pathlib import Path
from typing import Any, Literal

import matplotlib
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from bowlrec.atomic_files import atomic_path

__all__ = [
    "FORMATS",
    "PNG_DPI",
    "SVG_HASHSALT",
    "Format",
    "figure_bytes",
    "format_for",
    "new_figure",
    "save_figure",
]

Format = Literal["svg", "png"]
#: the formats figures are written in, by name (a file's suffix is ``.`` + the name)
FORMATS: tuple[Format, ...] = ("png", "svg")
#: resolution of PNG figures (dots per inch) unless a caller asks for another
PNG_DPI = 100
#: the salt of the ids matplotlib writes into SVG (fixed so the output is reproducible)
SVG_HASHSALT = "bowlrec"
#: blank space (inches) around a tightly cropped figure
PAD_INCHES = 0.15
#: matplotlib settings in force while a figure is rendered
_RC: dict[Any, Any] = {
    "svg.hashsalt": SVG_HASHSALT,
    "svg.fonttype": "path",
    "svg.image_inline": True,
}
_RC_LOCK = threading.Lock()


def new_figure(**kwargs: Any) -> Figure:
    """A :class:`~matplotlib.figure.Figure` (``kwargs`` as it takes them: ``figsize``,
    ``layout``, ``dpi``) on its own Agg canvas."""
    fig = Figure(**kwargs)
    FigureCanvasAgg(fig)
    return fig


def figure_bytes(
    fig: Figure, fmt: str, *, dpi: float | None = PNG_DPI, tight: bool = True
) -> bytes:
    """The bytes of ``fig`` as ``"svg"`` (reproducible) or ``"png"``; ValueError for another
    format. ``dpi``: the PNG's resolution (None: the figure's own); ``tight``: cropped to what
    is drawn, :data:`PAD_INCHES` around it (else the figure's own size)."""
    if fmt not in FORMATS:
        raise ValueError(f"fmt = {fmt!r} must be 'svg' or 'png'")
    if not isinstance(fig.canvas, FigureCanvasAgg):
        FigureCanvasAgg(fig)
    buf = io.BytesIO()
    metadata = {"Date": None, "Creator": None} if fmt == "svg" else {"Software": None}
    crop: dict[str, Any] = {"bbox_inches": "tight", "pad_inches": PAD_INCHES} if tight else {}
    with _RC_LOCK, matplotlib.rc_context(_RC):
        fig.savefig(
            buf, format=fmt, dpi="figure" if dpi is None else dpi, metadata=metadata, **crop
        )
    return buf.getvalue()


def format_for(path: str | os.PathLike[str]) -> Format:
    """The format a file is written in, by its suffix (any case); ValueError unless it is
    ``.png`` or ``.svg``."""
    suffix = Path(path).suffix
    for fmt in FORMATS:
        if suffix.lower() == f".{fmt}":
            return fmt
    raise ValueError(
        f"cannot plot to {os.fspath(path)!r}: the file name must end in .png or .svg "
        f"(got suffix {suffix!r})"
    )


def save_figure(
    fig: Figure,
    path: str | os.PathLike[str],
    *,
    dpi: float | None = PNG_DPI,
    tight: bool = True,
) -> Path:
    """Write ``fig`` to ``path`` (.png or .svg, as :func:`figure_bytes` renders it with ``dpi``
    and ``tight``); return the path. The file is written whole or not at all (a temporary file
    in the same directory, created if missing, then renamed) and keeps the permissions of a
    file it replaces. ValueError for another suffix, before anything is written."""
    out = Path(path)
    data = figure_bytes(fig, format_for(out), dpi=dpi, tight=tight)
    try:
        mode: int | None = out.stat().st_mode & 0o7777
    except FileNotFoundError:
        mode = None
    with atomic_path(out, durable=False) as tmp:
        tmp.write_bytes(data)
        if mode is not None:
            os.chmod(tmp, mode)
    return out
