"""Writers of finished runs to files and viewers: HDF5 archive, MCAP, rerun, plots.

Sinks know formats, never physics: each takes a :class:`RunData` (the scene as given, its
resolved :class:`~bowlrec.core.plan.Plan`, and the :class:`~bowlrec.core.trajectory.Trajectory`)
and writes it. Heavy libraries (h5py, mcap, foxglove, rerun, matplotlib) are imported inside
the writer modules only, so ``import bowlrec`` stays fast.
"""

from .common import RunData, SamplesRequiredError

__all__ = ["RunData", "SamplesRequiredError"]
