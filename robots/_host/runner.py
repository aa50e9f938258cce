"""The controller process: `python -m robots._host.runner SPEC [--path DIR] [--memory BYTES] [--max-procs N] [--join FDS]`.

Started by the referee as a fresh interpreter whose import path holds the standard library and
`robots` only. It joins the slot's control groups (`--join`: descriptors of their
`cgroup.procs` the referee opened), sets its own resource limits, then appends the team's folder (`--path`) to
the import path, after the standard library's (a team's `resource.py` or `robots` package
replaces nothing of ours), keeps the protocol on private copies of stdin and stdout, and sends
everything the team prints to stderr (the team's log, a pipe the referee reads and caps). Then it loads the team's class and
says `loaded` (a process that ends before that failed to load: a `load` fault), and answers
the referee's messages until `stop` or end of input. A team exception is reported
as a `fault` message (the traceback goes to the team's log) and the process ends.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from typing import Any, Final

from robots._host import loading, protocol
from robots._host.loading import LoadError, load_class
from robots._host.tracebacks import team_traceback
from robots.api import Brief, Observation


def _private_channel() -> tuple:
    """Move the protocol to private file descriptors; fd 0 reads nothing, fd 1 goes to the log."""
    proto_in = os.fdopen(os.dup(0), "rb", buffering=0)
    proto_out = os.fdopen(os.dup(1), "wb")
    devnull = os.open(os.devnull, os.O_RDONLY)
    os.dup2(devnull, 0)
    os.close(devnull)
    os.dup2(2, 1)
    sys.stdout = os.fdopen(1, "w", buffering=1, closefd=False)
    return proto_in, proto_out


READ_SIZE = 1 << 16  # bytes asked of the pipe at once: a message's header and body come in one read


class _Reader:
    """Exact reads (`read(n)`: n bytes, fewer only at end of stream) on an unbuffered pipe,
    buffered: the frame's header and its message come in one read, not two."""

    def __init__(self, stream: Any):
        self.stream, self.buf = stream, b""

    def read(self, n: int) -> bytes:
        while len(self.buf) < n:
            chunk = self.stream.read(max(n - len(self.buf), READ_SIZE))
            if not chunk:
                break
            self.buf += chunk
        out, self.buf = self.buf[:n], self.buf[n:]
        return out


def _fault(out, kind: protocol.FaultKind, where: str, e: BaseException) -> None:
    sys.stderr.write(team_traceback(e, globals(), vars(loading)))
    message = f"in {where}: {protocol.describe(e)}"
    protocol.write(out, protocol.FaultMsg(v=protocol.PROTOCOL_VERSION, kind=kind, message=message))


def _built(cls, brief):
    controller = cls()
    controller.setup(brief)
    return controller


def _guarded(out, where: str, call: Callable[..., Any], *args: object) -> tuple[bool, Any]:
    """Run the team's code, `call(*args)`: (True, its value), or report a fault (memory or
    exception) and return (False, None). A team's SystemExit counts too: it ends the controller."""
    try:
        return True, call(*args)
    except MemoryError as e:
        _fault(out, protocol.FaultKind.MEMORY, where, e)
    except BaseException as e:
        _fault(out, protocol.FaultKind.EXCEPTION, where, e)
    return False, None


def _limit(name: str, value: int, what: str) -> bool:
    """Set resource limit `name` to `value`; where this system has no such limit (Windows has
    no `resource`, macOS refuses RLIMIT_AS) say so in one line of the team's log and go on."""
    try:
        import resource

        resource.setrlimit(getattr(resource, name), (value, value))
        return True
    except (ImportError, AttributeError, ValueError, OSError) as e:
        print(
            f"laserarena: warning: no {what} limit on this system ({name}: {type(e).__name__}); "
            f"the controller runs without it",
            file=sys.stderr,
        )
        return False


OPTIONS = ("--memory", "--max-procs")
USAGE = "usage: python -m robots._host.runner SPEC [--path DIR] [--memory BYTES] [--max-procs N] [--join FDS]"
TEXT_OPTIONS = ("--path", "--join")


def options(argv: list[str]) -> tuple[str, dict[str, str], dict[str, int]]:
    """SPEC, the text options (`--path`: the team's folder; `--join`: descriptors to join,
    comma-separated) and the limits from the command line: `--memory` (address space, bytes), `--max-procs` (processes and threads of this user
    at once, only for a uid of its own); each 0 (none) when absent. Read by hand: building
    argparse's parser was a sixth of the CPU of a controller forked from the template.
    SystemExit, with the usage, on bad input."""
    spec, text, limits, args = None, dict[str, str](), dict.fromkeys(OPTIONS, 0), list(argv)
    while args:
        arg = args.pop(0)
        name, equals, value = arg.partition("=")
        if name in (*OPTIONS, *TEXT_OPTIONS):
            if not equals and not args:
                raise SystemExit(f"{USAGE}\nrobots.runner: {name} needs a value")
            value = value if equals else args.pop(0)
            if name in TEXT_OPTIONS:
                text[name] = value
                continue
            try:
                limits[name] = int(value)
            except ValueError:
                raise SystemExit(f"{USAGE}\nrobots.runner: {name}: not a whole number: {value!r}") from None
        elif spec is None and not arg.startswith("--"):
            spec = arg
        else:
            raise SystemExit(f"{USAGE}\nrobots.runner: unexpected argument {arg!r}")
    if spec is None:
        raise SystemExit(f"{USAGE}\nrobots.runner: the controller's SPEC is missing")
    return spec, text, limits


def _join(fds: str) -> None:
    """Join the control groups whose `cgroup.procs` are open as `fds`, then close them: all this
    process and its children hold is counted there from now on. OSError if the kernel refuses."""
    for fd in (int(f) for f in fds.split(",")):
        os.write(fd, b"0")
        os.close(fd)


def main(argv: list[str] | None = None) -> int:
    spec, text, limits = options(sys.argv[1:] if argv is None else argv)
    memory, max_procs = (limits[name] for name in OPTIONS)
    path = text.get("--path")
    if "--join" in text:
        _join(text["--join"])
    # whatever the referee's own limits allow: no core dump (the host's core_pattern may hand it
    # to a handler writing to the host's disk), no real-time priority (a busy loop would starve
    # the referee and the other controllers)
    _limit("RLIMIT_CORE", 0, "core dump")
    _limit("RLIMIT_RTPRIO", 0, "real-time priority")
    if max_procs:  # a fork bomb stops at the limit: fork() fails inside the sandbox
        _limit("RLIMIT_NPROC", max_procs, "process count")
    if memory:
        _limit("RLIMIT_AS", memory, "memory")
    if path:  # last: the standard library and `robots` come first, whatever the team names its modules
        sys.path.append(path)
    raw_in, out = _private_channel()
    inp = _Reader(raw_in)
    v: Final = protocol.PROTOCOL_VERSION
    try:
        cls = load_class(spec)
    except LoadError as e:
        if e.__cause__ is not None:  # the team's code raised as it loaded: its traceback names the line
            sys.stderr.write(team_traceback(e.__cause__, globals(), vars(loading)))
        protocol.write(out, protocol.FaultMsg(v=v, kind=protocol.FaultKind.LOAD, message=str(e)))
        return 1
    except BaseException as e:  # anything else the team's module does while it loads
        _fault(out, protocol.FaultKind.LOAD, "loading", e)
        return 1
    api = getattr(cls, "api_version", None)
    protocol.write(out, protocol.Loaded(v=v, api=api if isinstance(api, int) and not isinstance(api, bool) else -1))
    return _answer(cls, inp, out)


def _answer(cls: type, inp, out) -> int:
    """Answer the referee's messages with a controller of class `cls` until `stop` or end of
    input (0), or until the team's code fails (1, its fault reported)."""
    v: Final = protocol.PROTOCOL_VERSION
    controller = None
    while True:
        match protocol.read(inp):
            case None | protocol.Stop():
                return 0
            case protocol.Setup(brief=raw):
                ok, controller = _guarded(out, "setup", _built, cls, protocol.decoded(raw, Brief))
                if not ok:
                    return 1
                protocol.write(out, protocol.Ready(v=v))
            case protocol.Step(obs=raw) if controller is not None:
                obs = protocol.decoded(raw, Observation)
                ok, cmd = _guarded(out, "step", controller.step, obs)
                if not ok:
                    return 1
                cmd = protocol.sendable(cmd)  # drawings that cannot be drawn travel as warnings
                problem = protocol.command_problem(cmd)  # the same words as the referee-side check
                if problem:
                    protocol.write(out, protocol.FaultMsg(v=v, kind=protocol.FaultKind.BAD_COMMAND, message=problem))
                    return 1
                protocol.write(out, protocol.CommandMsg(v=v, tick=obs.tick, command=cmd))
            case msg:
                raise protocol.ProtocolError(f"unexpected message {msg.__struct_config__.tag!r}")


if __name__ == "__main__":
    raise SystemExit(main())
