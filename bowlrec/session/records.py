"""A session's per-shot state as archive record groups (archive format 2.1).

Every shot of a session is an archived run carrying two per-run record groups
(docs/archive-format.md, "Per-run record groups"):

* ``oil/``: the lane's oil grid after the shot, one row per cell: ``x_from_ft``, ``x_to_ft``
  (distance from the foul line), ``y_from_boards``, ``y_to_boards`` (board widths from the
  right gutter) and ``volume_ul`` (µL in the cell);
* ``session/``: ``state_json``, the UTF-8 bytes of a compact JSON object: the session ID, the
  shot's place (shot, game, frame, ball, bowler), every bowler's ball load (µL on the cover at
  its next release) and the shot's oil ledger (µL); in a session scored by the pins also the
  ball's ``pinfall`` (count), the pins ``standing`` after it (pin numbers), where they stand
  (``moved``: pin number -> [dx, dy], the base centre's offset from its spot, m, lane frame:
  +x toward the pit, +y left), the ``leave`` in bowlers' words and the bowler's game
  ``score`` after the ball (pins, bonuses counted as far as the balls thrown give them).

Both are what a resumed session needs to continue after the shot without simulating it again.
A state written without the pins' keys (the pocket-window rule, or a session stored before
sessions had pins) reads with ``pinfall``, ``standing``, ``leave`` and ``score`` None and no
``moved`` pins.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bowlrec.bowling.oil import OilGrid
from bowlrec.bowling.oil_transfer import TransferLedger

__all__ = ["ShotState", "oil_from_records", "oil_records", "state_records"]

OIL_GROUP = "oil"
STATE_GROUP = "session"


@dataclass(frozen=True)
class ShotState:
    """What a session carries from one shot to the next, and where the shot was."""

    session_id: str
    shot: int
    game: int
    frame: int
    ball: int
    bowler: str
    #: every bowler's ball load at its next release (µL)
    loads_ul: dict[str, float]
    ledger: TransferLedger
    #: pins knocked down by the ball (None: the pocket-window rule, no pins)
    pinfall: int | None = None
    #: pins standing after the ball, ascending (None without pins)
    standing: tuple[int, ...] | None = None
    #: standing pins off their spots after the ball: pin -> (dx, dy) (m, lane frame)
    moved: dict[int, tuple[float, float]] = field(default_factory=dict)
    #: the standing pins in bowlers' words (None without pins)
    leave: str | None = None
    #: the bowler's game score after the ball (None without pins)
    score: int | None = None

    def to_json(self) -> bytes:
        """Compact JSON (UTF-8) with the ledger's fields by name; the pins' keys only with
        pins (a pocket-window shot's state is what it was before sessions had pins)."""
        data: dict[str, Any] = {
            "session_id": self.session_id,
            "shot": self.shot,
            "game": self.game,
            "frame": self.frame,
            "ball": self.ball,
            "bowler": self.bowler,
            "loads_ul": self.loads_ul,
            "ledger": {k: getattr(self.ledger, k) for k in _LEDGER_FIELDS},
        }
        if self.pinfall is not None:
            data.update(
                {
                    "pinfall": self.pinfall,
                    "standing": list(self.standing or ()),
                    "moved": {str(p): list(xy) for p, xy in self.moved.items()},
                    "leave": self.leave,
                    "score": self.score,
                }
            )
        return json.dumps(data, sort_keys=True, separators=(",", ":")).encode()

    @classmethod
    def from_json(cls, text: bytes) -> ShotState:
        d = json.loads(text)
        return cls(
            session_id=d["session_id"],
            shot=int(d["shot"]),
            game=int(d["game"]),
            frame=int(d["frame"]),
            ball=int(d["ball"]),
            bowler=d["bowler"],
            loads_ul={k: float(v) for k, v in d["loads_ul"].items()},
            ledger=TransferLedger(**{k: float(d["ledger"][k]) for k in _LEDGER_FIELDS}),
            pinfall=None if d.get("pinfall") is None else int(d["pinfall"]),
            standing=None if d.get("standing") is None else tuple(int(p) for p in d["standing"]),
            moved={int(p): (float(xy[0]), float(xy[1])) for p, xy in d.get("moved", {}).items()},
            leave=d.get("leave"),
            score=None if d.get("score") is None else int(d["score"]),
        )


_LEDGER_FIELDS = (
    "lifted_ul",
    "deposited_ul",
    "ball_load_before_ul",
    "ball_load_after_ul",
    "lane_before_ul",
    "lane_after_ul",
    "absorbed_ul",
)


def oil_records(grid: OilGrid) -> dict[str, NDArray[Any]]:
    """The ``oil`` record group of a grid: one row per cell, row-major (along the lane first)."""
    x0, b0 = np.meshgrid(grid.x_edges_ft[:-1], grid.board_edges[:-1], indexing="ij")
    x1, b1 = np.meshgrid(grid.x_edges_ft[1:], grid.board_edges[1:], indexing="ij")
    return {
        "x_from_ft": x0.ravel().astype(np.float64),
        "x_to_ft": x1.ravel().astype(np.float64),
        "y_from_boards": b0.ravel().astype(np.float64),
        "y_to_boards": b1.ravel().astype(np.float64),
        "volume_ul": np.ascontiguousarray(grid.volume_ul, dtype=np.float64).ravel(),
    }


def oil_from_records(rows: dict[str, NDArray[Any]]) -> OilGrid:
    """The grid an ``oil`` record group holds (the inverse of :func:`oil_records`, exact)."""
    xe = np.unique(np.concatenate([rows["x_from_ft"], rows["x_to_ft"]]))
    be = np.unique(np.concatenate([rows["y_from_boards"], rows["y_to_boards"]]))
    nx, nb = xe.size - 1, be.size - 1
    volume = np.asarray(rows["volume_ul"], dtype=np.float64)
    if volume.size != nx * nb:
        raise ValueError(f"an oil record of {volume.size} cells is not a {nx} x {nb} grid")
    return OilGrid(xe, be, volume.reshape(nx, nb).copy())


def state_records(state: ShotState) -> dict[str, NDArray[Any]]:
    """The ``session`` record group of a shot: its state JSON as bytes (one row per byte)."""
    return {"state_json": np.frombuffer(state.to_json(), dtype=np.uint8).copy()}


def shot_records(grid: OilGrid, state: ShotState) -> dict[str, dict[str, NDArray[Any]]]:
    """Both record groups of a shot, as :meth:`bowlrec.archive.Archive.add` takes them."""
    return {OIL_GROUP: oil_records(grid), STATE_GROUP: state_records(state)}


def state_from_records(records: dict[str, dict[str, NDArray[Any]]]) -> ShotState:
    """The :class:`ShotState` of an archived shot's record groups."""
    return ShotState.from_json(np.asarray(records[STATE_GROUP]["state_json"]).tobytes())
