"""Attacks a team could try on a controller forked from the template (root referee): the
template's process, sockets and namespaces, what the fork shares, the
exchange's timing, kernel objects that outlive a process, leftovers. Each test keeps one
attack and checks it was contained: the others unharmed, a typed fault, nothing left behind
(the fixture), and the template holding no slot once the match is over."""

import dataclasses
import errno
import hashlib
import os
import secrets
import subprocess
import time
from pathlib import Path

import pytest

from hostile.hostile_kit import (
    FAST,
    HONEST,
    assert_contained,
    assert_ended_for_memory,
    assert_others_unharmed,
    hostile_match,
    short_race,
    team_file,
)
from referee.match.loop import play_match
from referee.sandbox import forkserver, kernel
from referee.sandbox.teams import resolve
from referee.sandbox.uids import slot_uid

pytestmark = pytest.mark.skipif(os.geteuid() != 0, reason="the template serves a root referee only")

# the controller's protocol channel: the runner's private copies of its stdin and stdout (pipes)
PROTOCOL_OUT = """
import fcntl
def protocol_end(mode):
    for fd in range(3, 64):
        try:
            if fcntl.fcntl(fd, fcntl.F_GETFL) & os.O_ACCMODE == mode and os.readlink(f"/proc/self/fd/{fd}").startswith("pipe:"):
                return fd
        except OSError:
            pass
def protocol_out():
    return protocol_end(os.O_WRONLY)
def protocol_in():
    return protocol_end(os.O_RDONLY)
"""


def _below(root: int) -> dict[int, tuple[int, str]]:
    """Every live process below `root`: pid -> (parent pid, command name), from one /proc scan."""
    parents: dict[int, tuple[int, str]] = {}
    for entry in os.scandir("/proc"):
        if entry.name.isdigit():
            try:
                stat = Path(entry.path, "stat").read_text()
                name, rest = stat[stat.index("(") + 1 : stat.rindex(")")], stat[stat.rindex(")") + 2 :].split()
                if rest[0] != "Z":
                    parents[int(entry.name)] = (int(rest[1]), name)
            except (OSError, ValueError, IndexError):
                continue  # ended while we looked
    below, todo = {}, [root]
    while todo:
        parent = todo.pop()
        for pid, (ppid, name) in parents.items():
            if ppid == parent and pid not in below:
                below[pid] = (ppid, name)
                todo.append(pid)
    return below


_EARLIER: set[int] = set()  # what ran below this process before the test began


@pytest.fixture(autouse=True)
def _earlier_processes():
    """Note what already runs below this process when a test begins: helpers that earlier
    tests in the same process started (multiprocessing's resource tracker, say, where a
    worker of `make test` runs several modules), not the referee's."""
    _EARLIER.clear()
    _EARLIER.update(_below(os.getpid()))
    yield


def assert_template_idle(timeout: float = 5.0) -> None:
    """Nothing this test started runs below the referee but its templates (bwrap and the
    template it starts): every slot's controller has ended (a bounded wait for the last of them)."""
    assert forkserver.server() is not None, forkserver.unavailable()
    deadline = time.monotonic() + timeout
    while True:
        below = _below(os.getpid())
        left = {
            pid: name
            for pid, (ppid, name) in below.items()
            if pid not in _EARLIER
            and name != "bwrap"
            and below.get(ppid, (0, ""))[1] != "bwrap"  # a template: bwrap's child
        }
        if not left or time.monotonic() > deadline:
            break
        time.sleep(0.05)
    assert left == {}, f"still running below the referee: {left}"


def test_closing_its_channel_and_living_on_does_not_hang_the_referee(tmp_path):
    # the referee sees the end of the controller's output: it must not then wait for ever for
    # a process that lives on (here for 30 s, then it would exit with code 1)
    result = hostile_match(
        tmp_path,
        PROTOCOL_OUT
        + """
class Mute(Controller):
    def step(self, obs):
        if obs.tick == 3:
            os.close(protocol_out())
            time.sleep(30)
        return Command(0.05, 0.05)
""",
    )
    bad = assert_contained(result, kind="protocol", words="closed its output")
    assert bad["faults"][0]["tick"] == 3
    assert_template_idle()


def test_signals_to_everything_it_can_name_leave_the_template_alone(tmp_path):
    # its parent (the template) is out of its PID namespace: no pid, no
    # pidfd, no /proc entry, no process group or session of theirs to signal
    result = hostile_match(
        tmp_path,
        """
import ctypes
class Parricide(Controller):
    def step(self, obs):
        if obs.tick != 3:
            return Command(0.05, 0.05)
        libc = ctypes.CDLL(None, use_errno=True)
        seen = {"ppid": os.getppid(), "pids": sorted(int(p) for p in os.listdir("/proc") if p.isdigit())}
        status = dict(l.split(":", 1) for l in open("/proc/self/status") if ":" in l)
        seen["nspid"] = status["NSpid"].split()
        pidfds = []
        for pid in range(2, 4096):
            fd = libc.syscall(434, pid, 0)  # pidfd_open
            if fd >= 0:
                pidfds.append(pid)
        for pid in range(2, 1 << 15):
            try:
                os.kill(pid, signal.SIGKILL)
                pidfds.append(("killed", pid))
            except OSError:
                pass
        for target in (0, os.getpgid(0), os.getsid(0)):
            try:
                os.killpg(target, signal.SIGCONT)  # its own group only: harmless
            except OSError:
                pass
        ok = seen == {"ppid": 0, "pids": [1], "nspid": seen["nspid"]} and seen["nspid"][-1] == "1" and not pidfds
        raise RuntimeError(("contained: " if ok else "LEAK: ") + repr((seen, pidfds)))
""",
    )
    assert_contained(result)
    assert_template_idle()


def test_namespaces_of_its_own_give_it_nothing_of_the_others(tmp_path):
    # setns needs a capability it has not; a user namespace of its own (where the kernel allows
    # one) gives it capabilities over copies of its own mounts only, and those are locked: it
    # cannot uncover what lies below its /proc, /tmp or /team
    result = hostile_match(
        tmp_path,
        """
import ctypes
CLONE_NEWUSER, CLONE_NEWNS, MNT_DETACH = 0x10000000, 0x00020000, 2
class Escaper(Controller):
    def step(self, obs):
        if obs.tick != 3:
            return Command(0.05, 0.05)
        libc = ctypes.CDLL(None, use_errno=True)
        joined = []
        for name in os.listdir("/proc/1/ns"):
            fd = os.open(f"/proc/1/ns/{name}", os.O_RDONLY)
            if libc.setns(fd, 0) == 0:
                joined.append(name)
            os.close(fd)
        pids_before = sorted(p for p in os.listdir("/proc") if p.isdigit())
        uncovered = []
        if libc.unshare(CLONE_NEWUSER | CLONE_NEWNS) == 0:
            points = [l.split()[4] for l in open("/proc/self/mountinfo")]
            for point in reversed(points):
                if libc.umount2(point.encode(), MNT_DETACH) == 0:
                    uncovered.append(point)
        pids_after = sorted(p for p in os.listdir("/proc") if p.isdigit())
        ok = not joined and not uncovered and pids_before == pids_after == ["1"]
        raise RuntimeError(("contained: " if ok else "LEAK: ") + repr((joined, uncovered, pids_after)))
""",
    )
    assert_contained(result)


def test_abstract_sockets_and_ipc_of_one_slot_are_out_of_anothers_reach(tmp_path):
    # abstract unix sockets belong to a network namespace, System V IPC and POSIX message
    # queues to an IPC namespace: each slot has its own of both
    writer = team_file(
        tmp_path,
        """
import ctypes, socket
class Writer(Controller):
    def setup(self, brief):
        libc = ctypes.CDLL(None, use_errno=True)
        self.listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.listener.bind(b"\\0laserarena-redteam")
        self.listener.listen()
        self.dgram = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        self.dgram.bind(b"\\0laserarena-redteam-dgram")
        assert libc.shmget(0x5151, 4096, 0o1666) >= 0  # IPC_CREAT | 0666
        assert libc.msgget(0x5151, 0o1666) >= 0
        assert libc.semget(0x5151, 1, 0o1666) >= 0
        libc.mq_open.restype = ctypes.c_int
        assert libc.mq_open(b"/laserarena-redteam", os.O_CREAT | os.O_RDWR, 0o666, None) >= 0
    def step(self, obs):
        return Command(0.0, 0.0)
""",
        "writer.py",
    )
    reader = team_file(
        tmp_path,
        """
import ctypes, socket
class Reader(Controller):
    def step(self, obs):
        if obs.tick < 4:
            return Command(0.0, 0.0)
        libc = ctypes.CDLL(None, use_errno=True)
        reached = []
        for name, kind in ((b"\\0laserarena-redteam", socket.SOCK_STREAM), (b"\\0laserarena-redteam-dgram", socket.SOCK_DGRAM)):
            s = socket.socket(socket.AF_UNIX, kind)
            try:
                s.connect(name)
                reached.append(name)
            except OSError:
                pass
            s.close()
        if libc.shmget(0x5151, 0, 0) >= 0: reached.append("shm")
        if libc.msgget(0x5151, 0) >= 0: reached.append("msg")
        if libc.semget(0x5151, 0, 0) >= 0: reached.append("sem")
        if libc.mq_open(b"/laserarena-redteam", os.O_RDONLY) >= 0: reached.append("mqueue")
        names = [l.split()[-1] for l in open("/proc/net/unix").readlines()[1:] if l.split()[-1].startswith("@")]
        raise RuntimeError("contained: reached nothing" if not reached and not names else f"LEAK: {reached} {names}")
""",
        "reader.py",
    )
    result = play_match(
        short_race(), [resolve(writer), resolve(reader), resolve(HONEST), resolve(HONEST)], seed=2, limits=FAST
    )
    assert result["robots"][0]["faults"] == []
    assert [f["message"] for f in result["robots"][1]["faults"]] == [
        "in step: RuntimeError: contained: reached nothing"
    ]
    assert_template_idle()


def _scanner(prefix: str, digest: str) -> str:
    """A controller that reads every page of its own memory (what the fork shared with the
    template included) for `prefix` followed by the text whose sha256 is `digest`."""
    return f"""
import dataclasses
import hashlib
PREFIX, DIGEST = {prefix!r}.encode(), {digest!r}
class Scanner(Controller):
    def setup(self, brief):
        found, scanned = [], 0
        mem = os.open("/proc/self/mem", os.O_RDONLY)
        for line in open("/proc/self/maps").readlines():
            span, perms = line.split()[:2]
            if not perms.startswith("r"):
                continue
            start, end = (int(x, 16) for x in span.split("-"))
            for at in range(start, end, 1 << 22):
                try:
                    chunk = os.pread(mem, min(1 << 22, end - at) + 64, at)
                except OSError:
                    break
                scanned += len(chunk)
                hit = chunk.find(PREFIX)
                while hit >= 0:
                    tail = chunk[hit:hit + 64]
                    if hashlib.sha256(tail).hexdigest() == DIGEST:
                        found.append(hex(at + hit))
                    hit = chunk.find(PREFIX, hit + 1)
        raise RuntimeError(("contained: " if not found and scanned > 1 << 20 else "LEAK: ") + repr(found))
"""


def test_its_memory_holds_no_other_teams_code_and_no_noise_key(tmp_path):
    # the pages it shares with the template (copied on write) were never another slot's: the
    # template reads nothing of a team and no secret; whatever the referee knows stays there
    key = secrets.token_hex(32)  # the grader's noise key: 64 hex characters
    mark = "REDTEAM" + secrets.token_hex(28) + "X"  # 64 characters in the other team's code
    for text, name in ((key, "key"), (mark, "mark")):
        scanner = team_file(tmp_path, _scanner(text[:7], hashlib.sha256(text.encode()).hexdigest()), f"scan_{name}.py")
        other = team_file(
            tmp_path,
            f"class Other(Controller):\n    MARK = {mark!r}\n    def step(self, obs): return Command(0, 0)\n",
            "other.py",
        )
        result = play_match(
            short_race(3),
            [resolve(scanner), resolve(other), resolve(HONEST), resolve(HONEST)],
            seed=2,
            limits=FAST,
            noise_key=key,
        )
        bad = result["robots"][0]
        assert [f["message"] for f in bad["faults"]] == ["in setup: RuntimeError: contained: []"], bad["faults"]
        assert all(not r["faults"] for r in result["robots"][1:])


def test_patching_the_preloaded_modules_changes_no_other_slot(tmp_path):
    # the template imported numpy and the reference controllers before forking: each slot has
    # its own copy, so what one patches (or scribbles over in memory) the others never see
    result = hostile_match(
        tmp_path,
        """
import numpy, numpy.linalg
import robots.controllers.dead_reckoning as honest
def broken(*args, **kwargs):
    raise SystemExit("patched")
class Patcher(Controller):
    def setup(self, brief):
        for module in (numpy, numpy.linalg, honest):
            for name, value in list(vars(module).items()):
                if callable(value) and not name.startswith("__"):
                    setattr(module, name, broken)
        for cls in vars(honest).values():
            if isinstance(cls, type) and "step" in vars(cls):
                cls.step = broken
    def step(self, obs):
        raise RuntimeError("contained: patched its own copies")
""",
    )
    assert_contained(result)


def test_an_answer_in_pieces_counts_when_whole(tmp_path):
    # the frame arrives one byte at a time, then the rest in three slices: assembled, it is the
    # answer; the robot plays on without a fault
    result = hostile_match(
        tmp_path,
        """
import robots._host.protocol as protocol
whole = protocol.write
class Slow:
    def __init__(self, out):
        self.out, self.data = out, b""
    def write(self, data):
        self.data += data
    def flush(self):
        pass
def dripping(out, msg):
    buf = Slow(out)
    whole(buf, msg)
    data = buf.data
    for i in range(8):
        out.write(data[i:i + 1]); out.flush()
    for part in (data[8:20], data[20:-1], data[-1:]):
        time.sleep(0.002)
        out.write(part); out.flush()
protocol.write = dripping
class Dripper(Controller):
    def step(self, obs):
        return Command(0.05, 0.05, estimate=(0.3, 0.25, 0.0))
""",
        seconds=3,
    )
    assert result["robots"][0]["faults"] == []
    assert_others_unharmed(result)


def test_answering_twice_or_ahead_is_a_protocol_fault(tmp_path):
    # two answers to one observation: the second is read as the next tick's, for the wrong tick
    result = hostile_match(
        tmp_path,
        """
import robots._host.protocol as protocol
whole = protocol.write
def twice(out, msg):
    whole(out, msg)
    if isinstance(msg, protocol.CommandMsg) and msg.tick == 3:
        whole(out, msg)
protocol.write = twice
class Eager(Controller):
    def step(self, obs):
        return Command(0.05, 0.05)
""",
    )
    bad = assert_contained(result, kind="protocol", words="tick 3")
    assert bad["faults"][0]["tick"] == 4


def test_huge_answers_every_tick_cost_the_others_nothing(tmp_path):
    # 3000 drawings of 64 points every tick: the team side sends the 255 a command may hold
    # and one note of the rest; the referee decodes it, and times the others alone
    result = hostile_match(
        tmp_path,
        """
POINTS = [(0.1, 0.2)] * 64
DRAWINGS = [Drawing("line", POINTS) for _ in range(3000)]
class Bloat(Controller):
    def step(self, obs):
        return Command(0.0, 0.0, debug=DRAWINGS)
""",
        seconds=3,
    )
    assert_others_unharmed(result)
    assert_template_idle()


def test_the_kernel_keyrings_are_closed_to_it(tmp_path):
    # a uid's user keyring outlives its processes (the kernel keeps it for the uid): a key left
    # there would be read by the next controller given that uid, and could fill its quota
    result = hostile_match(
        tmp_path,
        """
import ctypes, platform
ADD_KEY = {"x86_64": 248, "aarch64": 217}[platform.machine()]
class Keeper(Controller):
    def step(self, obs):
        if obs.tick != 3:
            return Command(0.05, 0.05)
        libc = ctypes.CDLL(None, use_errno=True)
        kept = [libc.syscall(ADD_KEY, b"user", f"left-{ring}".encode(), b"secret", 6, ring) for ring in (-4, -5, -3)]
        raise RuntimeError(("contained: " if max(kept) < 0 else "LEAK: ") + repr((kept, ctypes.get_errno())))
""",
    )
    assert_contained(result)
    uids = {slot_uid(s) for s in range(4)}
    owners = {int(line.split(":")[0]) for line in Path("/proc/key-users").read_text().splitlines()}
    assert not owners & uids, Path("/proc/key-users").read_text()


def test_pseudo_terminals_stop_at_the_slots_own_few(tmp_path):
    # the kernel has a few thousand ptys for every devpts instance but the host's: one slot
    # that took them all would deny them to every container on the machine
    result = hostile_match(
        tmp_path,
        """
class Hoarder(Controller):
    def step(self, obs):
        if obs.tick != 3:
            return Command(0.05, 0.05)
        import resource
        soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
        resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))
        held = []
        try:
            while len(held) < 400:
                held.append(os.openpty())
        except OSError:
            pass
        raise RuntimeError(("contained: " if len(held) <= 16 else "LEAK: ") + f"{len(held)} ptys")
""",
    )
    assert_contained(result)


def test_answering_ahead_without_reading_does_not_block_the_referee(tmp_path):
    # from tick 3 a thread answers every tick to come while nothing reads the observations:
    # the referee's writes fill the controller's input pipe; a blocking write would hold the
    # match (and every other slot) until the controller chose to read
    result = hostile_match(
        tmp_path,
        PROTOCOL_OUT
        + """
import threading
import robots._host.protocol as protocol
def answer_ahead(out):
    for tick in range(3, 100_000):
        protocol.write(out, protocol.CommandMsg(v=1, tick=tick, command=Command(0.05, 0.05)))
class Deaf(Controller):
    def step(self, obs):
        if obs.tick == 3:
            try:
                fcntl.fcntl(protocol_in(), 1031, 4096)  # F_SETPIPE_SZ: one page, full at once
            except PermissionError:
                pass  # refused in a sandbox: the pipe keeps its 64 KiB, full a little later
            out = os.fdopen(os.dup(protocol_out()), "wb")
            threading.Thread(target=answer_ahead, args=(out,), daemon=True).start()
            time.sleep(600)
        return Command(0.05, 0.05)
""",
        seconds=120,  # long enough for its unread observations to fill 64 KiB
    )
    bad = assert_contained(result, kind="protocol", words="its observations")  # unread; answered unread
    assert "without reading" in bad["faults"][0]["message"] or "does not read" in bad["faults"][0]["message"]
    assert_template_idle()


def test_a_fork_bomb_in_one_match_leaves_a_match_in_another_thread_alone(tmp_path):
    # two matches at once in two threads of one referee process (a Dask worker with several
    # threads does this): slot 0 of one holds every process its uid may have; slot 0 of the
    # other still starts a thread
    import threading

    bomb = team_file(
        tmp_path,
        """
class Bomb(Controller):
    def setup(self, brief):
        try:
            while True:
                if os.fork() == 0:
                    time.sleep(600)
                    os._exit(0)
        except OSError:
            pass
        open("/dev/null", "w").write("")
    def step(self, obs):
        return Command(0.0, 0.0)
""",
        "bomb.py",
    )
    probe = team_file(
        tmp_path,
        """
import threading
class Probe(Controller):
    def step(self, obs):
        try:
            t = threading.Thread(target=lambda: None)
            t.start()
            t.join()
        except RuntimeError as e:
            raise RuntimeError(f"LEAK: no thread at tick {obs.tick}")
        if obs.tick == 25:
            raise RuntimeError("contained: started a thread every tick")
        return Command(0.0, 0.0)
""",
        "probe.py",
    )
    results: dict[str, dict] = {}
    started = threading.Barrier(2)

    def play(name: str, first: str, seconds: float) -> None:
        started.wait(timeout=30)
        results[name] = play_match(short_race(seconds), [resolve(first)] + [resolve(HONEST)] * 3, seed=2, limits=FAST)

    threads = [
        threading.Thread(target=play, args=("bomb", bomb, 6.0)),
        threading.Thread(target=play, args=("probe", probe, 6.0)),
    ]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=120)
    assert results["bomb"]["robots"][0]["faults"] == []
    assert [f["message"] for f in results["probe"]["robots"][0]["faults"]] == [
        "in step: RuntimeError: contained: started a thread every tick"
    ]


def test_memory_held_through_descriptors_stays_within_the_limit(tmp_path):
    # memfd pages written through the descriptor are never mapped: RLIMIT_AS does not see them;
    # the slot's memory cgroup counts them, and its out-of-memory killer ends the hoarder alone
    limits = dataclasses.replace(FAST, memory=256 << 20)
    result = hostile_match(
        tmp_path,
        """
import resource
class Hoarder(Controller):
    def step(self, obs):
        if obs.tick != 3:
            return Command(0.05, 0.05)
        soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
        resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))
        limit, block, held = resource.getrlimit(resource.RLIMIT_AS)[0], b"x" * (1 << 19), []
        try:
            while len(held) * len(block) < limit * 3 // 2:
                fd = os.memfd_create("hoard")
                os.write(fd, block)
                held.append(fd)
        except OSError:
            pass
        pinned = len(held) * len(block)
        raise RuntimeError(("contained: " if pinned <= limit else "LEAK: ") + f"{pinned >> 20} MiB held beyond its {limit >> 20} MiB")
""",
        limits=limits,
    )
    assert_ended_for_memory(result, 256)


def test_a_daemon_in_a_nested_pid_namespace_dies_with_its_slot(tmp_path):
    # a daemon that double-forks into a user and PID namespace of its own (where the kernel
    # lets it), ignores every signal it can: it is still inside its slot's PID namespace
    result = hostile_match(
        tmp_path,
        """
import ctypes
CLONE_NEWUSER, CLONE_NEWPID = 0x10000000, 0x20000000
def setsid():  # refused in a sandbox (a slot's processes stay in its session): it tries anyway
    try:
        os.setsid()
    except PermissionError:
        pass
class Hider(Controller):
    def setup(self, brief):
        if os.fork() == 0:
            setsid()
            ctypes.CDLL(None).unshare(CLONE_NEWUSER | CLONE_NEWPID)
            if os.fork() == 0:  # the nested namespace's init
                for sig in (signal.SIGTERM, signal.SIGHUP, signal.SIGINT):
                    signal.signal(sig, signal.SIG_IGN)
                if os.fork() == 0:
                    setsid()
                    while True:
                        time.sleep(0.05)
                while True:
                    time.sleep(0.05)
            os._exit(0)
    def step(self, obs):
        if obs.tick == 3:
            raise RuntimeError("contained: hidden away")
        return Command(0.05, 0.05)
""",
    )
    assert_contained(result)
    assert_template_idle()


def test_no_core_dump_and_no_real_time_priority(tmp_path):
    # a core dump goes where the host's core_pattern says (a pipe to the host's handler on many
    # systems: its disk); a real-time priority would let a busy loop starve everyone else
    result = hostile_match(
        tmp_path,
        """
import resource
class Greedy(Controller):
    def step(self, obs):
        if obs.tick != 3:
            return Command(0.05, 0.05)
        got = []
        for name in ("RLIMIT_CORE", "RLIMIT_RTPRIO"):
            limit = getattr(resource, name)
            try:
                resource.setrlimit(limit, (resource.RLIM_INFINITY, resource.RLIM_INFINITY))
                got.append(name)
            except (ValueError, OSError):
                if resource.getrlimit(limit)[1] != 0:
                    got.append(name)
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(1))
            got.append("SCHED_FIFO")
        except OSError:
            pass
        raise RuntimeError(("contained: " if not got else "LEAK: ") + repr(got))
""",
    )
    assert_contained(result)


def test_a_spawned_sandbox_is_closed_to_the_keyrings_too():
    # where the template cannot serve, a root referee spawns a bwrap sandbox per controller
    # instead: the same filter comes with it
    adder = (
        "import ctypes, platform; libc = ctypes.CDLL(None, use_errno=True); "
        "nr = {'x86_64': 248, 'aarch64': 217}[platform.machine()]; "
        "print(libc.syscall(nr, b'user', b'left', b'secret', 6, -4), ctypes.get_errno())"
    )
    launch = kernel.launch([kernel.python(), "-c", adder], (), kernel.SANDBOX_ENV, slot_uid(7))
    try:
        done = subprocess.run(launch.argv, pass_fds=launch.pass_fds, capture_output=True, text=True, timeout=60)
    finally:
        for fd in (*launch.pass_fds, launch.info):
            os.close(fd)
    assert done.stdout.split() == ["-1", str(errno.ENOSYS)], done.stderr
    owners = {int(line.split(":")[0]) for line in Path("/proc/key-users").read_text().splitlines()}
    assert slot_uid(7) not in owners


def test_its_log_cannot_take_more_disk_than_the_output_limit(tmp_path):
    # fallocate(KEEP_SIZE) on its log would reserve blocks without growing the file, past any
    # file-size limit: its log is a pipe the referee reads, and fallocate is filtered out anyway
    result = hostile_match(
        tmp_path,
        """
import ctypes
class Filler(Controller):
    def step(self, obs):
        if obs.tick != 3:
            return Command(0.05, 0.05)
        libc = ctypes.CDLL(None, use_errno=True)
        libc.fallocate.argtypes = [ctypes.c_int, ctypes.c_int, ctypes.c_long, ctypes.c_long]
        libc.fallocate(2, 1, 0, 64 << 20)  # FALLOC_FL_KEEP_SIZE
        held = os.fstat(2).st_blocks * 512
        raise RuntimeError(("contained: " if held <= 1 << 20 else "LEAK: ") + f"{held >> 20} MiB of disk")
""",
    )
    assert_contained(result)


def test_posix_fallocate_still_works_within_the_limit(tmp_path):
    # what an honest controller may call: the C library writes zeros when the kernel says
    # EOPNOTSUPP; the space is reserved in its private /tmp, within its memory
    result = hostile_match(
        tmp_path,
        """
class Reserver(Controller):
    def step(self, obs):
        if obs.tick != 3:
            return Command(0.05, 0.05)
        with open("/tmp/reserved", "wb") as f:
            os.posix_fallocate(f.fileno(), 0, 1 << 16)
            size = os.fstat(f.fileno()).st_size
        raise RuntimeError(f"contained: reserved {size} bytes")
""",
    )
    assert_contained(result, words=f"contained: reserved {1 << 16} bytes")


def test_inotify_quota_is_each_slots_own(tmp_path):
    # the kernel counts inotify instances per uid: one slot that takes all
    # of its own leaves another slot's untouched
    taker = team_file(
        tmp_path,
        """
import ctypes, resource
class Taker(Controller):
    def setup(self, brief):
        libc = ctypes.CDLL(None, use_errno=True)
        resource.setrlimit(resource.RLIMIT_NOFILE, (resource.getrlimit(resource.RLIMIT_NOFILE)[1],) * 2)
        self.held = []
        while len(self.held) < 100_000 and (fd := libc.inotify_init1(0)) >= 0:
            self.held.append(fd)
        assert len(self.held) < 100_000
    def step(self, obs):
        return Command(0.0, 0.0)
""",
        "taker.py",
    )
    prober = team_file(
        tmp_path,
        """
import ctypes
class Prober(Controller):
    def step(self, obs):
        if obs.tick < 4:
            return Command(0.0, 0.0)
        fd = ctypes.CDLL(None, use_errno=True).inotify_init1(0)
        raise RuntimeError("contained: an inotify of its own" if fd >= 0 else f"LEAK: errno {ctypes.get_errno()}")
""",
        "prober.py",
    )
    result = play_match(
        short_race(), [resolve(taker), resolve(prober), resolve(HONEST), resolve(HONEST)], seed=2, limits=FAST
    )
    assert result["robots"][0]["faults"] == []
    assert [f["message"] for f in result["robots"][1]["faults"]] == [
        "in step: RuntimeError: contained: an inotify of its own"
    ]
