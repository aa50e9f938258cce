"""Markdown the product writes renders team, level and file text as that text: no raw HTML,
no link, no emphasis, no extra table cell. Judged twice, independently of the writer: by
counting a table's unescaped `|` and `<` by hand, and by GitHub's own renderer (cmark-gfm,
with raw HTML let through, as GitHub renders it before sanitizing)."""

import html
import json
import re

import cmarkgfm
from cmarkgfm.cmark import Options
from helpers import MINI_LEVEL, run_cli, secret_file
from hypothesis import given
from hypothesis import strategies as st

from referee.terminal import markdown_text, safe

HOSTILE_TEAM = "<img src=x onerror=alert(1)>|**bold**|[x](javascript:alert(1))"
HOSTILE_LEVEL = "<b>lvl</b>|`x`_&amp;"
LOUD = """from robots.api import Controller


class Loud(Controller):
    def step(self, obs):
        raise ValueError("<b>|**x**|</b>")
"""
LOUD_FAULT = "1 exception: in step: ValueError: <b>|**x**|</b> (loud.py:6)"  # the raise is line 6
TABLE_TAGS = {"table", "thead", "tbody", "tr", "th", "td", "h1", "p", "a"}  # `a`: GitHub's autolinks only


def unescaped(line: str, char: str) -> int:
    """How many times `char` stands in `line` not escaped by a backslash (one that is not
    itself escaped)."""
    count, i = 0, 0
    while i < len(line):
        if line[i] == "\\":
            i += 2
            continue
        count += line[i] == char
        i += 1
    return count


def render(markdown: str) -> str:
    return cmarkgfm.github_flavored_markdown_to_html(markdown, options=Options.CMARK_OPT_UNSAFE)


def cells(page: str) -> list[list[str]]:
    """Each rendered table row's cells, as the text a reader sees (autolinks' text kept)."""
    return [
        [html.unescape(re.sub(r"</?a\b[^>]*>", "", c)) for c in re.findall(r"<t[hd]>(.*?)</t[hd]>", row, re.S)]
        for row in re.findall(r"<tr>(.*?)</tr>", page, re.S)
    ]


def check_table(markdown: str, columns: int) -> list[list[str]]:
    """The Markdown's table has `columns` cells in every row, whichever way it is read, and
    nothing in it, nor elsewhere in the file, is raw HTML; returns the rendered cells."""
    rows = [line for line in markdown.splitlines() if line.startswith("|")]
    assert rows and all(unescaped(row, "|") == columns + 1 for row in rows), rows
    assert unescaped(markdown, "<") == 0 and unescaped(markdown, ">") == 0
    page = render(markdown)
    assert set(re.findall(r"<(\w+)", page)) <= TABLE_TAGS, page
    assert all(href.startswith(("http://", "https://", "mailto:")) for href in re.findall(r'href="([^"]*)"', page))
    rendered = cells(page)
    assert len(rendered) == len(rows) - 1 and all(len(r) == columns for r in rendered), rendered  # less the rule
    return rendered


@given(st.text(max_size=300))
def test_any_text_renders_as_itself_in_one_cell(text):
    markdown = f"| team | score |\n|---|---|\n| {markdown_text(text)} | 1 |\n"
    (_, (cell, score)) = check_table(markdown, 2)
    assert cell == safe(text).strip(" ") and score == "1"


def test_a_paragraph_renders_as_itself_too():
    page = render(f"Note: {markdown_text(HOSTILE_TEAM + ' *a* _b_ ~~c~~ `d`', 500)}\n")
    assert set(re.findall(r"<(\w+)", page)) == {"p"}
    assert html.unescape(re.sub(r"</?p>", "", page)).strip() == f"Note: {HOSTILE_TEAM} *a* _b_ ~~c~~ `d`"


def test_a_hostile_team_and_level_in_graded_and_tournament_markdown(shared_dir):
    (shared_dir / "level.yaml").write_text(MINI_LEVEL.replace("name: mini", f"name: {json.dumps(HOSTILE_LEVEL)}"))
    (shared_dir / f"{HOSTILE_TEAM}.py").write_text("from robots.controllers.dead_reckoning import DeadReckoning as B\n")
    (shared_dir / "loud.py").write_text(LOUD)  # a fault whose message is hostile text: its cell is that text
    for p in shared_dir.iterdir():
        p.chmod(0o755)
    refused = "ref:<i>nobody</i>"  # a team refused: its note is escaped too
    graded = run_cli(
        "grade", "level.yaml", "--team", f"{HOSTILE_TEAM}.py", "--team", "loud.py", "--team", refused, "--seeds", "1",
        "--workers", "1", "--db", "g.sqlite", "--out", "lb.csv", "--secret-file", secret_file("markdown"),
        cwd=shared_dir,
    )  # fmt: skip
    assert graded.returncode == 0, graded.stderr
    board = (shared_dir / "lb.md").read_text()
    assert graded.stdout == board  # what grade prints is the file
    header, *rows = check_table(board, 8)
    rows = {r[1]: r for r in rows}
    assert header[:2] == ["level", "team"] and rows[f"{HOSTILE_TEAM}.py"][0] == HOSTILE_LEVEL
    assert header[-1] == "faults" and rows["loud.py"][-1] == LOUD_FAULT
    assert rows[f"{HOSTILE_TEAM}.py"][-1].startswith(f"1 load: {HOSTILE_TEAM}.py defines no ")  # its load fault
    assert "Note: refused team ref:<i>nobody</i>" in html.unescape(render(board))

    played = run_cli(
        "tournament", "level.yaml", "--team", f"{HOSTILE_TEAM}.py", "--team", "loud.py", "--team", "ref:idle",
        "--workers", "1",
        "--db", "t.sqlite", "--out", "site", "--secret-file", secret_file("markdown"),
        cwd=shared_dir,
    )  # fmt: skip
    assert played.returncode == 0, played.stderr
    standings = (shared_dir / "site" / "standings.md").read_text()
    header, *teams = check_table(standings, 7)
    assert header[:2] == ["rank", "team"]
    assert sorted(t[1] for t in teams) == sorted([f"{HOSTILE_TEAM}.py", "loud.py", "ref:idle"])
    heats = next(int(t[5]) for t in teams if t[1] == "loud.py")
    assert f"Faults of loud.py: {LOUD_FAULT.replace('1 ', f'{heats} ', 1)}" in html.unescape(render(standings))
    assert f"<h1>Tournament: {html.escape(HOSTILE_LEVEL, quote=False)}</h1>" in render(standings)
