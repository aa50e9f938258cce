"""The `laserarena` commands, one `cmd_NAME` each over the rooms; `referee.cli.arguments`
parses their arguments and `referee.cli.main` runs them.

Bad input (a level file, a team spec, a path) prints one line to stderr and exits 2.
"""

from __future__ import annotations

import argparse
import functools
import sys
import time
import warnings
from dataclasses import asdict
from pathlib import Path

import numpy as np

import levels
from arena.heap import lasting
from levels.loader import find_level, load_level
from referee import api
from referee.cli.summary import table
from referee.errors import LaserArenaWarning, UserError
from referee.records.canonical import dumps
from referee.records.faults import located
from referee.sandbox.teams import controller_problem
from referee.terminal import safe

# s: about what a first match after installing spends compiling the kernels (the `first-run`
# row of docs/performance.json; tests/test_warm.py holds the two together)
COMPILING_S = 20


def announce_compiling(quiet: bool) -> None:
    """Say, in one line on stderr, that this command's first match compiles the kernels and
    how long that takes: numba's cache holds nothing for the loop every match steps (a fresh
    install that `referee.match.warm` has not warmed). Nothing with --quiet."""
    if quiet:
        return
    with lasting():  # numba's objects live as long as the process (arena.heap)
        from arena.compiled import cached
        from arena.stepping import run_steps

    if cached(run_steps) is False:
        print(
            f"laserarena: compiling the simulator's kernels, once after installing: about {COMPILING_S} s",
            file=sys.stderr,
            flush=True,
        )


def cmd_levels(args: argparse.Namespace) -> int:
    found = {
        name: load_level(levels.path(name), display=f"levels/{name}.yaml", controllers=controller_problem)
        for name in levels.names()
    }
    # columns as wide as their widest entry: the names and controllers are the levels' own
    names = max(map(len, found))
    robots = max(len(str(len(lv.robots))) for lv in found.values())
    defaults = max(len(lv.default_controller) for lv in found.values())
    for name, lv in found.items():
        print(
            f"{name:<{names}}  {len(lv.robots):>{robots}} robot{'s' if len(lv.robots) > 1 else ' '}  "
            f"default {lv.default_controller:<{defaults}}  {lv.description}"
        )
    return 0


def cmd_check(args: argparse.Namespace) -> int:
    for name in args.level:
        lv = find_level(name, controllers=controller_problem)
        print(
            f"{name}: ok ({lv.name}: {len(lv.robots)} robot(s), {len(lv.beacons.items)} "
            f"{lv.beacons.kind} beacons, {lv.task.kind} task)"
        )
    return 0


def cmd_run(args: argparse.Namespace) -> int:
    if args.quiet:  # nothing on success: not even that the controllers run unsandboxed
        warnings.simplefilter("ignore", LaserArenaWarning)
    level = find_level(args.level, controllers=controller_problem)
    api.check_seed(args.seed, "--seed")
    if args.replay == "-":
        raise UserError("--replay -: a replay is binary; give a file")
    for path in (args.json, args.replay):
        if path and path != "-" and not Path(path).resolve().parent.is_dir():
            raise UserError(f"{path}: the folder does not exist")
    with lasting():  # numba and its compiled kernels' machinery: a third of the command's start
        import referee.match.loop  # noqa: F401
    announce_compiling(args.quiet)
    result = api.run_match(
        level,
        args.team,
        seed=args.seed,
        replay=args.replay,
        ideal=args.ideal,
        isolate=not args.in_process,
        limits=not args.no_limits,
        logs=args.logs,
    )
    failed = [r["slot"] for r in result["robots"] if r["faults"]]
    # in-process, the team's output went to this terminal: nothing to keep, nothing to say
    logs = {slot: str(Path(args.logs) / f"slot{slot}.log") for slot in failed} if args.logs else None
    logs = {} if args.in_process and not args.logs else logs
    given = result["robots"][: len(args.team)] if args.team else result["robots"]  # else the level's own
    unloadable = [located(r["faults"][0]) for r in given if r["faults"] and r["faults"][0]["kind"] == "load"]
    if given and len(unloadable) == len(given):  # nothing the user asked for (or the level named) could run
        raise UserError("; ".join(unloadable))
    if args.json == "-":  # the JSON is the output; the table goes to stderr
        print(dumps(result))
    elif args.json:
        Path(args.json).write_text(dumps(result) + "\n", encoding="utf-8")
    if not args.quiet:
        print(table(result, logs), file=sys.stderr if args.json == "-" else sys.stdout)
    return 0


def _secret(args: argparse.Namespace) -> str | None:
    """The noise secret read (and judged) from --secret-file, or None (the journal's own)."""
    from referee.contest import noise_secret

    return noise_secret.read(args.secret_file) if args.secret_file else None


def _contest_options(args: argparse.Namespace) -> dict:
    """What `grade` and `tournament` take alike from their command lines."""
    return {
        "workers": args.workers,
        "db": args.db,
        "out": args.out,
        "secret": _secret(args),
        "scheduler": args.scheduler,
        "quiet": args.quiet,
        "unsandboxed": args.unsandboxed,
        "cluster_keys": args.cluster_keys,
        "insecure_cluster": args.insecure_cluster,
        "audit": args.audit,
    }


def cmd_grade(args: argparse.Namespace) -> int:
    from referee.contest.grading import markdown
    from referee.contest.journal import account

    if args.seeds < 1:
        raise UserError("--seeds must be at least 1")
    if not args.scheduler:  # a cluster's workers compile on their own machines
        announce_compiling(args.quiet)
    start = time.perf_counter()
    board = api.leaderboard(
        args.level,
        args.team,
        seeds=args.seeds,
        **_contest_options(args),
    )
    rows = board.rows
    if args.quiet:
        api.warn(board.notes)
    else:
        print(markdown([asdict(r) for r in rows], board.notes), end="")
        print(
            f"{account(board.matches, 'match', board.ran, args.db)}; leaderboard {args.out} (.json, .md); "
            f"{time.perf_counter() - start:.1f} s",
            file=sys.stderr,
        )
    return 0


def cmd_tournament(args: argparse.Namespace) -> int:
    from referee.contest.journal import account

    if not args.scheduler:  # a cluster's workers compile on their own machines
        announce_compiling(args.quiet)
    start = time.perf_counter()
    done = api.tournament(
        args.level,
        args.team,
        rounds=args.rounds,
        **_contest_options(args),
    )
    if args.quiet:
        api.warn(done.notes)
    else:
        print(f"{'rank':>4}  {'rating':>7}  {'heats':>5}  {'mean':>7}  team")
        for s in done.standings:
            rating = "-" if s.rating is None else f"{s.rating:.2f}"
            print(f"{s.rank:>4}  {rating:>7}  {s.heats:>5}  {s.mean_score:7.1f}  {safe(s.team)}")
        for note in done.notes:
            print(f"Note: {safe(note, 500)}")
        for s in done.standings:
            if s.faults:
                print(f"faults of {safe(s.team)}: {safe(s.faults, 500)}")
        heats = len({h.heat for h in done.heats})
        print(
            f"{account(heats, 'heat', done.ran, args.db)}; report {Path(args.out) / 'index.html'}; "
            f"{time.perf_counter() - start:.1f} s. Heats' own time {done.heat_seconds:.1f} s; scheduling and rating "
            f"{1000 * done.overhead_seconds:.1f} ms ({1000 * done.overhead_seconds / heats:.2f} ms per heat); "
            f"report and viewer pages {done.report_seconds:.1f} s",
            file=sys.stderr,
        )
    return 0


def cmd_cluster_keys(args: argparse.Namespace) -> int:
    from referee.contest.cluster_keys import make_keys

    written = make_keys(Path(args.dir))
    print(f"wrote {', '.join(p.name for p in written)} in {args.dir} (keys 0600, the folder 0700)")
    print(
        "copy to the scheduler: ca.pem scheduler.pem scheduler-key.pem; to each worker: ca.pem worker.pem worker-key.pem"
    )
    print(f"the client keeps the folder: --cluster-keys {args.dir}")
    return 0


def cmd_verify(args: argparse.Namespace) -> int:
    from referee.contest import noise_secret
    from referee.contest.journal import stored_secret

    with lasting():  # numba's objects live as long as the process (arena.heap)
        from referee.match.verify import verify
    announce_compiling(False)

    secret = _secret(args)
    if args.db:
        secret = noise_secret.checked(stored_secret(Path(args.db)), args.db)
    key_for = functools.partial(noise_secret.noise_key, secret) if secret else None
    ok, message = verify(Path(args.replay), args.team, key_for)
    print(safe(f"{args.replay}: {message}", 1000))
    return 0 if ok else 1


def cmd_secret_new(args: argparse.Namespace) -> int:
    from referee.contest import noise_secret

    noise_secret.create(Path(args.file), replace=args.force)
    print(f"wrote {safe(args.file)} (0600): 256 random bits; grade with --secret-file {safe(args.file)}")
    return 0


def cmd_journal_backup(args: argparse.Namespace) -> int:
    from referee.contest.journal import backup

    matches, heats = backup(Path(args.db), Path(args.out))
    counts = f"{matches} match{'es' * (matches != 1)}, {heats} heat{'s' * (heats != 1)}"
    print(f"wrote {safe(args.out)} (0600): {counts}; it holds the noise secret too")
    return 0


def cmd_render(args: argparse.Namespace) -> int:
    with lasting():  # numba's objects live as long as the process (arena.heap)
        from referee.media.render import render

    try:
        w, h = (int(v) for v in args.size.lower().split("x"))
    except ValueError:
        raise UserError(f"--size {args.size}: expected WIDTHxHEIGHT, e.g. 960x640") from None
    if not (args.html or args.out):
        raise UserError("render: give --out (a folder, FILE.mp4 or FILE.html) and/or --html FILE.html")
    html = args.html or (args.out if Path(args.out).suffix.lower() in (".html", ".htm") else None)
    if html:
        from referee.media.viewer import write_viewer

        write_viewer(Path(args.replay), Path(html), size=(w, h))
        if not args.quiet:
            print(f"wrote {html}: open it in a web browser")
    if args.out and args.out != html:
        suffix = Path(args.out).suffix.lower()
        if suffix not in ("", ".mp4"):
            raise UserError(f"--out {args.out}: expected a folder (PNG frames), FILE.mp4 or FILE.html, not {suffix}")
        if not Path(args.out).resolve().parent.is_dir():
            raise UserError(f"--out {args.out}: the folder does not exist")
        n = render(
            Path(args.replay),
            Path(args.out),
            fps=args.fps,
            size=(w, h),
            start=getattr(args, "from"),
            end=args.to,
            quiet=args.quiet,
        )
        if not args.quiet:
            print(f"wrote {n} frames to {args.out}")
    return 0


def cmd_watch(args: argparse.Namespace) -> int:
    from referee.media.watch import ELSEWHERE, KEYS_HELP, no_display, watch

    try:
        w, h = (int(v) for v in args.size.lower().split("x"))
    except ValueError:
        raise UserError(f"--size {args.size}: expected WIDTHxHEIGHT") from None
    problem = no_display()
    if problem:
        raise UserError(f"watch: {problem}; {ELSEWHERE}")
    print(KEYS_HELP)
    announce_compiling(False)
    watch(args.target, args.team, args.seed, (w, h), args.speed, args.frames)
    return 0


def cmd_plot(args: argparse.Namespace) -> int:
    from referee.media.plot import error_figure

    if args.width < 320:
        raise UserError("--width must be at least 320")
    if not Path(args.out).resolve().parent.is_dir():
        raise UserError(f"{args.out}: the folder does not exist")
    fig = error_figure(Path(args.replay), Path(args.out), width=args.width)
    for r in fig.robots:
        if r.times:
            rms = (sum(v * v for v in r.position_mm) / len(r.times)) ** 0.5
            print(
                f"{r.slot} {r.team}: {len(r.times)} estimates, position error rms {rms:.1f} mm "
                f"max {max(r.position_mm):.1f} mm, heading error max {max(r.heading_deg):.1f} deg, "
                f"{len(r.fouls)} fouls, {len(r.faults)} faults"
            )
        else:
            print(f"{r.slot} {r.team}: no estimates")
    print(f"wrote {args.out}")
    return 0


def cmd_map(args: argparse.Namespace) -> int:
    with lasting():  # numba's objects live as long as the process (arena.heap)
        from referee.media import accuracy_map as am

    maps = [am.compute(find_level(args.level, controllers=controller_problem), cells=args.cells)]
    if args.compare:
        maps.append(am.compute(find_level(args.compare, controllers=controller_problem), cells=args.cells))
    am.draw(maps, Path(args.out))
    for m in maps:
        finite = m.error[m.error == m.error]
        print(
            f"{m.level.name}: bearing noise {1000 * m.sigma:.3f} mrad; position error bound "
            f"median {1000 * float(np.median(finite)):.2f} mm, best {1000 * float(finite.min()):.2f} mm; "
            f"{100 * float((m.seen < 3).mean()):.0f} % of the field sees fewer than 3 beacons"
        )
    print(f"wrote {args.out}")
    return 0


def cmd_new(args: argparse.Namespace) -> int:
    from referee.cli.starter_kit import create, create_from_policy  # a run needs neither: loaded here alone

    if args.from_policy:
        folder = create_from_policy(args.name, Path(args.from_policy), Path(args.dir))
        print(f"wrote {folder}/: __init__.py, policy.npz, README.md")
        here = "" if args.dir == "." else f"cd {folder.parent} && "
        print(f"next: {here}laserarena run LEVEL --team {args.name}")
        return 0
    folder = create(args.name, Path(args.dir))
    print(f"wrote {folder}/: controller.py, test_controller.py, README.md")
    print(f"next: cd {folder} && laserarena run bac-line --team controller.py")
    return 0
