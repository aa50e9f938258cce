"""A controller sees its own code, read-only, and a private /tmp: not the other teams' code, the
replay or journal being written, the level files, the host's /tmp or /dev/shm, nor any network."""

import dataclasses
import os
import socket
import sqlite3
import sys
from pathlib import Path

import pytest

from hostile.hostile_kit import FAST, HONEST, assert_contained, short_race, team_file
from referee.match.loop import Match, play_match
from referee.records.replay_reader import load
from referee.sandbox.process import ProcessBot
from referee.sandbox.teams import resolve


def test_reads_nothing_but_its_own_code(tmp_path, shared_dir):
    journal = shared_dir / "results.sqlite"  # as a grader's journal: readable by anyone, on purpose
    sqlite3.connect(journal).execute("CREATE TABLE secret (x)").connection.commit()
    journal.chmod(0o644)
    replay = shared_dir / "match.replay"
    other = team_file(
        shared_dir, "class Other(Controller):\n    def step(self, obs): return Command(0, 0)\n", "other_team.py"
    )
    snoop = team_file(
        tmp_path,
        f"""
TARGETS = [{str(other)!r}, "/team/other_team.py", {str(journal)!r}, {str(shared_dir)!r}, "/etc/passwd",
           "/root", "/proc/1/root/etc/hostname"]
class Snoop(Controller):
    def step(self, obs):
        found = []
        for path in TARGETS:
            try:
                found.append((path, os.listdir(path) if os.path.isdir(path) else open(path, "rb").read(16)))
            except OSError:
                pass
        if obs.tick == 5:
            mine = open(__file__).read()
            raise RuntimeError(("contained: only its own code" if not found and "class Snoop" in mine
                                else f"LEAK: {{found}}"))
        return Command(0.0, 0.0)
""",
    )
    result = play_match(
        short_race(),
        [resolve(snoop), resolve(other), resolve(HONEST), resolve(HONEST)],
        seed=2,
        replay=replay,
        limits=FAST,
    )
    bad = result["robots"][0]
    assert [f["message"] for f in bad["faults"]] == ["in step: RuntimeError: contained: only its own code"]
    assert all(not r["faults"] for r in result["robots"][1:])
    assert load(replay).header["format"] == "laserarena-replay"


def test_writes_land_in_its_private_tmp_only(tmp_path, shared_dir):
    result = play_match(
        short_race(),
        [
            resolve(
                team_file(
                    tmp_path,
                    f"""
class Writer(Controller):
    def step(self, obs):
        if obs.tick < 3:
            return Command(0.0, 0.0)
        wrote = []
        for path in ({str(shared_dir / "planted")!r}, "/tmp/planted", "/dev/shm/laserarena-planted", "/team/planted",
                     "/planted", "/usr/planted", sys.prefix + "/planted"):
            try:
                with open(path, "w") as f:
                    f.write("x")
                wrote.append(path)
            except OSError:
                pass
        raise RuntimeError(("contained: " if wrote == ["/tmp/planted", "/dev/shm/laserarena-planted"]
                            else "LEAK: ") + repr(wrote))
""",
                )
            )
        ]
        + [resolve(HONEST)] * 3,
        seed=2,
        limits=FAST,
    )
    assert_contained(result)
    # what it wrote stayed in its sandbox, which is gone
    assert not (shared_dir / "planted").exists() and not (tmp_path / "planted").exists()
    assert not os.path.exists("/dev/shm/laserarena-planted") and not os.path.exists(sys.prefix + "/planted")


def test_no_network_not_even_the_hosts_loopback(tmp_path):
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen()
    server.setblocking(False)
    port = server.getsockname()[1]
    try:
        result = play_match(
            short_race(),
            [
                resolve(
                    team_file(
                        tmp_path,
                        f"""
import socket
class Caller(Controller):
    def step(self, obs):
        if obs.tick < 3:
            return Command(0.0, 0.0)
        reached = []
        for address in (("127.0.0.1", {port}), ("1.1.1.1", 53), ("8.8.8.8", 443)):
            try:
                socket.create_connection(address, timeout=0.05).close()
                reached.append(address)
            except OSError:
                pass
        raise RuntimeError("contained: reached " + repr(reached))
""",
                    )
                )
            ]
            + [resolve(HONEST)] * 3,
            seed=2,
            limits=FAST,
        )
        assert_contained(result, words="contained: reached []")
        try:
            server.accept()
            raise AssertionError("a controller connected to the host")
        except BlockingIOError:
            pass  # nobody knocked
    finally:
        server.close()


@pytest.mark.parametrize("forked", [True, False])  # from the template, or a sandbox spawned for it
def test_no_folder_of_the_installation_can_be_named(tmp_path, forked):
    """Whatever a controller reads of its own process (mounts, mappings, paths, environment,
    control group, the build configuration) or of the modules it may import (sources and
    compiled ones), it finds no folder name of the host's installation: the interpreter's,
    the virtual environment's, the product's or the checkout's; what it runs is staged at
    neutral paths (docs/security.md)."""
    import robots

    host = {os.path.realpath(p) for p in (sys.prefix, sys.base_prefix, sys.executable, os.getcwd())}
    host |= {str(Path(robots.__file__).resolve().parents[1]), str(Path(__file__).resolve().parents[2])}
    names = sorted(h for h in host if not Path(h).is_relative_to("/usr"))  # the system's /usr is bound whole
    assert names
    body = f"""
import json, sys
NAMES = {names!r}
class Looker(Controller):
    def step(self, obs):
        if obs.tick != 3:
            return Command(0.05, 0.05)
        import numpy
        seen = []
        for what in ("mountinfo", "mounts", "mountstats", "maps", "cgroup", "environ", "cmdline"):
            seen.append(open("/proc/self/" + what, "rb").read().decode(errors="replace"))
        seen += [sys.executable, sys.prefix, sys.base_prefix, json.dumps(sys.path), numpy.__file__, repr(os.environ)]
        import sysconfig
        seen.append(repr(sysconfig.get_config_vars()))
        for top in ("/laserarena", "/python"):  # every module and compiled module it may read
            for folder, _, files in os.walk(top):
                for name in files:
                    if name.endswith((".py", ".pyc")):
                        seen.append(open(os.path.join(folder, name), "rb").read().decode("latin-1"))
        found = sorted({{n for n in NAMES for text in seen if n in text}})
        raise RuntimeError(("contained: " if not found else "LEAK: ") + repr(found))
"""
    # reading every staged module takes its time (a pyenv's whole library): the tick may take 5 s
    limits = dataclasses.replace(FAST, step_deadline=5.0, overage_bank=5.0, think_budget=10.0)
    teams = [resolve(team_file(tmp_path, body))] + [resolve(HONEST)] * 3
    match = Match(short_race(), teams, seed=2, limits=limits)
    match.fleet.bots = [ProcessBot(team, limits, slot=i, forked=forked) for i, team in enumerate(match.teams)]
    assert_contained(match.run().to_dict(), words="contained: []")
