"""Tournaments: every team starts from every slot equally often, fillers fill what teams do
not and are never rated, a robot that stands still ranks below one that races, and the
standings are the same after a SIGKILL and a resume, on one worker or two, and on a Dask
cluster whose workers cannot see the client's files."""

import csv
import itertools
import json
import os
import re
import shutil
import signal
import sqlite3
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

import pytest
from helpers import alive, descendants, edited, run_cli, secret_file

from referee.contest.ratings import Placing, bootstrap, ranks, rate
from referee.contest.schedule import schedule

IDLE = """
from robots.api import Command, Controller

class StandStill(Controller):
    def step(self, observation):
        return Command(0.0, 0.0)
"""
TEAMS = ["starter.py", "idle.py", "ref:bac", "ref:dead-reckoning"]
SECRET = "a tournament secret"  # one secret: runs compared below draw the same noise


@pytest.fixture(scope="module")
def contest():
    """A folder any user can read (controllers run as `nobody`) with a 25 s variant of
    asabe-race, a copy of the starter and a team that stands still, and the standings of a
    full two-round tournament of them on two local workers."""
    import robots.controllers.starter as starter

    folder = Path(tempfile.mkdtemp(prefix="laserarena-tournament-", dir="/tmp"))
    folder.chmod(0o777)
    (folder / "race.yaml").write_text(edited("asabe-race", {"time_limit": 25, "name": "race25"}))
    shutil.copyfile(starter.__file__, folder / "starter.py")
    (folder / "idle.py").write_text(IDLE)
    for f in folder.iterdir():
        f.chmod(0o644)
    proc = tournament(folder, "full", "--workers", "2")
    assert proc.returncode == 0, proc.stderr
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


def args(folder: Path, name: str) -> list[str]:
    team_args = [a for t in TEAMS for a in ("--team", t)]
    db, out = folder / name / "t.sqlite", folder / name / "out"
    db.parent.mkdir(exist_ok=True)
    return [
        "tournament",
        "race.yaml",
        *team_args,
        "--rounds",
        "2",
        "--secret-file",
        secret_file(SECRET),
        "--db",
        str(db),
        "--out",
        str(out),
    ]


def tournament(folder: Path, name: str, *extra: str) -> subprocess.CompletedProcess:
    return run_cli(*args(folder, name), "--quiet", *extra, cwd=folder)


def read_csv(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


# ---- the schedule, the ranks and the ratings ---------------------------------------------------


@pytest.mark.parametrize("teams, slots, rounds", [(4, 4, 2), (2, 4, 2), (8, 4, 3), (5, 2, 2), (6, 3, 3)])
def test_every_team_starts_from_every_slot_equally_often(teams, slots, rounds):
    heats = schedule(teams, slots, rounds)
    groups_per_round = -(-teams // slots)
    assert len(heats) == rounds * groups_per_round * slots
    starts = Counter((e.team, slot) for h in heats for slot, e in enumerate(h.entries) if not e.filler)
    assert starts == {(t, s): rounds for t in range(teams) for s in range(slots)}  # each slot once a round
    for r in range(1, rounds + 1):  # every team plays every round, in exactly one heat per slot
        played = Counter(e.team for h in heats if h.round == r for e in h.entries if not e.filler)
        assert played == {t: slots for t in range(teams)}
    fillers = sum(e.filler for h in heats for e in h.entries)
    assert fillers == len(heats) * slots - teams * slots * rounds


def test_pairs_meet_about_equally_often():
    teams, slots, rounds = 8, 4, 3
    heats = schedule(teams, slots, rounds)
    met = Counter()
    for h in heats[::slots]:  # one heat per group: a group's rotations share its members
        for a, b in itertools.combinations(sorted(e.team for e in h.entries), 2):
            met[a, b] += 1
    counts = [met[p] for p in itertools.combinations(range(teams), 2)]
    # two groups of four a round: 12 of the 28 pairs meet each round, 36 meetings in 3 rounds;
    # a split that repeats a first-round pair in round two before all are used would give a 3
    assert sum(counts) == 36 and max(counts) <= 2
    # and the same arguments always give the same schedule
    assert schedule(teams, slots, rounds) == heats


def test_ranks_share_ties_as_openskill_expects():
    assert ranks([3.0, 5.0, 5.0, 1.0]) == [3, 1, 1, 4]  # competition ranking, 1 is best
    assert ranks([2.0, 2.0]) == [1, 1]


def test_ratings_follow_the_heats_and_fillers_are_not_rated():
    # team 0 beats team 1 in every heat; a filler (None) sits between them
    heats = [[Placing(0, 9.0, 1), Placing(None, 5.0, 2), Placing(1, 1.0, 3)] for _ in range(5)]
    history = rate(2, heats)
    assert len(history) == 5 and all(len(step) == 2 for step in history)  # the filler has no rating
    assert history[-1][0].ordinal > history[-1][1].ordinal
    assert [s[0].sigma for s in history] == sorted((s[0].sigma for s in history), reverse=True)  # more certain
    # a tie between equals moves neither apart (symmetry), and a swapped heat mirrors the ratings
    (tie,) = rate(2, [[Placing(0, 1.0, 1), Placing(1, 1.0, 1)]])
    assert tie[0] == tie[1]
    (a,) = rate(2, [[Placing(0, 2.0, 1), Placing(1, 1.0, 2)]])
    (b,) = rate(2, [[Placing(1, 2.0, 1), Placing(0, 1.0, 2)]])
    assert a[0] == b[1] and a[1] == b[0]


def test_bootstrap_matches_the_exact_distribution_of_two_heats():
    # resampling two scores 0 and 10: the mean is 0, 5 or 10 with chances 1/4, 1/2, 1/4, so the
    # 2.5 % and 97.5 % points are 0 and 10
    assert bootstrap([0.0, 10.0], "x") == (5.0, 0.0, 10.0)
    assert bootstrap([4.0, 4.0, 4.0], "x") == (4.0, 4.0, 4.0)
    assert bootstrap([1.0, 7.0, 2.0, 9.0], "a") == bootstrap([1.0, 7.0, 2.0, 9.0], "a")


def test_fewer_teams_than_slots_are_filled_by_the_level_default(contest, tmp_path):
    from levels.loader import load_level
    from referee.contest.tournaments import entrants, plan
    from referee.sandbox.teams import resolve

    path = contest / "race.yaml"
    level = load_level(path)
    heats = plan([(level, path)], entrants([resolve("ref:bac-seed"), resolve("ref:starter")]), 1, "s", "v")
    assert len(heats) == 4 and [h.seed for h in heats] == [1, 2, 3, 4]
    default = resolve(level.default_controller).spec
    for h in heats:
        assert sorted(t for t in h.teams if t is not None) == [0, 1]
        assert [s for t, s in zip(h.teams, h.specs) if t is None] == [default, default]
    assert len({h.noise_key for h in heats}) == 4  # a seed and its noise per heat


# ---- the command --------------------------------------------------------------------------


def test_a_tournament_of_four_teams_ranks_and_reports(contest):
    out = contest / "full" / "out"
    heats = read_csv(out / "heats.csv")
    assert len(heats) == 8 * 4 and {r["filler"] for r in heats} == {"0"}
    starts = Counter((r["team"], r["slot"]) for r in heats)
    assert starts == {(t, str(s)): 2 for t in TEAMS for s in range(4)}  # every team in every slot twice
    for _, rows in itertools.groupby(heats, key=lambda r: r["heat"]):
        rows = list(rows)
        scores = [float(r["score"]) for r in rows]
        assert [int(r["rank"]) for r in rows] == [1 + sum(o > s for o in scores) for s in scores]
        assert len({r["seed"] for r in rows}) == 1
    assert len({r["seed"] for r in heats}) == 8
    standings = read_csv(out / "standings.csv")
    assert list(standings[0])[:3] == ["rank", "team", "rating"] and {"sigma", "heats", "mean_score"} <= set(
        standings[0]
    )
    place = {r["team"]: int(r["rank"]) for r in standings}
    assert set(place) == set(TEAMS) and place["idle.py"] > place["ref:bac"]
    for r in standings:  # the mean score is the mean of the team's rows in heats.csv
        mine = [float(h["score"]) for h in heats if h["team"] == r["team"]]
        assert int(r["heats"]) == 8 and float(r["mean_score"]) == pytest.approx(sum(mine) / 8, abs=1e-3)
    ratings = [float(r["rating"]) for r in standings]
    assert ratings == sorted(ratings, reverse=True)
    data = json.loads((out / "standings.json").read_text())
    assert [s["team"] for s in data["standings"]] == [r["team"] for r in standings]
    page = (out / "index.html").read_text()
    assert all(t in page for t in TEAMS) and "<svg" in page and "<polyline" in page
    assert not re.search(r"(src|href)=\"(https?:)?//", page)  # nothing from the network
    links = re.findall(r'href="([^"]+)"', page)
    assert len(links) == 16 and all((out / link).is_file() for link in links)  # a viewer and a replay per heat
    assert "race25" in (out / "heats" / "heat-0001.html").read_text()


def test_a_killed_tournament_resumes_to_the_same_standings(contest):
    db = contest / "killed" / "t.sqlite"
    cmd = [sys.executable, "-m", "referee", *args(contest, "killed"), "--quiet", "--workers", "2"]
    proc = subprocess.Popen(cmd, cwd=contest, stderr=subprocess.PIPE, text=True)
    below: dict[int, str] = {}
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        below.update(descendants(proc.pid))
        try:
            with sqlite3.connect(db) as c:
                if c.execute("SELECT count(*) FROM heats").fetchone()[0]:
                    break
        except sqlite3.OperationalError:
            pass
        time.sleep(0.05)
    below.update(descendants(proc.pid))
    assert proc.poll() is None, "the kill came mid-way"
    os.kill(proc.pid, signal.SIGKILL)
    assert proc.wait(timeout=60) == -9
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and any(alive(p, s) for p, s in below.items()):
        time.sleep(0.05)
    left = {p: cmdline(p) for p, s in below.items() if alive(p, s)}
    assert not left  # its workers and their controllers ended
    with sqlite3.connect(db) as c:
        before = dict(c.execute("SELECT seed, graded_at FROM heats"))
    assert 1 <= len(before) < 8
    resumed = tournament(contest, "killed", "--workers", "1")  # one worker: the same as two
    assert resumed.returncode == 0, resumed.stderr
    with sqlite3.connect(db) as c:
        after = dict(c.execute("SELECT seed, graded_at FROM heats"))
    assert len(after) == 8 and all(after[s] == t for s, t in before.items())  # none ran twice
    full, killed = contest / "full" / "out", contest / "killed" / "out"
    for name in ("standings.csv", "standings.json", "heats.csv"):
        assert (killed / name).read_bytes() == (full / name).read_bytes(), name


def heats_in(db: Path) -> int:
    """How many heats the journal holds (0 while it is not there yet)."""
    try:
        with sqlite3.connect(db) as c:
            return c.execute("SELECT count(*) FROM heats").fetchone()[0]
    except sqlite3.OperationalError:
        return 0


def cmdline(pid: int) -> str:
    try:
        return open(f"/proc/{pid}/cmdline").read().replace("\0", " ")
    except OSError:
        return ""


def worker_processes(root: int) -> list[int]:
    """The Dask worker processes below `root` (each spawned by its nanny)."""
    return [p for p in descendants(root) if "spawn_main" in cmdline(p)]


def owner(pid: int) -> int | None:
    """The real uid of a process, or None if it is gone."""
    try:
        for line in open(f"/proc/{pid}/status"):
            if line.startswith("Uid:"):
                return int(line.split()[1])
    except OSError:
        pass
    return None


def playing(worker: int) -> bool:
    """Whether a worker is in the middle of a heat: its controllers are running below it (a
    spawned runner, or a controller forked from the template, which runs as a slot's uid)."""
    return any("robots._host.runner" in cmdline(p) or owner(p) not in (None, 0) for p in descendants(worker))


def start(cmd: list[str], cwd: Path) -> subprocess.Popen:
    return subprocess.Popen(cmd, cwd=cwd, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)


def stop(proc: subprocess.Popen) -> None:
    """End a process group this test started: SIGTERM, then SIGKILL after a bounded wait."""
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGTERM)
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(timeout=20)


def scheduler_address(sched_file: Path, scheduler: subprocess.Popen) -> str:
    """The scheduler's address from its file, once Dask has written it whole (the file appears
    empty first), within 60 s."""
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        assert scheduler.poll() is None, scheduler.stderr.read().decode()
        try:
            return json.loads(sched_file.read_text())["address"]
        except (FileNotFoundError, json.JSONDecodeError, KeyError):
            time.sleep(0.1)
    raise AssertionError("the Dask scheduler wrote no address within 60 s")


def test_a_dask_cluster_without_a_shared_folder_gives_the_same_standings(contest, tmp_path):
    """A scheduler and two workers started as an operator would; the workers run in a mount
    namespace of their own where the contest's folder and this test's are empty tmpfs, so the
    level, the team files, the journal and the report folder of the client are all out of
    their sight (their own interpreter stays, wherever it is installed: under /tmp too)."""
    if not shutil.which("unshare"):
        pytest.skip("needs util-linux unshare to hide the client's files from the workers")
    sched_file = tmp_path / "scheduler.json"
    scheduler = start(
        [
            sys.executable,
            "-m",
            "dask",
            "scheduler",
            "--port",
            "0",
            "--no-dashboard",
            "--scheduler-file",
            str(sched_file),
        ],
        tmp_path,
    )
    workers = None
    try:
        address = scheduler_address(sched_file, scheduler)
        hidden = (
            f"mount -t tmpfs tmpfs {contest} && mount -t tmpfs tmpfs {tmp_path} && cd {tmp_path} && exec "
            + " ".join(
                [
                    sys.executable,
                    "-m",
                    "dask",
                    "worker",
                    address,
                    "--nworkers",
                    "2",
                    "--nthreads",
                    "1",
                    "--no-dashboard",
                ]
            )
        )
        workers = start(["unshare", "--mount", "--propagation", "private", "sh", "-c", hidden], Path("/"))
        from dask.distributed import Client

        with Client(address, timeout=30) as client:
            client.wait_for_workers(2, timeout=60)
            seen = client.run(lambda path: os.path.exists(path), str(contest / "starter.py"))
            assert seen and not any(seen.values())  # the workers cannot see the team's file
        # a worker killed in the middle of the tournament: its heat is run again elsewhere, once
        db = contest / "dask" / "t.sqlite"
        cmd = [
            sys.executable,
            "-m",
            "referee",
            *args(contest, "dask"),
            "--quiet",
            "--scheduler",
            address,
            "--insecure-cluster",
        ]
        proc = subprocess.Popen(cmd, cwd=contest, stderr=subprocess.PIPE, text=True)
        deadline, busy = time.monotonic() + 120, None
        # a worker with a heat's controllers below it (the journal shows nothing yet: a worker's
        # results are held until one of its heats has passed its audit)
        while time.monotonic() < deadline and busy is None and proc.poll() is None:
            busy = next((w for w in worker_processes(workers.pid) if playing(w)), None)
            time.sleep(0.02)
        assert busy is not None and proc.poll() is None, "the kill came mid-way"
        os.kill(busy, signal.SIGKILL)
        _, err = proc.communicate(timeout=300)
        assert proc.returncode == 0, err
        assert heats_in(db) == 8
        # grading takes the same road: a file team graded on these workers as on this machine
        grade = [
            "grade",
            "race.yaml",
            "--team",
            "starter.py",
            "--seeds",
            "1",
            "--secret-file",
            secret_file(SECRET),
            "--quiet",
        ]
        for name, where in (
            ("grade-dask", ["--scheduler", address, "--insecure-cluster"]),
            ("grade-local", ["--workers", "1"]),
        ):
            (contest / name).mkdir()
            out = ["--db", f"{name}/r.sqlite", "--out", f"{name}/lb.csv"]
            assert run_cli(*grade, *out, *where, cwd=contest).returncode == 0
    finally:
        if workers:
            stop(workers)
        stop(scheduler)
    graded = (contest / "grade-dask" / "lb.csv").read_text()
    assert graded == (contest / "grade-local" / "lb.csv").read_text() and "starter.py,race25,1," in graded
    full, remote = contest / "full" / "out", contest / "dask" / "out"
    for name in ("standings.csv", "heats.csv"):
        assert (remote / name).read_bytes() == (full / name).read_bytes(), name
    published, local = (json.loads((where / "standings.json").read_text()) for where in (remote, full))
    assert any("--insecure-cluster" in note for note in published.pop("notes"))  # the organizer's choice, noted
    local.pop("notes", None)
    assert published == local


def test_a_worker_of_another_version_is_refused_in_one_line(contest):
    from dask import distributed

    def other_version():
        import referee.contest.runner as runner

        runner.__version__ = "0.0.0-other"

    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            client.run(other_version)
        proc = tournament(contest, "versions", "--scheduler", cluster.scheduler_address, "--insecure-cluster")
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1, proc.stderr
    assert "0.0.0-other" in proc.stderr and "Traceback" not in proc.stderr
    with sqlite3.connect(contest / "versions" / "t.sqlite") as c:
        assert c.execute("SELECT count(*) FROM heats").fetchone()[0] == 0


def test_bad_tournament_input_is_one_line(contest):
    for bad, expect in [
        (["--team", "ref:bac", "--team", "ref:bac"], "given twice"),
        (["--team", "ref:nobody"], "ref:nobody"),
        (["--team", "ref:bac", "--rounds", "0"], "--rounds"),
    ]:
        proc = run_cli("tournament", "race.yaml", *bad, "--db", "x/t.sqlite", "--out", "x/out", cwd=contest)
        assert proc.returncode == 2 and proc.stderr.count("\n") == 1 and expect in proc.stderr, proc.stderr


# ---- a level of one robot: teams compared on the same seeds ------------------------------------

ALONE = ["ref:idle", "ref:dead-reckoning", "ref:ubersetzig"]  # blind, blind and moving, the level's reference


def alone(folder: Path, teams: list[str], rounds: int, *extra: str) -> subprocess.CompletedProcess:
    """A tournament on the one-robot level ubersetzig, on two workers, into `folder`."""
    return run_cli(
        "tournament", "ubersetzig", *(a for t in teams for a in ("--team", t)), "--rounds", str(rounds),
        "--workers", "2", "--secret-file", secret_file(SECRET), "--db", "t.sqlite", "--out", "out", *extra,
        cwd=folder,
    )  # fmt: skip


def test_a_one_robot_level_plays_every_team_on_the_same_seeds():
    from levels.loader import find_level
    from referee.contest.tournaments import entrants, plan
    from referee.sandbox.teams import resolve

    level = find_level("ubersetzig")
    heats = plan([(level, Path("ubersetzig.yaml"))], entrants([resolve(t) for t in ALONE]), 3, "s", "v")
    assert [(h.round, h.seed, h.teams) for h in heats] == [(r, r, (t,)) for r in (1, 2, 3) for t in (0, 1, 2)]
    assert len({h.noise_key for h in heats}) == 3  # one seed, one noise: the same for every team


def test_a_one_robot_tournament_ranks_the_teams_as_their_scores_do(shared_dir):
    proc = alone(shared_dir, ALONE, 3)
    assert proc.returncode == 0, proc.stderr
    out = shared_dir / "out"
    heats = read_csv(out / "heats.csv")
    scores: dict[str, dict[int, float]] = {t: {} for t in ALONE}
    for r in heats:
        scores[r["team"]][int(r["seed"])] = float(r["score"])
    assert all(sorted(s) == [1, 2, 3] for s in scores.values()) and len(heats) == 9  # each team once per seed
    for r in heats:  # a heat's rank is its place among every team's match on that seed
        on_seed = [s[int(r["seed"])] for s in scores.values()]
        assert int(r["rank"]) == 1 + sum(o > float(r["score"]) for o in on_seed)
    mean = {t: sum(s.values()) / 3 for t, s in scores.items()}
    assert len(set(mean.values())) == 3  # clearly different: the order to follow is defined
    standings = read_csv(out / "standings.csv")
    assert [r["team"] for r in standings] == sorted(ALONE, key=lambda t: -mean[t])
    place = {r["team"]: int(r["rank"]) for r in standings}
    above = [(a, b) for a, b in itertools.permutations(ALONE, 2) if all(scores[a][k] > scores[b][k] for k in (1, 2, 3))]
    assert ("ref:ubersetzig", "ref:idle") in above and ("ref:ubersetzig", "ref:dead-reckoning") in above
    assert all(place[a] < place[b] for a, b in above)  # higher on every seed: ranked above
    ratings = [float(r["rating"]) for r in standings]
    assert len(set(ratings)) == 3 and ratings == sorted(ratings, reverse=True)
    table = [line.split() for line in proc.stdout.splitlines()[1:4]]  # what the command printed
    assert [(row[0], row[1], row[-1]) for row in table] == [
        (r["rank"], f"{float(r['rating']):.2f}", r["team"]) for r in standings
    ]
    assert "no rating" not in proc.stdout + proc.stderr
    files = {name: (out / name).read_bytes() for name in ("standings.csv", "standings.json", "heats.csv")}

    # resumed: a heat lost (as if the run had been killed before it was committed) is played
    # again, the others are taken from the journal, and the ranks and files come out the same
    with sqlite3.connect(shared_dir / "t.sqlite") as c:
        c.execute("DELETE FROM heats WHERE rowid = (SELECT max(rowid) FROM heats)")
    again = alone(shared_dir, ALONE, 3)
    assert again.returncode == 0, again.stderr
    assert "9 heats in the journal t.sqlite (8 resumed, 1 run now)" in again.stderr
    assert {name: (out / name).read_bytes() for name in files} == files


def test_where_no_rating_can_be_formed_the_standings_say_so(shared_dir):
    (shared_dir / "still.py").write_text(IDLE)
    (shared_dir / "still.py").chmod(0o644)
    # one team: nobody to compare it with
    one = alone(shared_dir, ["ref:idle"], 2)
    assert one.returncode == 0, one.stderr
    assert one.stdout.count("no rating") == 1 and "Note: no rating: one team alone" in one.stdout
    (row,) = read_csv(shared_dir / "out" / "standings.csv")
    assert (row["rating"], row["mu"], row["sigma"], row["heats"]) == ("", "", "", "2")
    assert one.stdout.splitlines()[1].split()[:2] == ["1", "-"]  # no 0.00 that looks like a rating
    # two teams that score alike on the one seed they play: a tie ranks nobody
    tied = alone(shared_dir, ["ref:idle", "still.py"], 1, "--db", "tied.sqlite", "--out", "tied")
    assert tied.returncode == 0, tied.stderr
    heats = read_csv(shared_dir / "tied" / "heats.csv")
    assert [(r["seed"], float(r["score"])) for r in heats] == [("1", 0.0), ("1", 0.0)]
    assert tied.stdout.count("no rating") == 1 and "Note: no rating: every heat was a tie" in tied.stdout
    data = json.loads((shared_dir / "tied" / "standings.json").read_text())
    assert [s["rating"] for s in data["standings"]] == [None, None]
    assert any(n.startswith("no rating") for n in data["notes"])
    page = (shared_dir / "tied" / "index.html").read_text()
    assert "no rating" in page and "<polyline" not in page  # no chart of ratings that do not exist


def test_on_a_seed_a_team_placed_higher_is_rated_higher_ties_included():
    """The teams' matches on one seed of a one-robot level, rated as one heat: a team that
    placed higher on every seed rates higher, and teams that tied on every seed rate alike,
    in cases where openskill's own formula for ties would rate the third place above the
    tied winners (1, 1, 2, 3)."""
    cases = [
        [[9.0, 9.0, 5.0, 1.0]],
        [[9.0, 9.0, 5.0, 1.0], [8.0, 8.0, 3.0, 0.0]],
        [[0.0, 13.0, 1.0, 13.0, 2.0, 5.0]],
        [[13.0, 1.0, 13.0, 1.0, 13.0, 3.0], [7.0, 0.0, 7.0, 0.0, 7.0, 2.0]],
        [[3.0, 3.0, 3.0, 0.0], [4.0, 1.0, 1.0, 1.0], [2.0, 2.0, 5.0, 2.0]],
    ]
    for seeds in cases:
        n = len(seeds[0])
        heats = [[Placing(t, s, k) for t, (s, k) in enumerate(zip(row, ranks(row)))] for row in seeds]
        final = [r.ordinal for r in rate(n, heats, seeds=range(len(heats)))[-1]]
        for a, b in itertools.permutations(range(n), 2):
            if all(row[a] > row[b] for row in seeds):
                assert final[a] > final[b], (seeds, a, b)
            if all(row[a] == row[b] for row in seeds):
                assert final[a] == final[b], (seeds, a, b)
