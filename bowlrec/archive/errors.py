"""Errors about stored data, importable without NumPy or h5py."""

from __future__ import annotations

__all__ = ["RunDamagedError", "SegmentError"]


class SegmentError(ValueError):
    """A file is not a readable segment of a supported format version."""


class RunDamagedError(ValueError):
    """A stored run's bytes do not match its digest (or cannot be read)."""

    def __init__(self, run_id: str, segment: str, reason: str) -> None:
        super().__init__(
            f"run {run_id} in segment {segment} is damaged ({reason}); "
            "`bowlrec runs repair` quarantines it and keeps the healthy runs"
        )
        self.run_id, self.segment, self.reason = run_id, segment, reason
