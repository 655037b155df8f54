"""The runs table of the web page: filters from a query string, one page of the index, the
columns with their units. Reads only the archive's index, so a page of a million-run archive
costs one ordered, limited SELECT and one capped COUNT (``benchmarks/results/web.md``)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any
from urllib.parse import urlencode

from bowlrec.archive import Archive
from bowlrec.archive.index import INDEX_COLUMNS, cell_text
from bowlrec.errors import InputError

__all__ = [
    "COUNT_CAP",
    "PAGE_SIZES",
    "RUN_COLUMNS",
    "RunsQuery",
    "RunsPage",
    "runs_page",
]

#: the table's columns: (header, index column, scale to the header's unit, format); hook and
#: pocket are the archive's signed lane-frame values (+: toward the left gutter)
RUN_COLUMNS: tuple[tuple[str, str, float, str], ...] = (
    ("created (UTC)", "created_at", 1.0, ""),
    ("name", "name", 1.0, ""),
    ("ball", "ball", 1.0, ""),
    ("pattern", "pattern", 1.0, ""),
    ("outcome", "outcome", 1.0, ""),
    ("leave", "leave", 1.0, ""),
    ("speed (m/s)", "speed_mps", 1.0, ".2f"),
    ("revs (rpm)", "rev_rate_rpm", 1.0, ".0f"),
    ("slide (m)", "slide_m", 1.0, ".3f"),
    ("hook (cm, +left)", "hook_m", 100.0, ".2f"),
    ("pocket (deg, +left)", "pocket_deg", 1.0, ".2f"),
    ("record", "record", 1.0, ""),
)
#: rows per page offered; the first is the default
PAGE_SIZES = (50, 100, 200, 500)
#: counting stops here: a broad filter of a million runs reads "100,000+ runs"
COUNT_CAP = 100_000
#: range inputs of the filter form: (parameter stem, index column, scale from the form's unit)
RANGES: tuple[tuple[str, str, float, str], ...] = (
    ("speed", "speed_mps", 1.0, "speed (m/s)"),
    ("hook", "hook_m", 0.01, "hook (cm)"),
    ("pocket", "pocket_deg", 1.0, "pocket (deg)"),
)


def _text(params: Mapping[str, str], key: str) -> str | None:
    value = params.get(key, "").strip()
    return value or None


def _number(params: Mapping[str, str], key: str, what: str) -> float | None:
    text = _text(params, key)
    if text is None:
        return None
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"{what}: {text[:40]!r} is not a number") from None
    if not math.isfinite(value):
        raise InputError(f"{what}: {text[:40]!r} is not a finite number")
    return value


@dataclass(frozen=True)
class RunsQuery:
    """The filters, order and page of the runs table (the query string of ``/``)."""

    outcome: str | None = None
    ball: str | None = None
    pattern: str | None = None
    name: str | None = None
    #: conditions as ``runs list --where`` takes them (``hook_m>=0.1``), one per item
    where: tuple[str, ...] = ()
    #: range bounds by RANGES stem: (low, high) in the form's units
    ranges: Mapping[str, tuple[float | None, float | None]] = field(default_factory=dict)
    sort: str = "-created_at"
    page: int = 1
    per_page: int = PAGE_SIZES[0]

    @classmethod
    def parse(cls, params: Mapping[str, str]) -> RunsQuery:
        """From a query string's parameters; :class:`InputError` naming a bad one."""
        where_text = params.get("where", "")
        where = tuple(w.strip() for w in where_text.replace(";", ",").split(",") if w.strip())
        ranges = {
            stem: (
                _number(params, f"{stem}_min", f"{label} from"),
                _number(params, f"{stem}_max", f"{label} to"),
            )
            for stem, _, _, label in RANGES
        }
        sort = _text(params, "sort") or "-created_at"
        if sort.lstrip("-") not in INDEX_COLUMNS:
            raise InputError(f"sort: cannot sort by {sort[:40]!r}; sort by an index column")
        page = _number(params, "page", "page")
        page = 1 if page is None else page
        per_page = _number(params, "per_page", "per_page")
        per_page = PAGE_SIZES[0] if per_page is None else per_page
        if int(per_page) not in PAGE_SIZES:
            raise InputError(
                f"per_page: {per_page:g} is not offered; one of {', '.join(map(str, PAGE_SIZES))}"
            )
        if page < 1 or page != int(page):
            raise InputError(f"page: {page:g} is not a page number (1, 2, ...)")
        return cls(
            outcome=_text(params, "outcome"),
            ball=_text(params, "ball"),
            pattern=_text(params, "pattern"),
            name=_text(params, "name"),
            where=where,
            ranges=ranges,
            sort=sort,
            page=int(page),
            per_page=int(per_page),
        )

    def conditions(self) -> list[str]:
        """``where`` plus the range bounds as index conditions (SI units)."""
        out = list(self.where)
        for stem, column, scale, _ in RANGES:
            low, high = self.ranges.get(stem, (None, None))
            if low is not None:
                out.append(f"{column}>={low * scale!r}")
            if high is not None:
                out.append(f"{column}<={high * scale!r}")
        return out

    def filters(self) -> dict[str, Any]:
        """Keyword arguments of :meth:`Archive.list_runs` / :meth:`Archive.count_runs`."""
        return {
            "ball": self.ball,
            "pattern": self.pattern,
            "outcome": self.outcome,
            "name": self.name,
            "where": self.conditions(),
        }

    def params(self, **changes: Any) -> dict[str, str]:
        """The query string's parameters (defaults left out), with ``changes`` applied."""
        values: dict[str, Any] = {
            "outcome": self.outcome,
            "ball": self.ball,
            "pattern": self.pattern,
            "name": self.name,
            "where": ", ".join(self.where) or None,
            "sort": None if self.sort == "-created_at" else self.sort,
            "page": None if self.page == 1 else self.page,
            "per_page": None if self.per_page == PAGE_SIZES[0] else self.per_page,
        }
        for stem, (low, high) in self.ranges.items():
            values[f"{stem}_min"] = low
            values[f"{stem}_max"] = high
        values.update(changes)
        return {k: _shown(v) for k, v in values.items() if v is not None and v != ""}

    def url(self, **changes: Any) -> str:
        """``/?...``: this query with ``changes`` (e.g. ``page=3``, ``sort="-hook_m"``)."""
        query = urlencode(self.params(**changes))
        return f"/?{query}" if query else "/"

    def sort_url(self, column: str) -> str:
        """The URL sorting by ``column``: descending first, ascending when already so."""
        new = column if self.sort == f"-{column}" else f"-{column}"
        return self.url(sort=new, page=None)


@dataclass(frozen=True)
class RunsPage:
    """One page of the table: its rows, the count of matching runs (capped) and the pages."""

    query: RunsQuery
    rows: Sequence[Mapping[str, Any]]
    total: int
    capped: bool

    @property
    def pages(self) -> int:
        return max(1, math.ceil(self.total / self.query.per_page))

    @property
    def first(self) -> int:
        """1-based number of the page's first row."""
        return (self.query.page - 1) * self.query.per_page + 1

    def cell(self, row: Mapping[str, Any], column: str, scale: float, fmt: str) -> str:
        """A cell as shown: numbers in the header's unit, the ball as ``name@version``."""
        return cell_text(row, column, scale, fmt)


def _shown(value: Any) -> str:
    """A query value as text: floats in their shortest exact form, ``12`` for ``12.0``."""
    if isinstance(value, float):
        return str(int(value)) if value.is_integer() else repr(value)
    return str(value)


def runs_page(archive: Archive, query: RunsQuery) -> RunsPage:
    """The page of runs ``query`` asks for (raises :class:`InputError` for a bad filter)."""
    filters = query.filters()
    offset = (query.page - 1) * query.per_page
    rows = archive.list_runs(**filters, order_by=query.sort, limit=query.per_page, offset=offset)
    total = archive.count_runs(**filters, cap=COUNT_CAP)
    return RunsPage(query, rows, total, capped=total >= COUNT_CAP)
