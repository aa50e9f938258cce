"""The Python API's grade and tournament: the same matches, journal and files as `laserarena
grade` and `laserarena tournament` for the same inputs, a Controller class team included (its
source kept beside the journal, so the command line can name the very same code), and a second
call resumes instead of playing again."""

from __future__ import annotations

import csv
import sqlite3
import subprocess
import sys

import pytest
from helpers import edited, secret_file, strong_secret

SCRIPT = """
import sys
from referee import grade, tournament
from robots.api import Command, Controller

class Forward(Controller):
    \"\"\"Both wheels at 0.05 m/s.\"\"\"
    def step(self, observation):
        return Command(0.05, 0.05)

def main(kind):
    if kind == "grade":
        rows = grade("short.yaml", ["ref:idle", Forward], seeds=2, workers=1, db="api.sqlite", out="api.csv", secret=SECRET)
        for r in rows:
            print(r.team, r.level, r.matches, repr(r.score_mean), repr(r.score_ci95), r.faults)
    else:
        done = tournament("race.yaml", ["ref:idle", Forward], rounds=1, workers=2, db="api.sqlite", secret=SECRET)
        for s in done.standings:
            print("S", s.rank, s.team, repr(s.rating), repr(s.mu), repr(s.sigma), s.heats, repr(s.mean_score))
        for h in done.heats:
            print("H", h.heat, h.level, h.seed, h.slot, h.team, h.rank, repr(h.score), int(h.filler))
        print("ran", done.ran)


if __name__ == "__main__":  # workers=2 starts processes that import this script
    main(sys.argv[1])
"""


def _python(folder, *args):
    out = subprocess.run([sys.executable, "api.py", *args], capture_output=True, text=True, cwd=folder, timeout=300)
    assert out.returncode == 0, out.stderr
    return [line.split() for line in out.stdout.splitlines()]


def _cli(folder, *args):
    out = subprocess.run(
        [sys.executable, "-m", "referee", *args], capture_output=True, text=True, cwd=folder, timeout=300
    )
    assert out.returncode == 0, out.stderr
    return out


def _rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def _shipped(folder):
    (source,) = (folder / "class-teams").glob("*.py")
    return f"class-teams/{source.name}:Forward"


def _journal(path, table):
    with sqlite3.connect(path) as c:
        return sorted(c.execute(f"SELECT level_hash, seed, result, graded_at FROM {table}"))


def test_grade_matches_the_command_line_and_resumes(shared_dir):
    (shared_dir / "short.yaml").write_text(edited("bac-line", {"time_limit": 3}))
    (shared_dir / "api.py").write_text(SCRIPT.replace("SECRET", repr(strong_secret("s"))))
    got = _python(shared_dir, "grade")
    journal = _journal(shared_dir / "api.sqlite", "matches")
    assert len(journal) == 4  # 2 teams x 1 level x 2 seeds
    _cli(
        shared_dir,
        "grade",
        "short.yaml",
        "--team",
        "ref:idle",
        "--team",
        _shipped(shared_dir),
        "--seeds",
        "2",
        "--workers",
        "1",
        "--db",
        "cli.sqlite",
        "--out",
        "cli.csv",
        "--secret-file",
        secret_file("s"),
        "--quiet",
    )
    cli = _rows(shared_dir / "cli.csv")
    # a file team is named by its path from here, as in `run`: never the machine's absolute path
    assert sorted(r["team"] for r in cli) == sorted(["ref:idle", _shipped(shared_dir)])
    names = {"ref:idle": "ref:idle", _shipped(shared_dir): "Forward"}
    assert len(cli) == len(got) == 2
    for row, (team, level, matches, mean, ci, faults) in zip(cli, got):
        assert (names[row["team"]], row["level"], row["matches"], row["faults"]) == (team, level, matches, faults)
        assert float(row["score_mean"]) == pytest.approx(float(mean), abs=1e-9)
        assert float(row["score_ci95"]) == pytest.approx(float(ci), abs=1e-9)
    api_csv = _rows(shared_dir / "api.csv")  # the API's own CSV: the same figures, the class by its name
    assert [dict(r, team=names[r["team"]]) for r in cli] == api_csv
    # idle never moves: a score equal over seeds; Forward moves and is scored apart from it
    assert got[0][0] != got[1][0] and all(r[5] == "0" for r in got)
    assert _python(shared_dir, "grade") == got  # resumed: nothing played again
    assert _journal(shared_dir / "api.sqlite", "matches") == journal


def test_tournament_matches_the_command_line_and_resumes(shared_dir):
    (shared_dir / "race.yaml").write_text(edited("asabe-race", {"time_limit": 3}))
    (shared_dir / "api.py").write_text(SCRIPT.replace("SECRET", repr(strong_secret("s"))))
    got = _python(shared_dir, "tournament")
    assert got[-1] == ["ran", "4"]  # two teams on four slots: one group, one heat per start slot
    _cli(
        shared_dir,
        "tournament",
        "race.yaml",
        "--team",
        "ref:idle",
        "--team",
        _shipped(shared_dir),
        "--rounds",
        "1",
        "--workers",
        "2",
        "--db",
        "cli.sqlite",
        "--out",
        "site",
        "--secret-file",
        secret_file("s"),
        "--quiet",
    )
    standings = _rows(shared_dir / "site" / "standings.csv")
    heats = _rows(shared_dir / "site" / "heats.csv")
    name = {"ref:idle": "ref:idle", _shipped(shared_dir): "Forward"}
    mine = [r[1:] for r in got if r[0] == "S"]
    assert len(mine) == len(standings) == 2
    for row, (rank, team, rating, mu, sigma, n, mean) in zip(standings, mine):
        assert (row["rank"], name.get(row["team"], row["team"]), row["heats"]) == (rank, team, n)
        for key, value in (("rating", rating), ("mu", mu), ("sigma", sigma), ("mean_score", mean)):
            assert float(row[key]) == pytest.approx(float(value), abs=1e-4)
    rows = [r[1:] for r in got if r[0] == "H"]
    assert len(rows) == len(heats) == 16  # 4 heats x 4 slots
    for row, mine_row in zip(heats, rows):
        expect = dict(row, team=name.get(row["team"], row["team"]))
        assert list(expect.values())[:6] == mine_row[:6] and expect["filler"] == mine_row[7]
        assert float(expect["score"]) == pytest.approx(float(mine_row[6]), abs=1e-9)
    # every team started once from every slot; the free slots held fillers
    for team in ("ref:idle", "Forward"):
        assert sorted(int(r[3]) for r in rows if r[4] == team) == [0, 1, 2, 3]
    assert sum(r[7] == "1" for r in rows) == 8
    again = _python(shared_dir, "tournament")
    assert again[:-1] == got[:-1] and again[-1] == ["ran", "0"]
