"""What the hostile-controller tests share: a short 4-robot match with one hostile slot, and the
checks that an attack was contained (the others unharmed, a typed fault, nothing left behind)."""

import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import yaml

import levels
from levels.loader import parse_level
from levels.match import ControllerLimits
from referee.match.loop import play_match
from referee.sandbox import leases, uids
from referee.sandbox.kernel import unavailable
from referee.sandbox.teams import resolve

FAST = ControllerLimits(setup_time=10, step_time=0.05, step_deadline=0.25, overage_bank=1.0, max_skips=3)
HONEST = "ref:dead-reckoning"


def short_race(seconds: float = 6.0):
    """asabe-race cut to `seconds`: the level's data with its time limit replaced, parsed again."""
    data = yaml.safe_load(levels.path("asabe-race").read_text())
    data["time_limit"] = seconds
    return parse_level(yaml.safe_dump(data, sort_keys=False).encode(), f"race{seconds:g}.yaml")


def team_file(folder: Path, body: str, name: str = "hostile.py") -> str:
    """Write a controller module (the API and os/sys imported) and return its spec."""
    p = folder / name
    p.write_text("from robots.api import *\nimport math, os, sys, signal, time\n\n" + textwrap.dedent(body))
    return str(p)


def hostile_match(folder: Path, body: str, seconds: float = 6.0, **kwargs) -> dict:
    """Slot 0 runs the hostile controller, slots 1-3 an honest reference one."""
    teams = [resolve(team_file(folder, body))] + [resolve(HONEST)] * 3
    return play_match(short_race(seconds), teams, seed=2, limits=kwargs.pop("limits", FAST), **kwargs)


def assert_others_unharmed(result: dict, bad: int = 0) -> None:
    """Every other robot answered every tick, with no fault, to the end."""
    for r in result["robots"]:
        if r["slot"] != bad:
            assert not r["faults"] and not r["stopped"], r["faults"]
            assert r["localization"]["fraction"] == 1.0 and r["localization"]["ticks"] > 0


def assert_contained(result: dict, kind: str = "exception", words: str = "contained", slow: bool = False) -> dict:
    """The hostile slot stopped with one typed fault whose one-line message holds `words`
    (`slow`: skipped ticks may come first, where the attack may outlast a step's deadline on a
    loaded machine)."""
    bad = result["robots"][0]
    kinds = [f["kind"] for f in bad["faults"]]
    skipped = kinds[:-1] if slow and set(kinds[:-1]) <= {"skipped_tick"} else []
    assert kinds[len(skipped) :] == [kind], bad["faults"]
    message = bad["faults"][-1]["message"]
    assert words in message and "\n" not in message, message
    assert bad["stopped"]
    assert_others_unharmed(result)
    return bad


def assert_ended_for_memory(result: dict, mib: int) -> None:
    """The hostile slot was ended by its group's memory limit (reclaim may take past a step's
    deadline: skipped ticks may come first); the others played on."""
    bad = result["robots"][0]
    kinds = [f["kind"] for f in bad["faults"]]
    assert kinds[-1] == "memory" and set(kinds[:-1]) <= {"skipped_tick"}, bad["faults"]
    assert f"more than its {mib} MiB of memory" in bad["faults"][-1]["message"]
    assert_others_unharmed(result)


def slot_uids(referee: int | None = None) -> set[int]:
    """The slot uids the referee process `referee` (default this one) holds while it lives: the
    leases it has locked (/proc/locks), by the files' inodes in the leases' folder."""
    pid = referee or os.getpid()
    folder = leases.folder(uids.KIND)
    names = {}
    for entry in os.scandir(folder):
        try:
            names[entry.inode()] = int(entry.name)
        except (OSError, ValueError):
            continue
    found = set()
    for line in Path("/proc/locks").read_text().splitlines():
        fields = line.split()  # "1: FLOCK  ADVISORY  WRITE PID MAJOR:MINOR:INODE 0 EOF" (waiters: "1: -> FLOCK ...")
        if len(fields) >= 6 and fields[1] == "FLOCK" and fields[4] == str(pid):
            inode = int(fields[5].rsplit(":", 1)[1])
            if inode in names:
                found.add(names[inode])
    return found


def sandboxed_processes(uids_of: set[int] | None = None) -> list[int]:
    """Host pids of controller processes still running: as root, those running as one of the
    uids `uids_of` (default: this process's slots'); as an ordinary user, ours in a PID
    namespace other than ours."""
    me, ours = os.geteuid(), os.readlink("/proc/self/ns/pid")
    held = slot_uids() if uids_of is None else uids_of
    found = []
    for entry in os.scandir("/proc"):
        if not entry.name.isdigit():
            continue
        try:
            status = Path(entry.path, "status").read_text()
            uid = int(status.split("\nUid:")[1].split()[0])
            if status.split("\nState:")[1].split()[0] == "Z":
                continue  # dead; left for an init that does not reap (a container's) to collect
            if me == 0 and uid in held or me != 0 and uid == me and os.readlink(f"{entry.path}/ns/pid") != ours:
                found.append(int(entry.name))
        except (OSError, IndexError, ValueError):
            continue  # ended while we looked
    return found


def _describe(pid: int) -> str:
    try:
        status = dict(
            line.split(":\t", 1) for line in Path(f"/proc/{pid}/status").read_text().splitlines() if ":\t" in line
        )
        return (
            f"{pid} ({status.get('State', '?')}, parent {status.get('PPid', '?')}): "
            + Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()[:200]
        )
    except OSError:
        return f"{pid}: gone"


def wait_until_gone(uids_of: set[int] | None = None, timeout: float = 10.0) -> list[int]:
    """Poll (bounded) until no controller process of the slot uids `uids_of` is left; the ones still there."""
    deadline = time.monotonic() + timeout
    while (left := sandboxed_processes(uids_of)) and time.monotonic() < deadline:
        time.sleep(0.05)
    return left


def laserarena(*args: str, **popen) -> subprocess.CompletedProcess:
    """Run the command line as a user would (`python -m referee ARGS`), bounded in time."""
    return subprocess.run(
        [sys.executable, "-m", "referee", *args], capture_output=True, text=True, timeout=300, **popen
    )


def tmp_entries() -> set[str]:
    return set(os.listdir("/tmp"))


def assert_nothing_left(before: set[str]) -> None:
    """No controller process of this referee alive, and nothing a controller owns added to /tmp."""
    held = slot_uids()
    left = sandboxed_processes(held)
    assert left == [], [_describe(pid) for pid in left]
    added = []
    for name in tmp_entries() - before:
        try:
            if os.lstat(f"/tmp/{name}").st_uid in held:
                added.append(name)
        except FileNotFoundError:
            continue
    assert added == [], added


def sandbox_missing() -> str | None:
    """Why these tests cannot hold here (they fail with it rather than pass without a sandbox)."""
    return unavailable()
