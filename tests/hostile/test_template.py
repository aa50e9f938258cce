"""A controller forked from the template (root referee) holds nothing of it: no descriptor but
its pipes and log, no capability, no writable mount but its own /tmp, /dev/shm and /dev/pts,
no process but its own; and what one slot leaves there another cannot see. Its probe slot is
forked as soon as it has imported."""

import os
import subprocess
import sys

import pytest

from hostile.hostile_kit import FAST, HONEST, assert_others_unharmed, short_race, team_file
from referee.match.loop import play_match
from referee.match.views import brief_for
from referee.sandbox import forkserver
from referee.sandbox.process import ProcessBot
from referee.sandbox.teams import resolve

pytestmark = pytest.mark.skipif(os.geteuid() != 0, reason="the template serves a root referee only")


def test_a_forked_controller_holds_nothing_of_the_template(tmp_path):
    assert forkserver.server() is not None, forkserver.unavailable()
    probe = team_file(
        tmp_path,
        """
class Probe(Controller):
    def step(self, obs):
        if obs.tick < 2:
            return Command(0.0, 0.0)
        found = []
        for fd in os.listdir("/proc/self/fd"):
            try:
                target = os.readlink(f"/proc/self/fd/{fd}")
            except OSError:
                continue  # the listing's own descriptor
            if not (target.startswith("pipe:") or target == "/dev/null" or target.startswith("/tmp/")):
                found.append(("fd", target))
        status = dict(line.split(":", 1) for line in open("/proc/self/status") if ":" in line)
        for key in ("CapInh", "CapPrm", "CapEff", "CapBnd", "CapAmb"):
            if int(status[key], 16):
                found.append((key, status[key].strip()))
        if status["NoNewPrivs"].strip() != "1" or os.getuid() == 0 or os.getgid() == 0 or os.getgroups():
            found.append(("ids", os.getuid(), os.getgid(), os.getgroups()))
        if os.getpid() != 1 or os.getppid() != 0:  # its namespace's init, its parent out of sight
            found.append(("pids", os.getpid(), os.getppid()))
        others = [p for p in os.listdir("/proc") if p.isdigit() and p != "1"]
        if others:
            found.append(("processes", others))
        for line in open("/proc/self/mountinfo"):
            point, options = line.split()[4], line.split()[5].split(",")
            if "rw" in options and point not in ("/tmp", "/dev/shm", "/dev/pts") and not point.startswith("/proc"):
                found.append(("writable", point))
        for path in ("/dev/planted", "/team/planted", "/laserarena/planted"):
            try:
                open(path, "w").close()
                found.append(("wrote", path))
            except OSError:
                pass
        raise RuntimeError("contained: nothing" if not found else f"LEAK: {found}")
""",
    )
    result = play_match(short_race(), [resolve(probe)] + [resolve(HONEST)] * 3, seed=2, limits=FAST)
    bad = result["robots"][0]
    assert [f["message"] for f in bad["faults"]] == ["in step: RuntimeError: contained: nothing"], bad["faults"]
    assert_others_unharmed(result)


def test_what_one_slot_leaves_in_tmp_shm_or_a_pty_another_cannot_see(tmp_path):
    writer = team_file(
        tmp_path,
        """
class Writer(Controller):
    def step(self, obs):
        if obs.tick == 1:
            for path in ("/tmp/planted", "/dev/shm/planted"):
                with open(path, "w") as f:
                    f.write("x")
            self.pty = os.openpty()
        return Command(0.0, 0.0)
""",
        "writer.py",
    )
    reader = team_file(
        tmp_path,
        """
class Reader(Controller):
    def step(self, obs):
        if obs.tick < 4:
            return Command(0.0, 0.0)
        seen = [p for p in ("/tmp/planted", "/dev/shm/planted") if os.path.exists(p)]
        seen += [p for p in os.listdir("/dev/pts") if p != "ptmx"]
        raise RuntimeError("contained: saw nothing" if not seen else f"LEAK: {seen}")
""",
        "reader.py",
    )
    result = play_match(
        short_race(), [resolve(writer), resolve(reader), resolve(HONEST), resolve(HONEST)], seed=2, limits=FAST
    )
    assert result["robots"][0]["faults"] == []
    assert [f["message"] for f in result["robots"][1]["faults"]] == ["in step: RuntimeError: contained: saw nothing"]


def test_a_slot_the_template_cannot_make_is_a_load_fault_saying_why():
    # the forked slot fails before the team's code runs (here: a CPU the machine has not): the
    # fault says so, in the slot's words, not "exited while its code was loading"
    bot = ProcessBot(resolve(HONEST), FAST, slot=0)
    bot.cpus = [4095]
    try:
        fault = bot.setup(brief_for(short_race(), 0))
    finally:
        bot.close()
    assert fault is not None and fault.kind == "load", fault
    assert "its sandbox could not be made: OSError" in fault.message and "Invalid argument" in fault.message


def test_the_probe_slot_is_forked_once_the_template_has_imported_without_being_waited_for():
    # asked for when the template starts: by the time a match wants a slot, the check is done
    assert forkserver.unavailable() is None, forkserver.unavailable()
    template = forkserver.ForkServer()
    try:
        assert template.probe is not None
        assert template.probe.wait(60) == 0, template.probe.problem  # nobody called wait_ready
        assert not template.ready
        assert template.wait_ready() is None and template.ready
    finally:
        template.close()
    assert not template.alive()


MATCH_WITHOUT_TRIAL = """
from hostile.hostile_kit import HONEST, short_race
from referee.match.loop import play_match
from referee.sandbox import forkserver, kernel
from referee.sandbox.teams import resolve

result = play_match(short_race(1.0), [resolve(HONEST)] * 4)
assert not [r for r in result.robots if r.faults], result.robots
assert forkserver.server() is not None  # the slots came from the template
print(kernel.unavailable.cache_info().misses, kernel.missing.cache_info().misses)
"""


def test_slots_forked_from_the_template_wait_for_no_sandbox_trial_of_their_own():
    # the template's probe slot has tried the sandbox: the spawned sandbox's trial (a bwrap
    # running `true`, tens of milliseconds of every run's start) is left for where it fails
    tests = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    out = subprocess.run(
        [sys.executable, "-c", MATCH_WITHOUT_TRIAL], cwd=tests, capture_output=True, text=True, timeout=120
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["0", "1"]  # never tried; its prerequisites looked up once


def test_a_template_still_booting_says_so_at_once():
    # whether a launch now would wait (ForkServer.booting): asked without waiting
    template = forkserver.ForkServer()
    try:
        assert template.booting()  # just started: still importing
        assert template.probe is not None and template.probe.wait(60) == 0  # imported, its probe slot done
        assert not template.booting() and not template.ready  # nobody waited for it
        assert template.wait_ready() is None and not template.booting()
    finally:
        template.close()


LAUNCH_AFTER_OWN_WORK = """
from hostile.hostile_kit import FAST, HONEST, short_race
from referee.match.fleet import Fleet
from referee.match.views import brief_for
from referee.sandbox import forkserver
from referee.sandbox.teams import resolve

fleet = Fleet([resolve(HONEST)] * 2, FAST, None, True)  # its template starts now
try:
    fleet.launch(wait=False)
    print("launched while it boots:", [bot.started is not None for bot in fleet.bots])
    print("faults:", fleet.start([brief_for(short_race(), s) for s in range(2)]))
    fleet.launch(wait=False)  # ready now: a later match launches at once
    print("ready:", not forkserver.booting())
finally:
    fleet.close()
"""


def test_a_match_launches_its_controllers_after_its_own_work_while_their_template_boots():
    # the referee builds its simulation rather than wait for a template still booting; the
    # controllers start when set up (Fleet.start), as they do from a ready template
    tests = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    out = subprocess.run(
        [sys.executable, "-c", LAUNCH_AFTER_OWN_WORK], cwd=tests, capture_output=True, text=True, timeout=120
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.splitlines() == [
        "launched while it boots: [False, False]",
        "faults: [None, None]",
        "ready: True",
    ]
