"""Chunk spans of a job, sized so a chunk takes about a set time of a worker.

A job's runs go to workers in chunks ``(start, stop)`` in job order. Large chunks keep the
kernel busy (thousands of summary-only deliveries per compiled call, one archive segment and
one index transaction per chunk); small chunks keep the progress bar moving. The first chunks
hold :data:`FIRST_CHUNK` runs; each finished chunk tells the time a run takes, and the next
chunks are sized to take about ``target_s`` each (:data:`TARGET_CHUNK_S`, or
:data:`SUMMARY_TARGET_S` for summary-only jobs, whose per-chunk archive costs weigh more),
growing at most :data:`GROWTH` times per chunk, never past the job's cap. A chunk size given
by the caller is used as is.
"""

from __future__ import annotations

import math
from collections import deque

__all__ = ["FIRST_CHUNK", "GROWTH", "SUMMARY_TARGET_S", "TARGET_CHUNK_S", "Spans"]

#: runs in each of the first chunks (before any chunk has been timed)
FIRST_CHUNK = 4
#: the worker time a chunk is sized to take, s
TARGET_CHUNK_S = 0.5
#: the same for a summary-only job: a chunk is one segment and one index transaction, whose
#: costs (HDF5 datasets, the index pages a commit rewrites) are shared by more runs
SUMMARY_TARGET_S = 1.0
#: a chunk holds at most this many times the runs of the one before it
GROWTH = 4


class Spans:
    """The spans still to run: chunks given back (a lost worker's) first, then new ones.

    ``total``: the job's runs; ``cap``: the largest chunk; ``fixed``: use ``cap`` for every
    chunk (a chunk size the caller chose); ``target_s``: the worker time a chunk is sized to
    take, s.
    """

    def __init__(
        self, total: int, cap: int, *, fixed: bool = False, target_s: float = TARGET_CHUNK_S
    ) -> None:
        self.total = total
        self.cap = max(1, cap)
        self.fixed = fixed
        self.target_s = target_s
        self.size = self.cap if fixed else min(self.cap, FIRST_CHUNK)
        self.next = 0
        self._again: deque[tuple[int, int]] = deque()

    def __bool__(self) -> bool:
        return bool(self._again) or self.next < self.total

    def pop(self) -> tuple[int, int]:
        """The next span to run."""
        if self._again:
            return self._again.popleft()
        start = self.next
        self.next = min(start + self.size, self.total)
        return start, self.next

    def give_back(self, span: tuple[int, int]) -> None:
        """Run ``span`` again before any new span."""
        self._again.appendleft(span)

    def timed(self, runs: int, seconds: float) -> None:
        """A chunk of ``runs`` took ``seconds`` of worker time: size the next chunks."""
        if self.fixed or runs <= 0 or seconds <= 0.0 or not math.isfinite(seconds):
            return
        want = self.target_s * runs / seconds
        self.size = max(1, min(self.cap, GROWTH * self.size, int(want)))

    def left(self) -> list[tuple[int, int]]:
        """Every span not run, in job order (the runs not yet split into chunks as one)."""
        rest = [(self.next, self.total)] if self.next < self.total else []
        return sorted([*self._again, *rest])
