"""A controller that burns every core it can must not cost the others their ticks, their
results or their think budget: busy children from setup to the end, each trying to start a
session of its own (a sandbox refuses it), in a race and beside an honest team in a grade with
two workers. Each slot is a control group of one slot's CPU weight, whatever it starts; the
referee's own group weighs more, so it keeps time; and the run weighs as the organizer's `nice`
says (docs/security.md). The others then play exactly the match they play beside a robot that
stands still."""

import os
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest
from helpers import run_cli, secret_file

from hostile.hostile_kit import FAST, HONEST, assert_others_unharmed, short_race, slot_uids, team_file
from referee.match.loop import play_match
from referee.sandbox import cgroup
from referee.sandbox.teams import resolve


def hog(children: int, cpus: str = "range(os.cpu_count())") -> str:
    """A controller whose setup starts `children` busy processes, each moved to `cpus` (every
    CPU, by default: a lone controller shares one with its referee) and into a session of its
    own where it may (a sandbox refuses both: they spin on where they were, in the slot's
    session)."""
    return f"""
class Hog(Controller):
    def setup(self, brief):
        for _ in range({children}):
            if os.fork() == 0:
                try:
                    os.sched_setaffinity(0, {cpus})
                except OSError:
                    pass
                try:
                    os.setsid()
                except OSError:
                    pass
                print("spinning", file=sys.stderr, flush=True)
                while True:
                    pass

    def step(self, obs):
        return Command(0.0, 0.0)
"""


STILL = """
class Still(Controller):
    def step(self, obs):
        return Command(0.0, 0.0)
"""


def thinker(base: str, seconds: float) -> str:
    """A reference controller that first spends `seconds` of its own CPU every step."""
    module, cls = base.split(":")
    return f"""
from {module} import {cls}
class Thinker({cls}):
    def step(self, obs):
        end = time.thread_time() + {seconds}
        while time.thread_time() < end:
            pass
        return super().step(obs)
"""


def race(tmp_path, body: str, name: str, honest: str):
    teams = [resolve(team_file(tmp_path, body, name))] + [resolve(honest)] * 3
    logs = tmp_path / name.removesuffix(".py")
    logs.mkdir()
    return play_match(short_race(20.0), teams, seed=3, limits=FAST, logs=logs).to_dict(), logs


def test_a_cpu_hog_costs_the_others_nothing(tmp_path):
    hogged, logs = race(tmp_path, hog(6), "hog.py", HONEST)
    assert (logs / "slot0.log").read_text().count("spinning") == 6  # the hog did burn
    assert_others_unharmed(hogged)
    calm, _ = race(tmp_path, STILL, "still.py", HONEST)
    assert hogged["robots"][1:] == calm["robots"][1:]


def test_sixty_children_in_sessions_of_their_own_cost_thinking_neighbours_nothing(tmp_path):
    honest = team_file(tmp_path, thinker("robots.controllers.dead_reckoning:DeadReckoning", 0.01), "thinker.py")
    hogged, logs = race(tmp_path, hog(60), "hog60.py", honest)
    assert (logs / "slot0.log").read_text().count("spinning") == 60
    assert_others_unharmed(hogged)
    calm, _ = race(tmp_path, STILL, "still.py", honest)
    assert hogged["robots"][1:] == calm["robots"][1:]


FALLBACK = """
import json, os, sys
from hostile.hostile_kit import FAST, short_race
from referee.match.loop import play_match
from referee.sandbox import cgroup
from referee.sandbox.teams import resolve

# as on a machine whose kernel has no cpu controller: every process in the root task group,
# where the kernel's autogroups share the CPU between sessions, and no cpu group for us
for line in open("/proc/self/mountinfo"):
    fields = line.split()
    kind, options = fields[fields.index("-") + 1], fields[-1].split(",")
    if kind == "cgroup" and "cpu" in options or kind == "cgroup2":
        open(fields[4] + "/cgroup.procs", "w").write(str(os.getpid()))
cgroup.OPTIONAL = ()
teams = [resolve(sys.argv[1])] + [resolve(sys.argv[2])] * 3
print(json.dumps(play_match(short_race(20.0), teams, seed=3, limits=FAST).to_dict()))
"""


def test_without_a_cpu_controller_a_slot_is_still_one_session(tmp_path):
    """Where no cpu group can be made, the slot's processes cannot leave its one session (a
    sandbox refuses setsid), and the kernel's autogroups share the CPU between sessions: sixty
    children still weigh one slot."""
    honest = team_file(tmp_path, thinker("robots.controllers.dead_reckoning:DeadReckoning", 0.01), "thinker.py")

    def played(neighbour: str) -> dict:
        proc = subprocess.run(
            [sys.executable, "-c", FALLBACK, team_file(tmp_path, neighbour, "n.py"), honest],
            capture_output=True, text=True, timeout=300, cwd=Path(__file__).parent.parent,
        )  # fmt: skip
        assert proc.returncode == 0, proc.stderr
        return __import__("json").loads(proc.stdout)

    assert Path("/proc/sys/kernel/sched_autogroup_enabled").read_text().strip() == "1"
    hogged = played(hog(60))
    assert_others_unharmed(hogged)
    assert hogged["robots"][1:] == played(STILL)["robots"][1:]


TRICKLE = """
class Trickle(Controller):
    def setup(self, brief):
        if os.fork() == 0:  # a byte at a time to its log, over the whole match, within the log's cap
            for _ in range(1_040_000):
                os.write(2, b".")
                end = time.perf_counter() + 8e-6
                while time.perf_counter() < end:
                    pass
            while True:
                time.sleep(1)

    def step(self, obs):
        return Command(0.0, 0.0)
"""


def test_a_log_written_a_byte_at_a_time_costs_thinking_neighbours_nothing(tmp_path):
    # each byte would wake the referee's log reader, at the referee's weight: it reads at most
    # every 20 ms, the pipe holding what comes meanwhile
    honest = team_file(tmp_path, thinker("robots.controllers.dead_reckoning:DeadReckoning", 0.02), "thinker.py")
    trickled, logs = race(tmp_path, TRICKLE, "trickle.py", honest)
    assert (logs / "slot0.log").read_text().count(".") > 1000  # it did write
    assert_others_unharmed(trickled)
    calm, _ = race(tmp_path, STILL, "still.py", honest)
    assert trickled["robots"][1:] == calm["robots"][1:]


def graded(tmp_path: Path, neighbour: str, honest: str) -> dict:
    """`grade --workers 2` of the neighbour and the honest team on bac-line, one seed each (so
    the two matches run side by side); the honest team's result from the journal."""
    folder = tmp_path / Path(neighbour).stem
    folder.mkdir(exist_ok=True)
    proc = run_cli(
        "grade", "bac-line", "--team", neighbour, "--team", honest, "--seeds", "1", "--workers", "2",
        "--quiet", "--db", str(folder / "j.sqlite"), "--out", str(folder / "lb.csv"),
        "--secret-file", secret_file("the noise both grades draw"),
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    with sqlite3.connect(folder / "j.sqlite") as db:
        rows = dict(db.execute("SELECT team, result FROM matches"))
    return __import__("json").loads(rows[honest])


# the CPUs a lone controller does not share with its referee: the other worker's, in a grade
OTHERS = "set(range(os.cpu_count())) - os.sched_getaffinity(0) or os.sched_getaffinity(0)"


@pytest.mark.parametrize("cpus, think", [("range(os.cpu_count())", 0.025), (OTHERS, 0.035)])
def test_a_hog_graded_beside_an_honest_team_costs_it_nothing(tmp_path, cpus, think):
    # the honest team thinks 25 or 35 ms a tick (of its budget's 50) for all of bac-line's 150
    # ticks, so its match spans the hog's; the hog's children go to every CPU, or to the others
    honest = team_file(tmp_path, thinker("robots.controllers.idle:Idle", think), "honest.py")
    beside_hog = graded(tmp_path, team_file(tmp_path, hog(60, cpus), "hog.py"), honest)
    beside_still = graded(tmp_path, team_file(tmp_path, STILL, "still.py"), honest)
    assert beside_hog["robots"][0]["faults"] == [] and beside_hog["end_reason"] == "time_limit"
    assert beside_hog == beside_still


def _cpu_group(pid: int) -> Path:
    """The folder of `pid`'s group in the cpu hierarchy (v1) or the unified one (v2)."""
    place = cgroup.available()
    assert not isinstance(place, str), place
    for line in Path(f"/proc/{pid}/cgroup").read_text().splitlines():
        number, names, path = line.split(":", 2)
        if place.version == 1 and "cpu" in names.split(",") or place.version == 2 and number == "0":
            mount = dict((controller, m) for m, controller in place.mounts)["cpu" if place.version == 1 else None]
            return Path(f"{mount}{path}")
    raise AssertionError(f"{pid} is in no cpu group")


def test_the_organizers_nice_is_the_weight_of_every_slot(tmp_path):
    """Under `nice -n 19`, each slot weighs against the rest of the machine what one nice-19
    process weighs (the kernel's weight table: 15 against a nice-0 process's 1024), whatever
    sessions it starts, and the referee's own group eight times that."""
    place = cgroup.available()
    if isinstance(place, str) or not place.cpu:
        pytest.fail(f"needs a cpu control group: {place}")
    spec = team_file(tmp_path, hog(2), "hog.py")
    referee = subprocess.Popen(
        ["nice", "-n", "19", sys.executable, "-m", "referee", "run", "asabe-race", "--team", spec, "--quiet"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    try:
        deadline, controllers = time.monotonic() + 60, []
        while len(controllers) < 3 and time.monotonic() < deadline:  # the hog's runner and its two children
            held = slot_uids(referee.pid)
            controllers = [
                int(p) for p in os.listdir("/proc") if p.isdigit() and _uid(p) in held
            ]  # fmt: skip
            time.sleep(0.1)
        assert len(controllers) >= 3, "the match never got going"
        key = "cpu.shares" if place.version == 1 else "cpu.weight"
        slots = {_cpu_group(pid) for pid in controllers}
        own = _cpu_group(referee.pid)
        assert own.name.endswith("-referee")
        assert all(
            s.parent == own.parent and s.name.startswith(own.name.removesuffix("referee") + "slot-") for s in slots
        )
        # v1: the kernel's weights themselves; v2: cpu.weight scaled from them (100 for nice 0)
        assert {_read(s / key) for s in slots} == {15 if place.version == 1 else 1}
        assert _read(own / key) == (120 if place.version == 1 else 12)
        assert all(os.getpriority(os.PRIO_PROCESS, pid) == 19 for pid in controllers)
    finally:
        referee.kill()
        referee.wait(10)


def _uid(pid: str) -> int | None:
    try:
        return int(Path(f"/proc/{pid}/status").read_text().split("\nUid:")[1].split()[0])
    except (OSError, IndexError):
        return None


def _read(path: Path) -> int:
    return int(path.read_text().split()[0])
