"""The docs' accuracy figures are the fidelity report's (`make fidelity` writes docs/fidelity.json
and sets every figure a page quotes from it), and every hardware parameter of the built-in
levels says where its value comes from."""

import json
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

import fidelity  # noqa: E402  (the report's own reader of quotes and level comments)

REPORT = json.loads((ROOT / "docs" / "fidelity.json").read_text())


def quotes() -> list[tuple[str, str, str, str]]:
    """(page, key, stat, value as quoted) of every figure a page quotes from the report."""
    out = []
    for page in fidelity.quoted_pages():
        for m in fidelity.QUOTED.finditer(page.read_text(encoding="utf-8")):
            out.append((page.name, *m.groups()))
    return out


def test_the_docs_quote_the_report_and_nothing_else():
    found = quotes()
    assert len(found) >= 20 and len({page for page, *_ in found}) >= 3  # the accuracy pages quote it
    for page, key, stat, value in found:
        assert key in REPORT, f"{page} quotes {key}, which the report does not have"
        digits = len(value.partition(".")[2])
        assert value == f"{REPORT[key][stat]:.{digits}f}", f"{page}: {key} {stat} is {REPORT[key][stat]}, not {value}"


def test_the_report_passes_every_row_it_writes():
    failed = [key for key, row in REPORT.items() if not row["ok"]]
    assert not failed, f"rows outside their band in docs/fidelity.json: {failed}"
    text = (ROOT / "docs" / "fidelity.md").read_text()
    assert "**no**" not in text and "## Sensitivity" in text


@pytest.mark.parametrize("level, key, value, comment", fidelity.level_parameters(), ids=lambda v: str(v)[:20])
def test_every_hardware_parameter_names_its_source_or_says_it_is_ours(level, key, value, comment):
    assert '"' in comment or "ours" in comment, f"levels/{level}.yaml: {key}: {value} gives no source and no reason"


def test_a_figure_is_set_to_the_report_with_the_decimals_it_was_quoted_with():
    report = {"a.b": {"median": 2.04567, "p5": 1.5, "p95": 3.0}}
    text = "RMS <!--f:a.b:median-->9.9<!--/f--> mm, from <!--f:a.b:p5-->0.000<!--/f-->"
    assert (
        fidelity.requote(text, report) == "RMS <!--f:a.b:median-->2.0<!--/f--> mm, from <!--f:a.b:p5-->1.500<!--/f-->"
    )
