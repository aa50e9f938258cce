"""`laserarena verify REPLAY`: re-simulate a match from its replay's header, compare bit for bit."""

from __future__ import annotations

import itertools
import tempfile
from pathlib import Path

from arena.loader import parse_level
from referee.errors import UserError
from referee.match.loop import run_match
from referee.records.replay_reader import lines, load
from referee.sandbox.teams import code_hash, resolve


def verify(path: Path, team_overrides: list[str] | None = None) -> tuple[bool, str]:
    """(identical?, a one-line account). Teams come from the header unless overridden (a team's
    file may live elsewhere on this machine); each must hash as the replay says."""
    try:
        rep = load(path, keep=False)  # checked through, one record at a time
    except (OSError, ValueError) as e:
        raise UserError.of(e) from None
    h = rep.header
    level = parse_level(h["level"]["text"].encode(), f"{path}:level")
    if level.hash != h["level"]["hash"]:
        return False, "the embedded level does not match its hash"
    specs = team_overrides or [t["spec"] for t in h["teams"]]
    if len(specs) != len(h["teams"]):
        raise UserError(f"{path} has {len(h['teams'])} teams; got {len(specs)} --team")
    teams = []
    for spec, recorded in zip(specs, h["teams"]):
        if code_hash(spec) != recorded["hash"]:
            return False, f"controller {spec} differs from the one recorded ({recorded['label']})"
        teams.append(resolve(spec))
    with tempfile.TemporaryDirectory() as d:
        again = Path(d) / "again.replay"
        run_match(level, teams, seed=h["seed"], replay=again, ideal=h["ideal"], noise_key=h.get("noise_key"))
        counts, first = [0, 0], None  # records of each; the first that differs
        try:  # a line at a time: two replays of any size are compared in the memory of a record
            for i, pair in enumerate(itertools.zip_longest(lines(path), lines(again))):
                counts[0] += pair[0] is not None
                counts[1] += pair[1] is not None
                if first is None and pair[0] != pair[1]:
                    first = i
        except (OSError, ValueError) as e:
            raise UserError.of(e) from None
    if first is None:
        return True, f"identical: {counts[0]} records, {rep.duration:.1f} s, result and every frame reproduced"
    return False, f"differs from record {first} on ({counts[0]} recorded, {counts[1]} re-simulated)"
