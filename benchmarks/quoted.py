"""Figures the docs quote from a committed report, so that a figure in prose cannot drift from
what was measured. A page quotes a figure as

    <!--f:KEY:STAT-->VALUE<!--/f-->   docs/fidelity.json's REPORT[KEY][STAT] (`make fidelity`)
    <!--p:KEY:STAT-->VALUE<!--/p-->   docs/performance.json's REPORT[KEY][STAT] (`make bench`)

with as many decimals as it wants shown. Writing a report sets every figure quoted from it
(`requote`); tests/test_docs_figures.py holds every quote to its report.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
REPORTS = {"f": ROOT / "docs" / "fidelity.json", "p": ROOT / "docs" / "performance.json"}
QUOTED = re.compile(r"<!--(?P<report>[fp]):(?P<key>[\w.-]+):(?P<stat>\w+)-->(?P<value>-?[0-9.]+)<!--/(?P=report)-->")

Report = dict[str, dict[str, Any]]


def pages() -> list[Path]:
    """The pages that may quote a report: README.md and docs/**/*.md."""
    return [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]


def shown(value: float, digits: int) -> str:
    """A figure as a page shows it, to `digits` decimals."""
    return f"{value:.{digits}f}"


def requote(text: str, which: str, report: Report) -> str:
    """`text` with every figure it quotes from report `which` ("f" or "p") set to the report's
    value, to the decimals it was quoted with."""

    def figure(m: re.Match) -> str:
        if m["report"] != which:
            return m[0]
        digits = len(m["value"].partition(".")[2])
        return f"<!--{which}:{m['key']}:{m['stat']}-->{shown(report[m['key']][m['stat']], digits)}<!--/{which}-->"

    return QUOTED.sub(figure, text)


def requote_pages(which: str, report: Report) -> list[Path]:
    """Set every page's figures from report `which`; the pages changed."""
    changed = []
    for page in pages():
        text = page.read_text(encoding="utf-8")
        new = requote(text, which, report)
        if new != text:
            page.write_text(new, encoding="utf-8")
            changed.append(page)
    return changed


def quotes() -> list[tuple[str, str, str, str, str]]:
    """(page, report, key, stat, value as quoted) of every figure the pages quote."""
    return [
        (str(page.relative_to(ROOT)), m["report"], m["key"], m["stat"], m["value"])
        for page in pages()
        for m in QUOTED.finditer(page.read_text(encoding="utf-8"))
    ]


def load(which: str) -> Report:
    """A committed report."""
    return json.loads(REPORTS[which].read_text(encoding="utf-8"))
