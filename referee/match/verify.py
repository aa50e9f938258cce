"""`laserarena verify REPLAY`: re-simulate a match from its replay's header, compare bit for bit.

A replay made with any noise key re-simulates identically with that key, so a re-simulation
alone says nothing of where the key came from: only the key's check against the run's secret
does (`key_for`, given by the caller that holds the secret; docs/integrity.md).
"""

from __future__ import annotations

import hmac
import itertools
import tempfile
from collections.abc import Callable
from pathlib import Path

from levels.loader import parse_level
from referee.errors import UserError
from referee.match.loop import play_match
from referee.records.replay_reader import lines, load
from referee.sandbox.teams import code_hash, resolve

UNCHECKED = "noise key not checked (--secret-file FILE or --db JOURNAL checks it against the run's secret)"


def _key_problem(header: dict, key_for: Callable[[str, int], str] | None) -> tuple[str | None, str]:
    """(why the replay's noise key is not the run's, None if it is; what verify says of it)."""
    recorded = header.get("noise_key")
    if key_for is None:
        return None, UNCHECKED if recorded else "no noise key (a local run: its noise comes from its seed)"
    if recorded is None:
        return "no noise key: not a match graded with this secret (a local run's noise comes from its seed)", ""
    if not hmac.compare_digest(recorded, key_for(header["level"]["hash"], header["seed"])):
        return "forged noise key: not HMAC(secret, level hash, seed) of the secret given (or graded with another)", ""
    return None, "noise key genuine (HMAC of the secret given)"


def verify(
    path: Path, team_overrides: list[str] | None = None, key_for: Callable[[str, int], str] | None = None
) -> tuple[bool, str]:
    """(identical?, a one-line account). Teams come from the header unless overridden (a team's
    file may live elsewhere on this machine); each must hash as the replay says. `key_for`
    gives the noise key of a level hash and seed under the run's secret: a replay whose key is
    not that one is refused before anything is re-simulated."""
    try:
        rep = load(path, keep=False)  # checked through, one record at a time
    except (OSError, ValueError) as e:
        raise UserError.of(e) from None
    h = rep.header
    level = parse_level(h["level"]["text"].encode(), f"{path}:level")
    if level.hash != h["level"]["hash"]:
        return False, "the embedded level does not match its hash"
    problem, key = _key_problem(h, key_for)
    if problem:
        return False, problem
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
        play_match(level, teams, seed=h["seed"], replay=again, ideal=h["ideal"], noise_key=h.get("noise_key"))
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
        return True, f"identical: {counts[0]} records, {rep.duration:.1f} s, result and every frame reproduced; {key}"
    return False, f"differs from record {first} on ({counts[0]} recorded, {counts[1]} re-simulated)"
