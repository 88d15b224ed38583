"""What a report says, independent of how it is shown (HTML page, markdown summary)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd


@dataclass(frozen=True)
class Figure:
    """An image file of the report (PNG plot or GIF animation)."""

    filename: str
    title: str
    caption: str
    data: bytes
    mime: str = "image/png"


@dataclass(frozen=True)
class Table:
    """A table of text cells shown in the report (its numbers are also in a CSV next to it)."""

    title: str
    headers: list[str]
    rows: list[list[str]]
    caption: str = ""


@dataclass(frozen=True)
class Section:
    """A titled group of figures, optionally with paragraphs of text and tables before them."""

    title: str
    figures: list[Figure]
    intro: str = ""
    paragraphs: list[str] = field(default_factory=list)
    tables: list[Table] = field(default_factory=list)


@dataclass
class Report:
    """Everything computed for one run directory; written out by :mod:`.html` and :mod:`.markdown`."""

    run_path: Path
    out: Path
    title: str
    facts: list[tuple[str, str]]
    notes: list[str]
    summary: pd.DataFrame  # the per-designer table (stats/summary.py), which headers and rows show
    headers: list[str]
    rows: list[list[str]]
    sections: list[Section] = field(default_factory=list)
    tables: list[tuple[str, str]] = field(default_factory=list)  # (file name, what it holds)
    definitions: list[tuple[str, str]] = field(default_factory=list)

    @property
    def figures(self) -> list[Figure]:
        return [f for s in self.sections for f in s.figures]
