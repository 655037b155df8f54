"""Bowlers' language: ball spec sheets, layouts, deliveries, lanes and oil patterns in the units
bowlers, drillers and coaches use (lb, in, oz, mph, rpm, boards, ft, degrees).

Everything here resolves to the physical :class:`~bowlrec.spec.Scene`; nothing reaches the
kernel directly. Conversions are exact (``bowlrec.units``).
"""
