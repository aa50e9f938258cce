"""Docs a reader can hold: the pages written by hand and the decision records together stay
within 25,000 words (the generated reports, which say "Do not edit by hand", apart), and each
decision record is short."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
GENERATED = re.compile(r"Do\s+not\s+edit\s+by\s+hand")


def written() -> dict[Path, int]:
    """Each hand-written page of docs/ (decision records included) and its words, as `wc -w` counts."""
    out = {}
    for page in sorted((ROOT / "docs").rglob("*.md")):
        text = page.read_text(encoding="utf-8")
        if not GENERATED.search(text[:1000]):
            out[page] = len(text.split())
    return out


def test_the_generated_reports_are_told_apart_and_the_rest_counted():
    pages = {p.relative_to(ROOT).as_posix() for p in written()}
    assert "docs/fidelity.md" not in pages and "docs/baselines.md" not in pages
    assert {"docs/index.md", "docs/controllers.md", "docs/decisions/README.md"} <= pages


def test_the_docs_stay_within_25000_words():
    assert sum(written().values()) <= 25_000


def test_each_decision_record_is_short():
    records = {p.name: n for p, n in written().items() if p.parent.name == "decisions" and p.name[:4].isdigit()}
    assert len(records) >= 48
    assert {name: n for name, n in records.items() if n > 150} == {}
