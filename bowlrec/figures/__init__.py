"""Every picture bowlrec draws (matplotlib, the ``plot`` extra), one figure a module.

Each module builds a :class:`matplotlib.figure.Figure` from data the layers below give (runs,
oil grids, shots, a ball and its layout, scatter results); :mod:`~bowlrec.figures.render` is the
one place that makes a Figure (on an Agg canvas, through the object API: no pyplot, no global
backend or figure registry, so threads may draw at once) and writes it as PNG or SVG, as bytes
or as a file (SVG reproducibly: the same figure gives the same bytes).

================  =====================================================================
module            pictures
================  =====================================================================
``render``        a new Figure; PNG/SVG bytes and files
``lane``          the lane: friction shading, boards, gutters, arrows, foul line, head pin
``trajectory``    the paper-style figure of one or many runs (``bowlrec plot``, a run's
                  page, Compare); the PNG/SVG writer of :mod:`bowlrec.sinks.registry`
``numbered``      many runs in one figure: colors and styles, numbers, the legend
``series``        speed, rev rate, slip speed and friction of a run against time
``oil``           an oil pattern as a Kegel graph; oil grids as board x distance maps
``session``       a session's oil before and after, and its drift shot by shot
``ball``          a bowler's ball and its layout (the grip, the PAP, the pin and the PSA)
``sweep``         a job's metric against a swept parameter
``variance``      release scatter at the pins, and the tolerance map of a shot
``carry``         a carry map: strike percentage over entry board x entry angle
================  =====================================================================

This package imports nothing until a module is imported; the modules import matplotlib.
"""
