"""Controllers in their own processes: same results as in-process; hostile code is contained."""

import dataclasses
import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from helpers import closed_to_others, exact_starts, variant
from hostile.hostile_kit import sandboxed_processes

import levels
from levels.loader import load_level
from levels.match import ControllerLimits
from referee.match.loop import play_match
from referee.records.canonical import dumps
from referee.records.replay_reader import load
from referee.sandbox.teams import resolve


def team_file(tmp_path, body, name="team.py"):
    p = tmp_path / name
    p.write_text("from robots.api import *\nimport math, os, sys\n\n" + textwrap.dedent(body))
    return str(p)


def race():
    return load_level(levels.path("asabe-race"))


def test_isolated_and_in_process_give_identical_bytes(tmp_path):
    lv = variant("asabe-race", **exact_starts("asabe-race"))  # set down exactly, for driving blind
    teams = [resolve("ref:dead-reckoning")] * 4
    # a perfect drive (ideal), so blind dead reckoning really finishes the race
    a = play_match(lv, teams, seed=4, replay=tmp_path / "a.replay", isolate=True, ideal=True)
    b = play_match(lv, teams, seed=4, replay=tmp_path / "b.replay", isolate=False, ideal=True)
    assert dumps(a) == dumps(b)
    assert (tmp_path / "a.replay").read_bytes() == (tmp_path / "b.replay").read_bytes()
    assert all(r["task"]["reached"] == 6 for r in a["robots"])


FAST = ControllerLimits(setup_time=10, step_time=0.05, step_deadline=0.25, overage_bank=1.0, max_skips=3)


def hostile_match(tmp_path, body, limits=FAST):
    """Slot 0 runs the hostile controller, the others reference ones."""
    lv = variant("asabe-race", "race30.yaml", time_limit=30)
    teams = [
        resolve(team_file(tmp_path, body)),
        resolve("ref:dead-reckoning"),
        resolve("ref:dead-reckoning"),
        resolve("ref:dead-reckoning"),
    ]
    return play_match(lv, teams, seed=2, limits=limits)


def check_contained(result, *kinds):
    bad, *others = result["robots"]
    assert [f["kind"] for f in bad["faults"]] == list(kinds), bad["faults"]
    assert bad["stopped"]
    for r in others:  # the match went on for everyone else, every tick answered
        assert not r["faults"] and not r["stopped"] and r["localization"]["fraction"] == 1.0


def test_infinite_loop_times_out(tmp_path):
    result = hostile_match(
        tmp_path,
        """
        class Spin(Controller):
            def step(self, obs):
                if obs.tick == 5:
                    while True:
                        pass
                return Command(0.05, 0.05)
    """,
    )
    # skipped at the deadline, then disqualified when the overage bank ran dry
    check_contained(result, "skipped_tick", "timeout")
    assert [f["tick"] for f in result["robots"][0]["faults"]] == [5, 6]
    skipped, stopped = result["robots"][0]["faults"]
    assert skipped["message"].startswith("no answer within step_deadline (0.25 s): tick skipped")
    assert stopped["message"].startswith("in step: step() did not return within step_deadline (0.25 s), nor before")


def test_slow_steps_draw_on_the_bank_without_skipping(tmp_path):
    result = hostile_match(
        tmp_path,
        """
        import time
        class Slow(Controller):
            def step(self, obs):
                if obs.tick in (3, 9):
                    time.sleep(0.12)  # over step_time 0.05, under the 0.25 deadline
                return Command(0.05, 0.05, estimate=(0, 0, 0))
    """,
    )
    bad = result["robots"][0]
    assert bad["faults"] == [] and bad["localization"]["fraction"] == 1.0


def test_slow_steps_that_empty_the_bank_are_told_in_the_limits_names(tmp_path):
    result = hostile_match(
        tmp_path,
        """
        import time
        class Slow(Controller):
            def step(self, obs):
                time.sleep(0.15)  # 0.1 s over step_time 0.05 every tick, under the 0.25 s deadline
                return Command(0.05, 0.05, estimate=(0, 0, 0))
    """,
    )
    check_contained(result, "timeout")
    (fault,) = result["robots"][0]["faults"]
    assert fault["message"] == (
        "in step: steps over step_time (0.05 s) used up the overage_bank (1 s of excess a match); make step() faster"
    )
    assert 8 <= fault["tick"] <= 11  # 1 s of 0.1 s excesses: the 10th or so


def test_late_answers_are_skipped_ticks_and_the_robot_goes_on(tmp_path):
    result = hostile_match(
        tmp_path,
        """
        import time
        class Late(Controller):
            def step(self, obs):
                if obs.tick in (3, 20):
                    time.sleep(0.35)  # past the 0.25 s deadline
                return Command(0.05, 0.05, estimate=(0, 0, 0))
    """,
    )
    bad = result["robots"][0]
    assert [(f["kind"], f["tick"]) for f in bad["faults"]] == [("skipped_tick", 3), ("skipped_tick", 20)]
    assert not bad["stopped"]
    skips = [f for f in bad["fouls"] if f["kind"] == "skipped_tick"]  # and each is a foul
    assert [f["time"] for f in skips] == pytest.approx([3 * 0.2, 20 * 0.2]) and skips[0]["penalty"] == 0.5
    loc = bad["localization"]
    assert loc["estimates"] == loc["ticks"] - 2  # the skipped ticks carried no estimate


def test_too_many_skips_in_a_row_disqualify(tmp_path):
    result = hostile_match(
        tmp_path,
        """
        import time
        class Sluggish(Controller):
            def step(self, obs):
                if obs.tick >= 4:
                    time.sleep(0.3)
                return Command(0.05, 0.05)
    """,
    )
    check_contained(result, "skipped_tick", "skipped_tick", "timeout")
    assert result["robots"][0]["faults"][-1]["message"].startswith(
        "in step: 3 ticks in a row without an answer within step_deadline (0.25 s, max_skips 3)"
    )


def test_exit_is_a_crash(tmp_path):
    result = hostile_match(
        tmp_path,
        """
        class Quit(Controller):
            def step(self, obs):
                os._exit(3)
    """,
    )
    check_contained(result, "crash")
    assert "exited with code 3" in result["robots"][0]["faults"][0]["message"]


def test_unbounded_allocation_hits_the_memory_limit(tmp_path):
    result = hostile_match(
        tmp_path,
        """
        class Hog(Controller):
            def step(self, obs):
                hoard = []
                while True:
                    hoard.append(bytearray(50 << 20))
    """,
        dataclasses.replace(FAST, memory=300 << 20, step_deadline=3.0, overage_bank=5.0),
    )
    check_contained(result, "memory")


def test_nan_command_is_rejected(tmp_path):
    result = hostile_match(
        tmp_path,
        """
        class Nan(Controller):
            def step(self, obs):
                return Command(float("nan"), 0.1)
    """,
    )
    check_contained(result, "bad_command")
    assert result["robots"][0]["faults"][0]["tick"] == 0  # rejected at once: NaN never reached physics


def test_no_world_state_in_the_controller_process(tmp_path):
    # it looks through its own memory for anything of the simulator; finding any, it crashes
    result = hostile_match(
        tmp_path,
        """
        import gc
        class Snoop(Controller):
            def step(self, obs):
                leaks = [m for m in sys.modules if m.split(".")[0] in ("pymunk", "levels", "arena", "referee", "numpy")]
                leaks += [type(o).__name__ for o in gc.get_objects()
                          if type(o).__module__.split(".")[0] in ("pymunk", "levels", "arena", "referee")]
                if leaks:
                    raise RuntimeError(f"found {leaks[:5]}")
                return Command(0.0, 0.0)
    """,
    )
    bad = result["robots"][0]
    assert bad["faults"] == [] and not bad["stopped"]  # it found nothing
    assert result["end_reason"] == "time_limit"


def test_forked_children_do_not_outlive_the_match(tmp_path):
    result = hostile_match(
        tmp_path,
        """
        class Forker(Controller):
            def setup(self, brief):
                if os.fork() == 0:
                    import time
                    time.sleep(600)
                    os._exit(0)
            def step(self, obs):
                raise RuntimeError("done")
    """,
    )
    assert result["robots"][0]["faults"][0]["kind"] == "exception"
    # the child ran as the slot's own uid (as root) or in the slot's PID namespace: none is left
    assert sandboxed_processes() == []


def test_cannot_read_the_referees_memory_or_environment(tmp_path, monkeypatch):
    monkeypatch.setenv("LASERARENA_TEST_SECRET", "the-true-pose-is-here")
    result = hostile_match(
        tmp_path,
        """
        class Peek(Controller):
            def step(self, obs):
                parent = os.getppid()
                found = []
                try:
                    found.append(open(f"/proc/{parent}/environ", "rb").read()[:64])
                except OSError:
                    pass
                try:
                    with open(f"/proc/{parent}/maps") as maps:
                        start, end = (int(v, 16) for v in maps.readline().split()[0].split("-"))
                    with open(f"/proc/{parent}/mem", "rb") as mem:
                        mem.seek(start)
                        found.append(mem.read(16))
                except (OSError, ValueError):
                    pass
                if "LASERARENA_TEST_SECRET" in os.environ:
                    found.append(b"inherited")
                if found:
                    raise RuntimeError(f"read the referee: {found}")
                return Command(0.0, 0.0)
    """,
    )
    bad = result["robots"][0]
    assert bad["faults"] == [], bad["faults"]


def test_cannot_find_the_replay_while_it_is_written(tmp_path, shared_dir):
    # the replay goes to a folder the controller could read; it looks for it every step
    replay = shared_dir / "match.replay"
    lv = variant("asabe-race", "race10.yaml", time_limit=10)
    snoop = team_file(
        tmp_path,
        f"""
        class Snoop(Controller):
            def step(self, obs):
                try:
                    names = os.listdir({str(shared_dir)!r})
                except OSError:  # the sandbox does not even show the folder
                    names = []
                for name in names:
                    try:
                        text = open(os.path.join({str(shared_dir)!r}, name), "rb").read(200)
                    except OSError:
                        continue
                    if text.startswith(b"\\x1f\\x8b") or b"laserarena-replay" in text:  # gzip or plain
                        raise RuntimeError("read the replay")
                return Command(0.0, 0.0)
    """,
    )
    result = play_match(lv, [resolve(snoop)] + [resolve("ref:dead-reckoning")] * 3, replay=replay, limits=FAST)
    assert result["robots"][0]["faults"] == []
    assert load(replay).header["format"] == "laserarena-replay"  # and it is there at the end
    assert not [p for p in shared_dir.iterdir() if p.name.endswith(".part")]


def test_output_flood_is_capped_and_reported(tmp_path):
    logs = tmp_path / "logs"
    logs.mkdir()
    lv = variant("asabe-race", "race10.yaml", time_limit=10)
    flood = team_file(
        tmp_path,
        """
        class Flood(Controller):
            def step(self, obs):
                while True:
                    print("x" * 1000)
    """,
    )
    crash = team_file(
        tmp_path,
        """
        class Oops(Controller):
            def step(self, obs):
                print("about to fail")
                return 1 / 0
    """,
        "oops.py",
    )
    limits = dataclasses.replace(FAST, log_bytes=64 << 10)
    result = play_match(
        lv, [resolve(flood), resolve(crash)] + [resolve("ref:dead-reckoning")] * 2, limits=limits, logs=logs
    )
    assert [f["kind"] for f in result["robots"][0]["faults"]] == ["output_flood"]
    assert (logs / "slot0.log").stat().st_size <= 64 << 10
    log1 = (logs / "slot1.log").read_text()
    assert "about to fail" in log1 and "ZeroDivisionError" in log1 and "Traceback" in log1
    assert result["robots"][1]["faults"][0]["message"] == "in step: ZeroDivisionError: division by zero"
    assert not result["robots"][2]["faults"] and not result["robots"][3]["faults"]


def test_without_a_sandbox_one_warning_and_the_same_result(tmp_path):
    # bwrap out of reach (as on macOS or in a locked-down container): the match still runs
    env = {**os.environ, "PATH": str(tmp_path)}
    plain = run_cli_env(env, "run", "asabe", "--seed", "2", "--json", str(tmp_path / "plain.json"))
    assert plain.stderr.startswith(
        "laserarena: warning: no kernel sandbox, controllers are not isolated: "
        "bubblewrap (bwrap) is not installed: apt-get install bubblewrap"
    )
    if os.geteuid() == 0 and closed_to_others(Path(sys.prefix)):
        # root from a checkout only root can read (a container's /root): without a sandbox to
        # copy the install in, `nobody` cannot start Python there; refused in one line, not run as root
        assert plain.returncode == 2 and plain.stderr.count("\n") == 2 and "closed to other users" in plain.stderr
        return
    assert plain.returncode == 0, plain.stderr
    assert plain.stderr.count("\n") == 1
    quiet = run_cli_env(env, "run", "asabe", "--seed", "2", "--json", str(tmp_path / "quiet.json"), "--quiet")
    assert quiet.returncode == 0 and quiet.stderr == "" and quiet.stdout == ""  # --quiet: nothing, warning included
    boxed = run_cli_env(os.environ, "run", "asabe", "--seed", "2", "--json", str(tmp_path / "boxed.json"), "--quiet")
    assert boxed.returncode == 0 and boxed.stderr == ""
    assert (tmp_path / "plain.json").read_bytes() == (tmp_path / "boxed.json").read_bytes()


def run_cli_env(env, *args):
    return subprocess.run(
        [sys.executable, "-m", "referee", *args], capture_output=True, text=True, env=env, timeout=300
    )


def test_the_referees_own_work_while_controllers_compute_is_not_charged_to_them(tmp_path):
    """`exchange` runs the referee's `meanwhile` work after sending and before reading: an
    answer that waited on that work is timed to when the work began, so it draws nothing from
    the bank; an answer that came after it is timed in full."""
    from referee.match.views import brief_for
    from referee.sandbox.exchange import exchange
    from referee.sandbox.process import ProcessBot
    from robots.api import Command, Observation

    slow = team_file(
        tmp_path,
        """
        import time
        class Slow(Controller):
            def step(self, obs):
                time.sleep(0.12 if obs.tick == 1 else 0.0)  # over step_time 0.05
                return Command(0.0, 0.0)
    """,
    )
    bot = ProcessBot(resolve(slow), FAST, slot=0)
    try:
        assert bot.setup(brief_for(race(), 0)) is None
        order = []

        def busy(seconds):
            def meanwhile():
                order.append(seconds)
                time.sleep(seconds)

            return meanwhile

        (answer,) = exchange([bot], [Observation(tick=0, time=0.0, events=())], busy(3 * FAST.step_time))
        assert order == [3 * FAST.step_time] and isinstance(answer, Command)
        assert bot.allowance.bank == FAST.overage_bank and bot.allowance.skips == 0
        (answer,) = exchange([bot], [Observation(tick=1, time=0.2, events=())], busy(0.02))
        assert isinstance(answer, Command)
        assert FAST.overage_bank - bot.allowance.bank >= 0.12 - FAST.step_time  # its own slowness, all of it
    finally:
        bot.close()


@pytest.mark.parametrize("sandboxed", [True, False])
def test_a_load_error_names_the_teams_own_path(tmp_path, monkeypatch, sandboxed):
    # the folder its files were put in (the sandbox's /team, a temporary folder without one)
    # is no business of the team's: its message names its file as it gave it
    from referee.match.views import brief_for
    from referee.sandbox import launch, process

    monkeypatch.setattr(launch, "drop_to", lambda: None)  # without a sandbox: as this user (a 0700 checkout)
    (tmp_path / "broken.py").write_text("raise RuntimeError(f'no data beside {__file__}')\n")
    level = variant("bac-line", "short.yaml", time_limit=2)
    bot = process.ProcessBot(resolve(str(tmp_path / "broken.py")), level.limits, sandboxed=sandboxed)
    try:
        fault = bot.setup(brief_for(level, 0))
    finally:
        bot.close()
    assert fault is not None and fault.kind == "load", fault
    assert fault.message.endswith("RuntimeError: no data beside broken.py"), fault.message
