"""The archive contract (tests/helpers/archive_contract.py) run against the Archive facade and,
directly, against the middle modules on an ArchiveDir (no facade): both keep every check."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from helpers.archive_contract import ArchiveContract, contract_runs  # noqa: F401 - a fixture

from bowlrec.archive import Archive, compaction, maintenance, queries, reading, repair, writing
from bowlrec.archive.balls import BallLibrary
from bowlrec.archive.directory import ArchiveDir
from bowlrec.archive.index import Filter
from bowlrec.sinks import RunData


class TestArchiveFacade(ArchiveContract):
    def open(self, root: Path) -> Any:
        return Archive(root)


class ModuleArchive:
    """The archive's middle modules called directly on an :class:`ArchiveDir`, under the
    facade's method names (what the contract calls)."""

    def __init__(self, root: Path) -> None:
        self.d = ArchiveDir(root)
        self.root = self.d.root
        self.balls = BallLibrary(self.d)

    def builder(self) -> Any:
        return writing.new_builder()

    def record(self, run: RunData, *, wall_time_s: float) -> Any:
        return writing.make_record(run, self.balls.refs_by_sha, wall_time_s=wall_time_s)

    def seal(self, builder: Any) -> Any:
        return writing.seal(self.d, builder)

    def register(self, segments: Iterable[Any]) -> tuple[int, int]:
        return writing.register(self.d, segments)

    def add(self, run: RunData, *, wall_time_s: float) -> writing.AddResult:
        return writing.add(self.d, run, self.balls.refs_by_sha, wall_time_s=wall_time_s)

    def locate(self, run_id: str) -> tuple[str, int, Path] | None:
        return queries.locate(self.d, run_id)

    def has_run(self, run_id: str) -> bool:
        return queries.locate(self.d, run_id) is not None

    def resolve_id(self, run_id: str) -> str:
        return queries.resolve_id(self.d, run_id)

    def load(self, run_id: str) -> Any:
        return reading.load(self.d, run_id)

    def run_data(self, run_id: str) -> RunData:
        return reading.run_data(self.d, run_id)

    def export(self, run_id: str, dest: Path) -> Path:
        return reading.export(self.d, run_id, dest)

    def list_runs(
        self,
        *,
        order_by: str = "created_at",
        limit: int | None = None,
        offset: int = 0,
        where: Sequence[Filter | str] = (),
        **filters: Any,
    ) -> list[dict[str, Any]]:
        found = queries.run_filters(self.d, where=where, **filters)
        return queries.list_runs(self.d, *found, order_by=order_by, limit=limit, offset=offset)

    def count_runs(
        self, *, cap: int | None = None, where: Sequence[Filter | str] = (), **filters: Any
    ) -> int:
        return queries.count_runs(self.d, *queries.run_filters(self.d, where=where, **filters), cap)

    def row(self, run_id: str) -> dict[str, Any]:
        rid = queries.resolve_id(self.d, run_id)
        return queries.rows(self.d, [rid])[rid]

    def rows(self, run_ids: Iterable[str]) -> dict[str, dict[str, Any]]:
        return queries.rows(self.d, run_ids)

    def damaged(self) -> list[dict[str, Any]]:
        return queries.damaged(self.d)

    def info(self) -> dict[str, Any]:
        return queries.info(self.d)

    def __len__(self) -> int:
        return queries.count(self.d)

    def remove(self, run_id: str) -> str:
        return maintenance.remove(self.d, run_id)

    def set_aside(self, run_id: str, segment_id: str, reason: str) -> None:
        maintenance.set_aside(self.d, run_id, segment_id, reason)

    def recover(self) -> dict[str, int]:
        return maintenance.recover(self.d)

    def reindex(self) -> int:
        return int(maintenance.reindex(self.d)["runs"])

    def compact(self) -> dict[str, int]:
        return compaction.compact(self.d)

    def repair(self) -> dict[str, Any]:
        return repair.repair(self.d)

    def close(self) -> None:
        self.d.close()


class TestMiddleModules(ArchiveContract):
    def open(self, root: Path) -> Any:
        return ModuleArchive(root)
