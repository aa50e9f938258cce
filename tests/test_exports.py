"""What the referee writes from a team's or a level's name stays what and where it should be:
CSV cells a spreadsheet would run as a formula are neutralised (numbers stay numbers), and a
level name with `/`, `..` or control characters never turns a replay's file name into a path."""

import csv
import io
import json

from helpers import MINI_LEVEL, run_cli, secret_file

from referee.terminal import csv_text

FORMULA = '=HYPERLINK("http://x","y")'
HOSTILE_NAME = "../a/b/..\x07\x1b[31m"  # a parent folder, a subfolder, a bell and an ANSI escape


def test_formula_cells_get_a_quote_and_numbers_stay_numbers():
    rows = [[FORMULA, -4.5], ["+1+A1", 3], ["-x", -2], ["@a", 0], ["\tx", 1], ["\rx", 1], ["ok", "-6.2844"]]
    read = list(csv.reader(io.StringIO(csv_text(["team", "score"], rows), newline="")))
    assert read[1:] == [
        ["'" + FORMULA, "-4.5"],
        ["'+1+A1", "3"],
        ["'-x", "-2"],
        ["'@a", "0"],
        ["'\\tx", "1"],  # then escaped: a lone CR would end the row
        ["'\\rx", "1"],
        ["ok", "-6.2844"],  # a number formatted as text stays a number
    ]


def test_grade_and_tournament_keep_replays_of_a_hostile_level_name_in_their_folder(shared_dir):
    """A level named with `..`, `/` and control characters, played by a team named like a
    spreadsheet formula: grade and tournament finish, every replay is a plain file in the
    output's replays/ folder, and the leaderboard's team cell is text, not a formula."""
    (shared_dir / "level.yaml").write_text(MINI_LEVEL.replace("name: mini", f"name: {json.dumps(HOSTILE_NAME)}"))
    folder = shared_dir / '=HYPERLINK("http:'  # the spec FORMULA.py names the file x","y").py in it
    folder.mkdir()
    (folder / 'x","y").py').write_text("from robots.controllers.dead_reckoning import DeadReckoning as Bot\n")
    for p in (shared_dir / "level.yaml", folder, folder / 'x","y").py'):
        p.chmod(0o755)
    spec = FORMULA + ".py"
    for run in ("g", "t"):
        (shared_dir / run).mkdir(mode=0o755)

    graded = run_cli(
        "grade", "level.yaml", "--team", spec, "--seeds", "1", "--quiet", "--db", "g/j.sqlite", "--out", "g/lb.csv",
        cwd=shared_dir,
    )  # fmt: skip
    assert graded.returncode == 0, graded.stderr
    board = list(csv.DictReader((shared_dir / "g" / "lb.csv").open(newline="")))
    assert board[0]["team"] == "'" + '=HYPERLINK("http:/x","y").py'  # the team's label: its path, tidied
    assert isinstance(float(board[0]["score_mean"]), float)  # a number, written as one

    played = run_cli(
        "tournament", "level.yaml", "--team", spec, "--team", "ref:idle", "--rounds", "1", "--secret-file", secret_file("s"),
        "--db", "t/j.sqlite", "--out", "t/out",
        cwd=shared_dir,
    )  # fmt: skip
    assert played.returncode == 0, played.stderr
    assert played.stdout.splitlines()[0].split() == ["rank", "rating", "heats", "mean", "team"]  # the standings' header
    assert {p.name for p in shared_dir.iterdir()} == {"level.yaml", folder.name, "g", "t"}
    for run in ("g", "t"):
        replays = list((shared_dir / run / "replays").iterdir())
        assert replays and all(r.is_file() and r.name.endswith(".replay") for r in replays), replays
        assert all(r.name.isprintable() and not r.name.startswith(".") for r in replays), replays
