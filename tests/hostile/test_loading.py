"""Team code never runs in the referee; whatever goes wrong while it loads is a `load` fault."""

import builtins
import hashlib
import sys
from pathlib import Path

import pytest

import referee.match.scoring
from hostile.hostile_kit import (
    HONEST,
    assert_contained,
    assert_others_unharmed,
    hostile_match,
    laserarena,
    short_race,
    team_file,
)
from referee.match.loop import play_match
from referee.match.verify import verify
from referee.sandbox.teams import resolve

# module-level code that, run anywhere, leaves a mark and rewrites the scoring
SUBVERT = """
import builtins
builtins.LASERARENA_PWNED = True
try:
    import referee.match.scoring
    referee.match.scoring.score = lambda *a, **k: {"total": 1e9}
except ImportError:
    pass
"""


def test_module_code_never_runs_in_the_referee(tmp_path):
    scoring = Path(referee.match.scoring.__file__)
    digest, score = hashlib.sha256(scoring.read_bytes()).hexdigest(), referee.match.scoring.score
    result = hostile_match(
        tmp_path,
        SUBVERT
        + """
found = []
for attempt in (lambda: open(referee.match.scoring.__file__, "a").write("# pwned"),   # the installed code
                lambda: os.listdir(os.path.dirname(os.path.dirname(referee.match.scoring.__file__)) + "/levels")[0],
                lambda: open("/proc/1/environ", "rb").read(1) if os.getpid() != 1 else 1 / 0,  # an init not itself
                lambda: open(f"/proc/{os.getppid()}/mem", "rb").read(1)):
    try:
        found.append(attempt())
    except Exception:
        pass

class Subvert(Controller):
    def step(self, obs):
        if obs.tick == 3:
            raise RuntimeError("LEAK: " + repr(found) if found else "contained: nothing reached")
        return Command(0.05, 0.05)
""",
        replay=tmp_path / "match.replay",
    )
    assert_contained(result, words="contained: nothing reached")
    assert not hasattr(builtins, "LASERARENA_PWNED")  # the module ran, but never here
    assert referee.match.scoring.score is score and hashlib.sha256(scoring.read_bytes()).hexdigest() == digest
    ok, message = verify(tmp_path / "match.replay")  # re-simulating loads it again, again elsewhere
    assert ok, message
    assert not hasattr(builtins, "LASERARENA_PWNED")


@pytest.mark.parametrize(
    "body, words",
    [
        ("os._exit(0)\n", "exited with code 0 while its code was loading"),
        ("sys.exit()\n", "SystemExit"),
        ("def broken(:\n", "SyntaxError"),
        ("import no_such_module_anywhere\n", "ModuleNotFoundError"),
        ("X = 1\n", "hostile.py defines no class; a controller is a class that subclasses Controller"),
        ("class A: pass\n", "no class in hostile.py subclasses Controller (found A)"),
        ("class A(Controller): pass\nclass B(Controller): pass\n", "hostile.py has 2 Controller classes (A, B)"),
    ],
)
def test_a_team_that_cannot_load_is_a_load_fault_of_its_slot(tmp_path, body, words):
    result = hostile_match(tmp_path, body)
    bad = assert_contained(result, kind="load", words=words)
    assert bad["faults"][0]["message"].startswith("team hostile.py")  # named as given
    assert bad["faults"][0]["tick"] == 0


def test_run_with_only_broken_teams_exits_2_in_one_line(tmp_path):
    quits = team_file(tmp_path, "os._exit(0)\n", "quits.py")
    broken = team_file(tmp_path, "def broken(:\n", "broken.py")
    for teams in ([quits], [quits, broken]):
        args = [a for t in teams for a in ("--team", t)]
        done = laserarena("run", "asabe-race", "--seed", "2", "--json", str(tmp_path / "r.json"), *args)
        assert done.returncode == 2, done.stderr
        assert done.stdout == "" and done.stderr.count("\n") == 1 and "Traceback" not in done.stderr
        assert done.stderr.startswith("laserarena: team quits.py: exited with code 0 while its code was loading")
        assert not (tmp_path / "r.json").exists()


def test_one_broken_team_among_good_ones_is_just_its_fault(tmp_path):
    broken = team_file(tmp_path, "def broken(:\n", "broken.py")
    result = play_match(short_race(), [resolve(HONEST), resolve(broken), resolve(HONEST), resolve(HONEST)], seed=2)
    assert [f["kind"] for f in result["robots"][1]["faults"]] == ["load"]
    assert_others_unharmed(result, bad=1)
    assert "LASERARENA_PWNED" not in sys.modules


def test_a_package_team_is_shipped_whole_and_never_imported_here(tmp_path, monkeypatch):
    package = tmp_path / "evilpkg"
    (package / "sub").mkdir(parents=True)
    (package / "__init__.py").write_text(SUBVERT)  # would run on any import of evilpkg.team
    (package / "sub" / "__init__.py").write_text("")
    (package / "sub" / "helper.py").write_text("SPEED = 0.05\n")
    (package / "team.py").write_text(
        "from robots.api import Command, Controller\nfrom evilpkg.sub.helper import SPEED\n\n"
        "class Team(Controller):\n    def step(self, obs):\n        return Command(SPEED, SPEED, estimate=(0.3, 0.25, 0.0))\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    team = resolve("evilpkg.team:Team")
    assert "evilpkg" not in sys.modules and not hasattr(builtins, "LASERARENA_PWNED")
    shipped = sorted(rel for rel, _ in team.files)
    assert shipped == ["evilpkg/__init__.py", "evilpkg/sub/__init__.py", "evilpkg/sub/helper.py", "evilpkg/team.py"]
    h = hashlib.sha256()  # the documented recipe: path, size and bytes of each file in path order
    for rel in shipped:
        data = (tmp_path / rel).read_bytes()
        h.update(f"{rel}\0{len(data)}\0".encode() + data)
    assert team.code_hash == "sha256:" + h.hexdigest()
    result = play_match(short_race(3), [team] + [resolve(HONEST)] * 3, seed=2)
    assert all(not r["faults"] for r in result["robots"])  # it loaded and ran, in its sandbox
    assert "evilpkg" not in sys.modules and not hasattr(builtins, "LASERARENA_PWNED")
