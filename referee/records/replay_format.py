"""The replay format: its name and versions, its size bounds, the header a match's caller
builds, and `Replay`, a replay held in memory.

Format `laserarena-replay` version 1 (docs/replay.md): gzip-compressed JSON lines (gzip's
timestamp fixed at 0, so the same match gives the same bytes). The first line is the header
(software, level name, hash and full text, seed, ideal, record rate, teams with controller
hashes); then records in the order they were known, each with a kind `k`:
`f` frame (true poses), `e` sensor event with its beam line, `est` estimate, `dbg` debug
drawings, `trial` (a localize trial began: the robots were carried to new poses), `foul`,
`fault`; the last line is the result. Written by `replay_writer`, read by `replay_reader`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from referee.records.results import MatchResult

FORMAT, VERSION = "laserarena-replay", 1
BEHAVIOUR = 13  # bump when a change alters simulation results (the golden-replay test says so)
MAX_RECORD = 1 << 23  # bytes in one record line: a header with a 1 MiB level, or a result, fit
MAX_REPLAY = 64 << 20  # bytes of a whole replay, decompressed (and its file): what readers accept


@dataclass(frozen=True)
class TeamEntry:
    """One slot's team as the header names it: its label, its spec, and the sha256 of the code
    that ran (which may have been shipped from a machine where the spec's files live)."""

    label: str
    spec: str
    hash: str


@dataclass(frozen=True)
class Header:
    """What a replay's first line says, as plain data its caller builds (the level's name,
    hash and whole text; the match's seed, noise and teams; the software that played it)."""

    level_name: str
    level_hash: str
    level_text: str
    seed: int
    ideal: bool
    record_rate: int
    control_period: float
    teams: tuple[TeamEntry, ...]
    software: str
    noise_key: str | None = None  # graded matches only (docs/integrity.md)

    def to_dict(self) -> dict[str, Any]:
        """The header line's JSON data (`noise_key` left out when there is none)."""
        return {
            "format": FORMAT,
            "version": VERSION,
            "behaviour": BEHAVIOUR,
            "software": self.software,
            "level": {"name": self.level_name, "hash": self.level_hash, "text": self.level_text},
            "seed": self.seed,
            "ideal": self.ideal,
            "record_rate": self.record_rate,
            "control_period": self.control_period,
            "teams": [{"label": t.label, "spec": t.spec, "hash": t.hash} for t in self.teams],
            **({"noise_key": self.noise_key} if self.noise_key else {}),
        }


@dataclass
class Replay:
    """A replay in memory (read back, or recorded live): the header's JSON data, the frames,
    and the other records by kind, as JSON data; the result as its typed record."""

    header: dict[str, Any]
    frames: list[tuple[float, list[list[float]]]] = field(default_factory=list)
    events: list[dict[str, Any]] = field(default_factory=list)
    estimates: list[dict[str, Any]] = field(default_factory=list)
    debug: list[dict[str, Any]] = field(default_factory=list)
    fouls: list[dict[str, Any]] = field(default_factory=list)
    faults: list[dict[str, Any]] = field(default_factory=list)
    trials: list[dict[str, Any]] = field(default_factory=list)  # {"t": when, "n": which} of each trial after the first
    result: MatchResult | None = None  # None until the match ends, or when of another result version

    @property
    def moves(self) -> list[float]:
        """The times at which the robots were carried to a new trial's poses."""
        return [float(r["t"]) for r in self.trials]

    @property
    def duration(self) -> float:
        """The time of the last frame (s)."""
        return self.frames[-1][0] if self.frames else 0.0
