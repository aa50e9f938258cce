"""Names a root referee holds cannot collide: two referees that each see themselves as pid 1
(each in a PID namespace of its own, as in a container) hold no slot uid in common, and the
control groups a killed referee left behind never fail the next run (docs/security.md). A
match makes its slots' groups before it starts their processes, and a referee that ends
leaves none of its groups."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from hostile.hostile_kit import HONEST, short_race, slot_uids, team_file, wait_until_gone
from referee.match.loop import play_match
from referee.sandbox import cgroup, launch, process
from referee.sandbox.teams import resolve

pytestmark = pytest.mark.skipif(os.geteuid() != 0, reason="slot uids and control groups are a root referee's")

HOLDER = """
import json, os, sys, time
from referee.sandbox.uids import slot_uid
print(json.dumps({"pid": os.getpid(), "uids": [slot_uid(s) for s in range(8)]}), flush=True)
sys.stdin.read()  # held until the test closes our input
"""


def test_referees_that_are_each_pid_one_hold_no_uid_in_common():
    held = []
    procs = [
        subprocess.Popen(
            ["unshare", "--pid", "--fork", "--mount-proc", sys.executable, "-c", HOLDER],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )  # fmt: skip
        for _ in range(3)
    ]
    try:
        for proc in procs:
            assert proc.stdout is not None
            held.append(json.loads(proc.stdout.readline()))
    finally:
        for proc in procs:
            proc.communicate("", timeout=30)
    assert [h["pid"] for h in held] == [1, 1, 1]  # what a pid-derived uid would have made alike
    uids = [set(h["uids"]) for h in held]
    assert all(len(u) == 8 for u in uids)
    assert not (uids[0] & uids[1] or uids[0] & uids[2] or uids[1] & uids[2])


KILLED = """
import sys
from hostile.hostile_kit import HONEST, short_race
from referee.match.loop import play_match
from referee.sandbox.teams import resolve
play_match(short_race(600.0), [resolve(sys.argv[1])] + [resolve(HONEST)] * 3, seed=2)
"""


def test_groups_a_killed_referee_left_never_fail_the_next_run(tmp_path):
    place = cgroup.available()
    assert not isinstance(place, str), place
    slow = team_file(
        tmp_path, "class Slow(Controller):\n    def step(self, obs):\n        return Command(0.05, 0.05)\n"
    )
    referee = subprocess.Popen([sys.executable, "-c", KILLED, slow], cwd=Path(__file__).parent.parent)
    try:
        deadline, uids, runs = time.monotonic() + 60, set(), set()
        while len(runs) < 1 and time.monotonic() < deadline:
            uids |= slot_uids(referee.pid)
            runs = {p.name.removesuffix("-slot-3") for f in place.folders for p in f.glob("laserarena-*-slot-3")}
            time.sleep(0.1)
        assert runs, "the match never got going"
    finally:
        referee.send_signal(signal.SIGKILL)
        referee.wait(30)
    assert wait_until_gone(uids) == []
    left = {p for f in place.folders for run in runs for p in f.glob(f"{run}-*")}
    assert left, "a killed referee leaves its groups"
    deadline = time.monotonic() + 30  # its last processes (its template) gone too
    while any(procs.read_text().strip() for p in left for procs in p.rglob("cgroup.procs")):
        assert time.monotonic() < deadline, "a killed referee's processes live on"
        time.sleep(0.05)
    old_style = [f / f"laserarena-1-{n}" for f in place.folders for n in range(2)]  # pid-named, as older referees made
    for group in old_style:
        group.mkdir(exist_ok=True)
    after = subprocess.run(
        [sys.executable, "-c", NEXT], capture_output=True, text=True, timeout=300, cwd=Path(__file__).parent.parent
    )
    assert after.returncode == 0, after.stderr
    assert all(not r["faults"] for r in json.loads(after.stdout)["robots"])
    assert not any(p.exists() for p in left) and not any(p.exists() for p in old_style)


NEXT = """
import json
from hostile.hostile_kit import HONEST, short_race
from referee.match.loop import play_match
from referee.sandbox.teams import resolve
print(json.dumps(play_match(short_race(), [resolve(HONEST)] * 4, seed=2).to_dict()))
"""


HIDDEN = """
import json, sys
from hostile.hostile_kit import HONEST, short_race
from referee.match.loop import play_match
from referee.sandbox.teams import resolve
print(json.dumps(play_match(short_race(float(sys.argv[1])), [resolve(HONEST)] * 4, seed=2).to_dict()))
"""


def test_a_referee_whose_leases_are_out_of_sight_keeps_its_groups(tmp_path):
    """A referee with a /run of its own (a container's, sharing the machine's control groups)
    holds leases no other referee sees: referees starting meanwhile never take its live groups
    for a killed one's (it is in its own run's groups), and its match plays to the end."""
    place = cgroup.available()
    assert not isinstance(place, str), place
    before = {p.name for f in place.folders for p in f.glob("laserarena-*-slot-3")}
    hidden = f"mount -t tmpfs tmpfs /run && exec {sys.executable} -c '{HIDDEN}' 20"
    referee = subprocess.Popen(
        ["unshare", "--mount", "--propagation", "private", "sh", "-c", hidden],
        cwd=Path(__file__).parent.parent, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        deadline, theirs = time.monotonic() + 60, set()
        while not theirs and time.monotonic() < deadline and referee.poll() is None:
            theirs = {p.name for f in place.folders for p in f.glob("laserarena-*-slot-3")} - before
            time.sleep(0.05)
        assert theirs, "the hidden referee's match never got going"
        for _ in range(3):  # referees that start meanwhile, each sweeping what it takes for stale
            after = subprocess.run(
                [sys.executable, "-c", HIDDEN, "2"], capture_output=True, text=True, timeout=300,
                cwd=Path(__file__).parent.parent,
            )  # fmt: skip
            assert after.returncode == 0, after.stderr
        out, err = referee.communicate(timeout=300)
    finally:
        if referee.poll() is None:
            referee.kill()
            referee.wait(30)
    assert referee.returncode == 0, err
    assert all(not r["faults"] for r in json.loads(out)["robots"])


ENDING = """
import atexit, json, sys, threading
from hostile.hostile_kit import HONEST, short_race
from referee.match.loop import play_match
from referee.sandbox import cgroup
from referee.sandbox.teams import resolve

def refuse(thread):
    raise RuntimeError("can't create new thread at interpreter shutdown")

result = play_match(short_race(2.0), [resolve(HONEST)] * 4, seed=2)
print(json.dumps({"name": cgroup.run().name, "faults": [r["faults"] for r in result.to_dict()["robots"]]}))
if sys.argv[1] == "refused":  # at exit, no thread starts, as in Python 3.12 (run first: registered last)
    atexit.register(lambda: setattr(threading.Thread, "start", refuse))
"""


@pytest.mark.parametrize("threads_at_exit", ["started", "refused"])
def test_a_referee_that_ends_leaves_none_of_its_groups(threads_at_exit):
    """At exit the referee moves back to the groups it came from (on a thread, while its
    template ends; itself, where Python starts no thread then) and removes its own."""
    place = cgroup.available()
    assert not isinstance(place, str), place
    done = subprocess.run(
        [sys.executable, "-c", ENDING, threads_at_exit], capture_output=True, text=True, timeout=300,
        cwd=Path(__file__).parent.parent,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout)
    assert out["faults"] == [[]] * 4
    assert out["name"].startswith("laserarena-")
    assert [p for f in place.folders for p in f.glob(f"{out['name']}-*")] == []


def test_a_match_makes_every_slot_s_groups_before_it_starts_a_controller(monkeypatch):
    """A group made while another slot's process joins its own waits for that move's grace
    period: every slot's groups come first (ProcessBot.prepare), then the processes."""
    events = []
    make, start = cgroup.SlotGroup.__init__, launch.launch

    def made(group, *args):
        make(group, *args)
        events.append("group")

    def started(*args):
        events.append("process")
        return start(*args)

    monkeypatch.setattr(cgroup.SlotGroup, "__init__", made)
    monkeypatch.setattr(process, "launch", started)
    result = play_match(short_race(1.0), [resolve(HONEST)] * 4, seed=2)
    assert all(not r["faults"] for r in result.to_dict()["robots"])
    assert events == ["group"] * 4 + ["process"] * 4
