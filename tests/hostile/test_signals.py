"""A controller that signals or traces every process it can name reaches only its own sandbox."""

from hostile.hostile_kit import assert_contained, hostile_match


def test_kill_minus_one_kills_nobody_else(tmp_path):
    # the classic: SIGKILL to every process the caller may signal, at its 4th step
    result = hostile_match(
        tmp_path,
        """
        class Killer(Controller):
            def step(self, obs):
                if obs.tick == 3:
                    try:
                        os.kill(-1, signal.SIGKILL)
                    except ProcessLookupError:
                        pass  # no other process in its PID namespace
                    raise RuntimeError(f"contained: still alive as pid {os.getpid()}")
                return Command(0.05, 0.05)
    """,
    )
    assert_contained(result)
    assert result["robots"][0]["faults"][0]["tick"] == 3


def test_sigstop_of_every_pid_stops_nobody_else(tmp_path):
    result = hostile_match(
        tmp_path,
        """
        class Freezer(Controller):
            def step(self, obs):
                if obs.tick == 3:
                    stopped = []
                    try:
                        os.kill(-1, signal.SIGSTOP)
                    except ProcessLookupError:
                        pass
                    for pid in range(1, 1 << 15):  # the host's controllers have pids in this range too
                        if pid == os.getpid():
                            continue
                        try:
                            os.kill(pid, signal.SIGSTOP)
                            stopped.append(pid)
                        except OSError:
                            pass
                    raise RuntimeError(f"contained: stopped {stopped}" if not stopped else f"LEAK: stopped {stopped}")
                return Command(0.05, 0.05)
    """,
    )
    assert_contained(result, words="contained: stopped []")


def test_ptrace_reaches_nothing(tmp_path):
    result = hostile_match(
        tmp_path,
        """
        import ctypes
        PTRACE_ATTACH = 16
        class Tracer(Controller):
            def step(self, obs):
                if obs.tick == 3:
                    libc = ctypes.CDLL(None, use_errno=True)
                    traced = [pid for pid in [1, os.getppid()] + list(range(2, 4096))
                              if pid != os.getpid() and libc.ptrace(PTRACE_ATTACH, pid, 0, 0) == 0]
                    peeked = []
                    for pid in {1, os.getppid()} - {os.getpid()}:  # its namespace's init, its parent
                        try:
                            peeked.append(open(f"/proc/{pid}/environ", "rb").read(64))
                        except OSError:
                            pass
                    raise RuntimeError(f"contained: traced {traced} peeked {len(peeked)}"
                                       if not traced and not peeked else f"LEAK: traced {traced} peeked {peeked}")
                return Command(0.05, 0.05)
    """,
    )
    assert_contained(result, words="contained: traced [] peeked 0")


def test_a_fork_bomb_stops_at_the_slots_process_limit(tmp_path):
    # forks until the kernel refuses; every child sleeps. The slot's own uid has a process
    # limit, its PID namespace takes every child down with it at the end
    result = hostile_match(
        tmp_path,
        """
        import time

        class Bomb(Controller):
            def step(self, obs):
                if obs.tick == 3:
                    children = 0
                    try:
                        while children < 100_000:
                            if os.fork() == 0:
                                time.sleep(600)
                                os._exit(0)
                            children += 1
                    except OSError as e:
                        raise RuntimeError(f"contained: fork refused after {children} children ({e.errno})")
                    raise RuntimeError(f"LEAK: {children} children")
                return Command(0.05, 0.05)
    """,
    )
    bad = assert_contained(result, slow=True)  # a hundred forks may outlast a step's deadline when loaded
    assert "fork refused after" in bad["faults"][-1]["message"]
