"""The `laserarena` command line's arguments: one sub-parser per command (`parser`), each
handing its parsed arguments to its `cmd_NAME` in `referee.cli.commands`, loaded only then.

A bad argument prints one line to stderr and exits 2, like every other bad input; `--help`
still shows the usage.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import TYPE_CHECKING, NoReturn

from arena.heap import lasting
from referee.errors import EXIT_BAD_INPUT, UserError
from referee.version import __version__


class _Parser(argparse.ArgumentParser):
    """argparse with its errors on one line (no usage block) and exit code 2, like every other
    bad input; `--help` still shows the usage."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: {message} (see {self.prog} --help)\n")


if TYPE_CHECKING:  # argparse's class is generic to the type checker only
    Commands = argparse._SubParsersAction[_Parser]  # where each command adds its sub-parser


class _Command:
    """A command: its `cmd_NAME`, loaded when it runs (parsing, `--help` and a bad argument
    load none of the commands' modules), after `before(args)`, which may start work that
    overlaps that loading."""

    def __init__(self, name: str, before: Callable[[argparse.Namespace], None] | None = None):
        self.name, self.before = name, before

    def __call__(self, args: argparse.Namespace) -> int:
        if self.before is not None:
            self.before(args)
        with lasting():  # the commands' modules (numpy, the levels' loader, ...) live as long as the process
            from referee.cli import commands
        return int(getattr(commands, f"cmd_{self.name}")(args))


def _template_soon(args: argparse.Namespace) -> None:
    """A root referee's controller template, started before `run` loads its modules: it boots
    on another CPU meanwhile (referee.sandbox.forkserver)."""
    if not args.in_process:
        from referee.sandbox import forkserver

        forkserver.start()


class _NoSecretOnTheCommandLine(argparse.Action):
    """`--secret S`, gone: every local process can read a command line (/proc/PID/cmdline)."""

    def __call__(self, parser, namespace, values, option_string=None) -> NoReturn:
        raise UserError("--secret is gone (other processes can read a command line); use --secret-file FILE")


def _at_least_one(text: str) -> int:
    """A count given on the command line: a whole number, 1 or more (argparse's type)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a whole number: {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def _secret_file(s: argparse._ActionsContainer, what: str) -> None:
    """`--secret-file FILE` (`what` it does with the secret), and `--secret S` refused."""
    s.add_argument(
        "--secret-file",
        metavar="FILE",
        help=f"{what}; at least 128 bits (`laserarena secret new FILE` makes one; docs/integrity.md)",
    )
    s.add_argument("--secret", nargs="?", action=_NoSecretOnTheCommandLine, help=argparse.SUPPRESS)


def _contest_flags(s: argparse.ArgumentParser) -> None:
    """The options `grade` and `tournament` share: the noise secret, and playing unsandboxed."""
    _secret_file(
        s,
        "read the noise secret from FILE (default: the journal's own, made on first use); "
        "every match's noise derives from it",
    )
    s.add_argument(
        "--unsandboxed",
        action="store_true",
        help="play even where no kernel sandbox can be made (controllers then share the machine "
        "with few limits); the journal, leaderboard and report say so",
    )


def _run(sub: Commands) -> None:
    """`laserarena run`: one match, headless."""
    s = sub.add_parser("run", help="run one match headless and print its score table")
    s.add_argument("level", help="a level file or built-in level name")
    s.add_argument(
        "--team",
        action="append",
        metavar="T",
        help="controller for the next robot slot: ref:NAME, FILE.py[:Class], DIR[:Class] (a team folder), "
        "module:Class or an installed controller's NAME",
    )
    s.add_argument("--seed", type=int, help="match seed (default: the level's)")
    s.add_argument(
        "--json", metavar="OUT", help="write the result JSON here (- for stdout; the table then goes to stderr)"
    )
    s.add_argument("--replay", metavar="OUT", help="write the replay here")
    s.add_argument(
        "--ideal",
        action="store_true",
        help="ideal sensors and drive: no noise, no missed or false pulses, no quantization, no drive errors",
    )
    s.add_argument(
        "--in-process",
        action="store_true",
        help="run the controllers inside this process, for a debugger: UNSAFE, the team's code "
        "runs with the referee's rights (never for grading); same results within budget; a fault "
        "prints its whole traceback",
    )
    s.add_argument(
        "--logs",
        metavar="DIR",
        help="keep each controller's output here (slotN.log); without it, nothing is written "
        "(a fault's message and its traceback's tail are in the table and the result)",
    )
    s.add_argument("--no-limits", action="store_true", help="no time or memory limits for the controllers (debugging)")
    s.add_argument("--quiet", action="store_true", help="print nothing on success")
    s.set_defaults(func=_Command("run", before=_template_soon))


def _check(sub: Commands) -> None:
    """`laserarena check`: level files validated."""
    s = sub.add_parser("check", help="validate level files")
    s.add_argument("level", nargs="+")
    s.set_defaults(func=_Command("check"))


def _share(text: str) -> float:
    """A share of the matches given on the command line: a number from 0 to 1 (argparse's type)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not 0 <= value <= 1:
        raise argparse.ArgumentTypeError(f"a share from 0 to 1 (0.05 is 5 %), got {text}")
    return value


def _where(s: argparse.ArgumentParser, action: str) -> None:
    """Where a contest's matches run: local worker processes, or a Dask cluster."""
    s.add_argument("--workers", type=_at_least_one, default=2, help="local worker processes (default 2)")
    s.add_argument(
        "--scheduler",
        metavar="tls://HOST:PORT",
        help=f"{action} on this Dask cluster instead (docs/cluster.md)",
    )
    s.add_argument(
        "--cluster-keys",
        metavar="DIR",
        help="the organizer's keys folder (`laserarena cluster-keys DIR`): the client's certificate and the CA",
    )
    s.add_argument(
        "--insecure-cluster",
        action="store_true",
        help="accept a plain tcp:// scheduler, which any machine that reaches it may join; the results say so",
    )
    s.add_argument(
        "--audit",
        type=_share,
        default=0.05,
        metavar="SHARE",
        help="the share of a cluster's matches played again here and compared byte for byte "
        "(default 0.05; at least one per worker)",
    )


def _grade(sub: Commands) -> None:
    """`laserarena grade`: every team alone on every level and seed, into a leaderboard."""
    what = "grade teams x levels x seeds headless, resumable, into a leaderboard"
    s = sub.add_parser("grade", help=what, description=f"{what[0].upper()}{what[1:]} (docs/contests.md).")
    s.add_argument("level", nargs="+", help="level names or level files")
    s.add_argument("--team", action="append", required=True, metavar="T", help="a team spec (repeat)")
    s.add_argument("--seeds", type=_at_least_one, default=3, help="seeds 1..N per team and level (default 3)")
    _where(s, "grade")
    s.add_argument("--db", default="results.sqlite", help="the journal (default results.sqlite)")
    _contest_flags(s)
    s.add_argument("--out", default="leaderboard.csv", help="the leaderboard CSV (.json and .md beside it)")
    s.add_argument("--quiet", action="store_true")
    s.set_defaults(func=_Command("grade"))


def _tournament(sub: Commands) -> None:
    """`laserarena tournament`: rated heats of the teams racing each other, into a report folder."""
    what = "rated heats of teams racing each other on levels, resumable, into a report folder"
    s = sub.add_parser("tournament", help=what, description=f"{what[0].upper()}{what[1:]} (docs/contests.md).")
    s.add_argument("level", nargs="+", help="level names or level files (their robot slots are the heats' lanes)")
    s.add_argument("--team", action="append", required=True, metavar="T", help="a rated team spec (repeat)")
    s.add_argument(
        "--rounds", type=_at_least_one, default=1, help="rounds; in each, every team starts once from every slot"
    )
    _where(s, "play the heats")
    s.add_argument("--db", default="tournament.sqlite", help="the journal (default tournament.sqlite)")
    _contest_flags(s)
    s.add_argument(
        "--out", default="tournament", help="the report folder: index.html, standings, heats, replays, viewer pages"
    )
    s.add_argument("--quiet", action="store_true")
    s.set_defaults(func=_Command("tournament"))


def _cluster_keys(sub: Commands) -> None:
    """`laserarena cluster-keys`: the organizer's CA and keys for a Dask cluster."""
    what = "make the organizer's CA, certificates and keys for a TLS Dask cluster"
    s = sub.add_parser("cluster-keys", help=what, description=f"{what[0].upper()}{what[1:]} (docs/cluster.md).")
    s.add_argument("dir", help="a new folder to make (0700): ca.pem and each role's ROLE.pem and ROLE-key.pem")
    s.set_defaults(func=_Command("cluster_keys"))


def _render(sub: Commands) -> None:
    """`laserarena render`: a replay to PNG frames, an MP4 or a web page."""
    s = sub.add_parser("render", help="render a replay to PNG frames, an MP4 or a web page, headless")
    s.add_argument("replay")
    s.add_argument("--out", help="a folder (PNG frames), FILE.mp4, or FILE.html (a page that plays it)")
    s.add_argument("--html", metavar="OUT", help="write a self-contained web page that plays the replay")
    s.add_argument("--fps", type=int, default=30)
    s.add_argument("--size", default="960x640", help="WIDTHxHEIGHT in pixels")
    s.add_argument("--from", type=float, default=0.0, metavar="T", help="start time (s)")
    s.add_argument("--to", type=float, default=None, metavar="T", help="end time (s)")
    s.add_argument("--quiet", action="store_true")
    s.set_defaults(func=_Command("render"))


def _watch(sub: Commands) -> None:
    """`laserarena watch`: a level live, or a replay, in a window."""
    s = sub.add_parser("watch", help="watch a level live or play a replay in a window")
    s.add_argument("target", help="a level (file or built-in name) or a replay file")
    s.add_argument("--team", action="append", metavar="T", help="for a level: the controller of each slot")
    s.add_argument("--seed", type=int)
    s.add_argument("--speed", type=float, default=1.0, help="playback speed (x real time)")
    s.add_argument("--size", default="960x700")
    s.add_argument("--frames", type=int, help="close after this many frames (for scripts and tests)")
    s.set_defaults(func=_Command("watch"))


def _map(sub: Commands) -> None:
    """`laserarena map`: where a beacon layout localizes well."""
    s = sub.add_parser("map", help="draw where a beacon layout localizes well (Cramer-Rao bound)")
    s.add_argument("level")
    s.add_argument("--out", default="map.png")
    s.add_argument("--compare", metavar="LEVEL", help="a second layout, drawn beside on the same scale")
    s.add_argument("--cells", type=int, default=120, help="grid cells along the longer side")
    s.set_defaults(func=_Command("map"))


def _plot(sub: Commands) -> None:
    """`laserarena plot`: each robot's estimate error over a replay."""
    s = sub.add_parser("plot", help="plot each robot's position and heading error over a replay")
    s.add_argument("replay")
    s.add_argument("--out", default="errors.png", help="the PNG to write (default errors.png)")
    s.add_argument("--width", type=int, default=960, help="picture width in pixels")
    s.set_defaults(func=_Command("plot"))


def _verify(sub: Commands) -> None:
    """`laserarena verify`: a replay re-simulated and compared."""
    s = sub.add_parser("verify", help="re-simulate a replay from its header and compare bit for bit")
    s.add_argument("replay")
    s.add_argument("--team", action="append", metavar="T", help="where a team's controller is here (in slot order)")
    key = s.add_mutually_exclusive_group()
    _secret_file(key, "check the replay's noise key against the run's secret in FILE")
    key.add_argument("--db", metavar="JOURNAL", help="check the noise key against the secret this journal made")
    s.set_defaults(func=_Command("verify"))


def _secret(sub: Commands) -> None:
    """`laserarena secret new`: a noise secret file."""
    s = sub.add_parser("secret", help="make a noise secret file for grade and tournament (--secret-file)")
    actions = s.add_subparsers(dest="action", required=True)
    n = actions.add_parser("new", help="write 256 random bits to a new file, 0600")
    n.add_argument("file")
    n.add_argument("--force", action="store_true", help="replace the file if it exists")
    n.set_defaults(func=_Command("secret_new"))


def _journal(sub: Commands) -> None:
    """`laserarena journal backup`: a journal copied whole."""
    s = sub.add_parser("journal", help="copy a grading or tournament journal safely")
    actions = s.add_subparsers(dest="action", required=True)
    b = actions.add_parser(
        "backup", help="copy the journal into a new file (0600) with SQLite's online backup, even while a run writes"
    )
    b.add_argument("db", help="the journal (grade's or tournament's --db)")
    b.add_argument("out", help="the copy: a new file")
    b.set_defaults(func=_Command("journal_backup"))


def _new(sub: Commands) -> None:
    """`laserarena new`: a starter controller package."""
    s = sub.add_parser("new", help="write a starter controller package for a team")
    s.add_argument("name")
    s.add_argument("--dir", default=".", help="where to create it (default: here)")
    s.add_argument(
        "--from-policy",
        metavar="WEIGHTS.npz",
        help="write a package team that plays this trained policy instead (docs/rl.md)",
    )
    s.set_defaults(func=_Command("new"))


def _levels(sub: Commands) -> None:
    """`laserarena levels`: the built-in levels listed."""
    s = sub.add_parser("levels", help="list the built-in levels")
    s.set_defaults(func=_Command("levels"))


# every command's sub-parser, in the order `laserarena --help` lists them
COMMANDS = (
    _run,
    _check,
    _grade,
    _tournament,
    _cluster_keys,
    _render,
    _watch,
    _map,
    _plot,
    _verify,
    _secret,
    _journal,
    _new,
    _levels,
)


def parser() -> argparse.ArgumentParser:
    """The `laserarena` parser: `--version` and one sub-parser per command, each naming its
    `cmd_NAME` as `func`."""
    p = _Parser(
        prog="laserarena", description="LaserArena: spinning-laser beacon navigation contests, simulated and refereed."
    )
    p.add_argument("--version", action="version", version=f"laserarena {__version__}")
    sub = p.add_subparsers(dest="command", required=True)
    for add in COMMANDS:
        add(sub)
    return p
