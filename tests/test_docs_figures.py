"""Figures in the docs cannot drift: every accuracy figure a page quotes is the fidelity report's
(`make fidelity` writes docs/fidelity.json) and every speed figure the performance report's
(`make bench` writes docs/performance.json), quoted through benchmarks/quoted.py's markers and
set from the report whenever it is written; and every hardware parameter of the built-in levels
says where its value comes from."""

import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

import fidelity  # noqa: E402  (the report's own reader of level comments)
import quoted  # noqa: E402  (the one reader and writer of quoted figures)

REPORT = quoted.load("f")
REPORTS = {which: quoted.load(which) for which in quoted.REPORTS}


def test_the_docs_quote_the_reports_and_nothing_else():
    found = quoted.quotes()
    fid = [q for q in found if q[1] == "f"]
    perf = [q for q in found if q[1] == "p"]
    assert len(fid) >= 20 and len({page for page, *_ in fid}) >= 3  # the accuracy pages quote it
    assert len(perf) >= 10 and {"docs/performance.md", "docs/accuracy.md"} <= {page for page, *_ in perf}
    for page, which, key, stat, value in found:
        report = REPORTS[which]
        assert key in report and stat in report[key], (
            f"{page} quotes {key}:{stat}, which {quoted.REPORTS[which].name} has not"
        )
        digits = len(value.partition(".")[2])
        assert value == quoted.shown(report[key][stat], digits), (
            f"{page}: {key} {stat} is {report[key][stat]}, not {value}"
        )


def test_a_marker_that_is_not_read_fails_rather_than_hides_a_figure():
    """A marker misspelt (another report letter, a closing tag of the wrong report) is not a
    quote: no page may carry one, since its figure would be held to nothing."""
    loose = re.compile(r"<!--/?[a-z]:[^>]*-->|<!--/[a-z]-->")
    for page in quoted.pages():
        text = quoted.QUOTED.sub("", page.read_text(encoding="utf-8"))
        assert not loose.findall(text), f"{page}: markers no report reads: {loose.findall(text)[:3]}"


def test_the_speed_figures_are_the_performance_reports():
    """The pages that state speed figures quote them: the ToTal solver's figures, the match
    ratios and the rendering rates appear nowhere as hand-written numbers. The decision records
    are dated: they keep what was measured when each decision was taken."""
    hand = re.compile(r"(?<![->\w.])\d[\d.]* (?:us per call|M solves/s|frames/s|x real time)")
    for page in quoted.pages():
        if page.name == "fidelity.md" or page.parent.name == "decisions":
            continue
        text = quoted.QUOTED.sub("QUOTED", page.read_text(encoding="utf-8"))
        assert not hand.findall(text), (
            f"{page.relative_to(ROOT)}: speed figures not quoted from a report: {hand.findall(text)}"
        )


def test_the_report_passes_every_row_it_writes():
    failed = [key for key, row in REPORT.items() if not row["ok"]]
    assert not failed, f"rows outside their band in docs/fidelity.json: {failed}"
    text = (ROOT / "docs" / "fidelity.md").read_text()
    assert "**no**" not in text and "## Sensitivity" in text


@pytest.mark.parametrize("level, key, value, comment", fidelity.level_parameters(), ids=lambda v: str(v)[:20])
def test_every_hardware_parameter_names_its_source_or_says_it_is_ours(level, key, value, comment):
    assert '"' in comment or "ours" in comment, f"levels/{level}.yaml: {key}: {value} gives no source and no reason"


def test_a_figure_is_set_to_its_report_with_the_decimals_it_was_quoted_with():
    report = {"a.b": {"median": 2.04567, "p5": 1.5, "p95": 3.0}}
    text = "RMS <!--f:a.b:median-->9.9<!--/f--> mm, from <!--f:a.b:p5-->0.000<!--/f-->, <!--p:a.b:p5-->7<!--/p-->"
    assert (
        quoted.requote(text, "f", report)
        == "RMS <!--f:a.b:median-->2.0<!--/f--> mm, from <!--f:a.b:p5-->1.500<!--/f-->, <!--p:a.b:p5-->7<!--/p-->"
    )
    assert quoted.requote(text, "p", report).endswith("<!--p:a.b:p5-->2<!--/p-->")
