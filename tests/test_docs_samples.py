"""Output samples in the docs keep the program's shape. A ```text block in README.md or docs/
is either checked character for character (`<!-- output: COMMAND -->`, tests/test_docs_run.py)
or marked `<!-- sample: NAME -->`: a sample whose figures vary (a secret, a seed), held here
to what the program prints for NAME, with every number and every CAPITALS placeholder read
as "some value" and a `...` line as "more lines like these"."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from helpers import MINI_LEVEL, edited, run_cli, variant

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
BLOCK = re.compile(r"^(?:<!--\s*(?P<marker>[^\n]*?)\s*-->\n)?```text\n(?P<text>.*?)^```\s*$", re.S | re.M)
GENERATED = re.compile(r"Do\s+not\s+edit\s+by\s+hand")


def samples() -> dict[str, str]:
    """Every `sample:` block's text, by name."""
    out = {}
    for page in PAGES:
        for m in BLOCK.finditer(page.read_text(encoding="utf-8")):
            marker = m["marker"] or ""
            if marker.startswith("sample:"):
                out[marker.partition(":")[2].strip()] = m["text"]
    return out


NUMBER = r"-?\d+(?:\.\d+)?"


def line_pattern(line: str) -> str:
    """A sample line as a pattern: a placeholder in capitals stands for any word, a number for
    any number, a run of spaces for any."""
    words = []
    for word in line.split():
        if re.fullmatch(r"[A-Z]{3,}", word):
            words.append(r"\S+")
        else:
            words.append(NUMBER.join(re.escape(part) for part in re.split(NUMBER, word)))
    return r"[ \t]*" + r"[ \t]+".join(words) + r"[ \t]*\n"


def fits(sample: str, printed: str) -> bool:
    """Whether `printed` has `sample`'s lines, in order and next to each other, a `...` line
    standing for any number of lines."""
    lines = sample.strip("\n").splitlines()
    pattern = "".join(r"(?:.*\n)*" if line.strip() == "..." else line_pattern(line) for line in lines)
    return re.search(pattern, printed.strip("\n") + "\n") is not None


def test_every_text_block_is_checked_or_a_named_sample():
    loose = []
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        if GENERATED.search(text[:1000]):
            continue
        for m in BLOCK.finditer(text):
            marker = m["marker"] or ""
            if not (marker.startswith("output:") or marker.startswith("sample:")):
                loose.append(f"{page.name}: {m['text'].splitlines()[0][:60]}")
    assert not loose
    assert set(samples()) == set(PRINTED)


def test_the_shape_reads_values_as_values():
    assert fits("rank   rating\n   1   RATING\n   ...\n", "rank rating\n 1 3.2\n 2 1.0\n")
    assert not fits("rank   rating\n   1   RATING\n", "place rating\n 1 3.2\n")


def tournament(tmp_path: Path) -> str:
    level = tmp_path / "short.yaml"
    level.write_text(edited("bac-line", {"time_limit": 2}))
    proc = run_cli(
        "tournament", str(level), "--team", "ref:bac", "--team", "ref:idle", "--team", "ref:dead-reckoning",
        "--rounds", "2", "--db", str(tmp_path / "t.sqlite"), "--out", str(tmp_path / "site"),
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    return proc.stdout


def hud(tmp_path: Path) -> str:
    from referee.match.loop import play_match
    from referee.media.standings import Standings
    from referee.records.replay_reader import load
    from referee.sandbox.teams import resolve

    level = variant("asabe", time_limit=12)
    play_match(level, [resolve("ref:bac")], seed=1, replay=tmp_path / "m.replay", isolate=False)
    replay = load(tmp_path / "m.replay")
    return Standings(level, replay).line(0, "ref:bac", 10.0)


def level_error(tmp_path: Path) -> str:
    (tmp_path / "my-level.yaml").write_text(MINI_LEVEL.replace("start: [0.5, 0.5, 0]", "start: [0.5, 1.5, 0]"))
    proc = run_cli("check", "my-level.yaml", cwd=tmp_path)
    assert proc.returncode == 2
    return proc.stderr


PRINTED = {"tournament": tournament, "hud": hud, "level-error": level_error}


@pytest.mark.parametrize("name", sorted(PRINTED))
def test_a_sample_has_the_shape_of_what_the_program_prints(name, tmp_path):
    sample = samples()[name]
    printed = PRINTED[name](tmp_path)
    assert fits(sample, printed), f"the {name} sample:\n{sample}\nwhat the program prints:\n{printed}"
