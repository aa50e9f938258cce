"""A team's code as bytes, so a match can run on a machine that cannot see the team's files.

The client resolves every team (referee.sandbox.teams) and ships its files' bytes with the
job; a worker writes them into a folder of its own and runs them there. The code hash travels
with the bytes and is checked again on arrival: a result always belongs to the code that was
resolved. Built-in teams (reference controllers) ship no files: the worker resolves them from
its own installation, which must hash the same (the software version is pinned as well).
"""

from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from referee.errors import TeamError
from referee.sandbox.teams import Team, resolve


@dataclass(frozen=True)
class Shipped:
    """A resolved team with its files' bytes: `files` holds (path inside the code folder, bytes)."""

    label: str
    spec: str
    code_hash: str
    entry: str
    files: tuple[tuple[str, bytes], ...]


def ship(team: Team) -> Shipped:
    """Read a resolved team's files into a `Shipped` (TeamError if one cannot be read)."""
    files = []
    for rel, path in team.files:
        try:
            files.append((rel, Path(path).read_bytes()))
        except OSError as e:
            raise TeamError(f"team {team.label}: cannot read {path}: {e.strerror or e}") from None
    return Shipped(team.label, team.spec, team.code_hash, team.entry, tuple(files))


def _hashes(files: tuple[tuple[str, bytes], ...]) -> set[str]:
    """The code hashes shipped files may carry: `referee.sandbox.teams` sums a single file's
    bytes, and a package's paths, sizes and bytes in path order."""
    h = hashlib.sha256()
    for rel, data in sorted(files):
        h.update(f"{rel}\0{len(data)}\0".encode())
        h.update(data)
    found = {"sha256:" + h.hexdigest()}
    if len(files) == 1:
        found.add("sha256:" + hashlib.sha256(files[0][1]).hexdigest())
    return found


def unship(shipped: Shipped, folder: Path) -> Team:
    """The `Team` of shipped code, its files written under `folder` (readable by the sandbox's
    user); TeamError if the bytes do not hash to the code hash that was resolved."""
    if not shipped.files:
        team = resolve(shipped.spec)
        if team.code_hash != shipped.code_hash:
            raise TeamError(f"team {shipped.label}: this worker's copy of it differs from the client's")
        return team
    if shipped.code_hash not in _hashes(shipped.files):
        raise TeamError(f"team {shipped.label}: its code arrived damaged")
    placed = []
    for rel, data in shipped.files:
        inner = PurePosixPath(rel)
        if inner.is_absolute() or ".." in inner.parts:
            raise TeamError(f"team {shipped.label}: a shipped path leaves its folder: {rel}")
        path = folder.joinpath(*inner.parts)
        path.parent.mkdir(mode=0o755, parents=True, exist_ok=True)
        path.write_bytes(data)
        os.chmod(path, 0o644)
        placed.append((rel, path))
    return Team(shipped.label, shipped.spec, shipped.code_hash, tuple(placed), shipped.entry)
