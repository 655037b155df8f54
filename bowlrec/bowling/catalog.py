"""Where the numbers of the curated ball catalog come from: typed, user-facing sources.

A :class:`Source` names a public document by publisher, title and address (URL), with a short
verbatim quote of the numbers it gives. Its ``kind`` says how close it is to the maker:

* ``manufacturer``: the maker's own spec sheet or product page;
* ``review``: a magazine, web or forum review that prints the specs (the maker's sheet was not
  found; the numbers are as the reviewer printed them);
* ``database``: a third-party compilation of spec sheets;
* ``paper``: a scientific publication;
* ``usbc``: a USBC rule or announcement (also as republished by others);
* ``illustrative``: values chosen for illustration, with no public source of their own.

Every line printed for a user is built by :func:`citation` (publisher, title, date, address,
and the kind when it is not the maker). :func:`internal_tags` finds note-keeping tags (e.g. a
bracketed upper-case key or a "Sec. 1.2" pointer) that must never reach user-facing text.
"""

from __future__ import annotations

import re
from typing import Literal

from pydantic import Field, model_validator

from bowlrec.spec._base import SpecModel, spec_error

__all__ = [
    "INTERNAL_TAG_PATTERNS",
    "Source",
    "SourceKind",
    "citation",
    "internal_tags",
]

SourceKind = Literal["manufacturer", "review", "database", "paper", "usbc", "illustrative"]

#: what a citation line adds after the address, per kind (empty for the maker's own sheet)
_KIND_LABEL: dict[str, str] = {
    "manufacturer": "",
    "review": "(review)",
    "database": "(spec database)",
    "paper": "(paper)",
    "usbc": "(USBC)",
    "illustrative": "(illustrative)",
}

#: note-keeping tags that user-facing text must not contain
INTERNAL_TAG_PATTERNS: tuple[re.Pattern[str], ...] = (
    re.compile(r"domain[- ]notes", re.IGNORECASE),
    re.compile(r"\[[A-Z][A-Z0-9]*(?:-[A-Z0-9]+)*\]"),
    re.compile(r"\bSec\.\s*\S"),
    re.compile(r"§"),
)


class Source(SpecModel):
    """One public source of a catalog entry's numbers."""

    kind: SourceKind = Field(description="How close the source is to the maker (module doc).")
    publisher: str = Field(min_length=1, description="Who published it, e.g. 'Bowlers Journal'.")
    title: str = Field(min_length=1, description="Title of the page, article or paper.")
    url: str = Field(default="", description="Address (http or https); empty only if none.")
    date: str = Field(default="", description="Publication date as printed, if printed.")
    quote: str = Field(default="", description="Short verbatim quote of the numbers.")

    @model_validator(mode="after")
    def _address(self) -> Source:
        """A URL is http(s); every kind but 'illustrative' has one."""
        if self.url and not re.match(r"https?://\S+$", self.url):
            raise spec_error(f"url = {self.url!r} must be an http:// or https:// address")
        if not self.url and self.kind != "illustrative":
            raise spec_error(f"a {self.kind!r} source needs its url ({self.title!r})")
        return self

    @property
    def is_review(self) -> bool:
        """True when the numbers come from a review rather than the maker."""
        return self.kind == "review"


def citation(source: Source) -> str:
    """One readable line: ``publisher — title (date) — url (kind)``."""
    title = f"{source.title} ({source.date})" if source.date else source.title
    parts = [source.publisher, title] + ([source.url] if source.url else [])
    label = _KIND_LABEL[source.kind]
    return " — ".join(parts) + (f" {label}" if label else "")


def internal_tags(text: str) -> list[str]:
    """Every note-keeping tag in ``text`` (empty when the text is clean)."""
    return [m.group(0) for pattern in INTERNAL_TAG_PATTERNS for m in pattern.finditer(text)]
