"""Slots for recorded simulations in the service: at most one per core at once, and a bounded
number of requests waiting for one (the others are refused at once, HTTP 503)."""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Iterator

from bowlrec.errors import ServerBusyError

__all__ = ["RecordingSlots", "ServerBusyError"]


class RecordingSlots:
    """At most ``slots`` recorded simulations at once, and at most ``WAITING_PER_SLOT`` x
    ``slots`` requests waiting for one; a request beyond that is refused at once
    (:class:`ServerBusyError`), so waiting requests never take every worker thread."""

    WAITING_PER_SLOT = 4

    def __init__(self, slots: int) -> None:
        self._slots = threading.BoundedSemaphore(slots)
        self._max_waiting = self.WAITING_PER_SLOT * slots
        self._waiting = 0
        self._lock = threading.Lock()

    @contextlib.contextmanager
    def slot(self) -> Iterator[None]:
        with self._lock:
            if self._waiting >= self._max_waiting:
                raise ServerBusyError(
                    f"the server is busy: {self._max_waiting} recorded runs are waiting to be "
                    "simulated; retry later, or record a summary only"
                )
            self._waiting += 1
        try:
            self._slots.acquire()
        finally:
            with self._lock:
                self._waiting -= 1
        try:
            yield
        finally:
            self._slots.release()
