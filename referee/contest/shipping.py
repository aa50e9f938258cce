"""A team's code as bytes, so a match can run on a machine that cannot see the team's files.

The client resolves every team once (referee.sandbox.teams): a `Team` carries the bytes of
its files, the very bytes its code hash was computed from, and travels with the job as they
are. The code hash is checked again on arrival: a result always belongs to the code that was
resolved. Built-in teams (reference controllers) carry no files: the worker resolves them from
its own installation, which must hash the same (the software version is pinned as well).
"""

from __future__ import annotations

from pathlib import PurePosixPath

from referee.errors import TeamError
from referee.sandbox.teams import Team, file_hash, resolve, tree_hash


def _hashes(files: tuple[tuple[str, bytes], ...]) -> set[str]:
    """The code hashes shipped files may carry: a package's (`tree_hash`), or a single file's."""
    return {tree_hash(files)} | ({file_hash(files[0][1])} if len(files) == 1 else set())


def arrived(team: Team) -> Team:
    """A team as a worker runs it, checked: its bytes hash to the code hash that was resolved
    and no path leaves its folder; a built-in team resolved from this installation. TeamError
    (one line) otherwise."""
    if not team.files:
        here = resolve(team.spec)
        if here.code_hash != team.code_hash:
            raise TeamError(f"team {team.label}: this worker's copy of it differs from the client's")
        return here
    if team.code_hash not in _hashes(team.files):
        raise TeamError(f"team {team.label}: its code arrived damaged")
    for rel, _ in team.files:
        inner = PurePosixPath(rel)
        if inner.is_absolute() or ".." in inner.parts:
            raise TeamError(f"team {team.label}: a shipped path leaves its folder: {rel}")
    return team
