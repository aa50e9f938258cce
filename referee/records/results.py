"""The result of a match as typed, frozen records (format `laserarena-result`, `RESULT_VERSION`).

Every record is a frozen msgspec Struct (its lists are plain lists, as in the JSON): attribute access for Python (`r.robots[0].score.total`),
read-only access by the result JSON's own field names for scripts written against the JSON
(`r["robots"][0]["score"]["total"]`), `to_dict()` for the plain data, and one serialiser,
`referee.records.canonical.dumps`, which writes the same bytes as always. Fields that exist
only for some task kinds or foul kinds are `UNSET` when absent and left out of the JSON.
`referee.records.result_schema` publishes the JSON Schema generated from these types in
docs/schema/ (each field); docs/results.md describes the result.
"""

from __future__ import annotations

from typing import Any

import msgspec
from msgspec import UNSET, UnsetType

RESULT_FORMAT, RESULT_VERSION = "laserarena-result", 4  # 4: every length in m (cross-track was in mm)


class Record(msgspec.Struct, frozen=True, kw_only=True):
    """A frozen record whose fields can also be read by their JSON names, like a mapping."""

    def __getitem__(self, key: str) -> Any:
        if key in self.__struct_fields__:
            value = getattr(self, key)
            if value is not UNSET:
                return value
        raise KeyError(key)

    def __contains__(self, key: object) -> bool:
        return key in self.__struct_fields__ and getattr(self, str(key)) is not UNSET

    def get(self, key: str, default: Any = None) -> Any:
        """The field named `key`, or `default` if there is none (or it is unset)."""
        try:
            return self[key]
        except KeyError:
            return default

    def keys(self) -> list[str]:
        """The names of the fields that are set, in declaration order."""
        return [k for k in self.__struct_fields__ if getattr(self, k) is not UNSET]

    def to_dict(self) -> dict[str, Any]:
        """The record as plain JSON data (unset fields left out)."""
        data: dict[str, Any] = msgspec.to_builtins(self)
        return data


class LevelRef(Record, frozen=True):
    """Which level was played: its name and `sha256:` of its file's bytes."""

    name: str
    hash: str


class Score(Record, frozen=True):
    """A robot's points: task + time + localization - penalties = total (docs/rules.md)."""

    task: float
    time: float
    localization: float
    penalties: int | float  # the sum of the fouls' penalties: 0 (an int) when there are none
    total: float


class CrossTrack(Record, frozen=True):
    """How far the robot strayed from the ideal polyline, in m."""

    mean: float
    std: float
    max: float


class TaskProgress(Record, frozen=True):
    """Task progress: waypoint and race tasks count points reached; goto keeps the distance left."""

    kind: str
    finished: float | None
    reached: int | UnsetType = UNSET
    total: int | UnsetType = UNSET
    reached_at: list[float] | UnsetType = UNSET
    cross_track: CrossTrack | UnsetType = UNSET
    worth: list[float] | UnsetType = UNSET  # where the task sets an accuracy: each reached waypoint's share, 0..1
    final_distance: float | None | UnsetType = UNSET


class Localization(Record, frozen=True):
    """The reported estimates against the truth: counts, the localization quality (0..1, the
    mean tick quality of docs/rules.md), and errors in m and rad (None: no estimate)."""

    ticks: int
    estimates: int
    fraction: float
    quality: float
    position_rms: float | None
    position_max: float | None
    heading_rms: float | None
    heading_max: float | None


class FoulRecord(Record, frozen=True):
    """One foul: kind, when, where, its penalty, and the details its kind carries."""

    kind: str
    tick: int
    time: float
    place: list[float]  # [x, y]
    penalty: float
    impulse: float | UnsetType = UNSET  # collisions (N s)
    other: int | None | UnsetType = UNSET  # robot collisions: the other slot
    speed: float | UnsetType = UNSET  # speeding (m/s)
    fault: str | UnsetType = UNSET  # controller fouls: the fault's kind
    message: str | UnsetType = UNSET  # controller fouls: the fault's message


class Fault(Record, frozen=True):
    """A controller fault, one type from the moment the sandbox finds it to the result: control
    tick, time, kind (docs/results.md lists them), a one-line terminal-safe message and, when
    the team's log holds one, the tail of its traceback. A skipped tick is the one fault that
    is not fatal: its robot keeps its last command."""

    tick: int
    time: float
    kind: str
    message: str
    traceback: str | UnsetType = UNSET

    @property
    def fatal(self) -> bool:
        """Whether it stops the robot (every kind but a skipped tick)."""
        return self.kind != "skipped_tick"


class WarningRecord(Record, frozen=True):
    """Something of a team's the referee set aside without stopping it, one per kind
    (`drawing_dropped`, `drawing_over_tick`, `drawing_over_match`): the first tick, how many
    times, and the first example's text."""

    kind: str
    tick: int
    count: int
    message: str


class RobotResult(Record, frozen=True):
    """One robot's result: score, task progress, localization, fouls and faults, final pose."""

    slot: int
    team: str
    score: Score
    task: TaskProgress
    localization: Localization
    fouls: list[FoulRecord]
    faults: list[Fault]
    stopped: bool
    final_pose: list[float]  # [x, y, heading]
    warnings: list[WarningRecord] | UnsetType = UNSET  # left out when there are none


class MatchResult(Record, frozen=True):
    """The result of one match: what was played, how it ended, and every robot's result."""

    format: str
    version: int
    software: str
    level: LevelRef
    seed: int
    ideal: bool
    end_time: float
    end_reason: str
    robots: list[RobotResult]

    @classmethod
    def from_json(cls, data: bytes | str) -> MatchResult:
        """A result read back from its JSON, checked against these types (ValidationError)."""
        return msgspec.json.decode(data, type=cls)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> MatchResult:
        """A result from plain data (a replay's last record, a journal row), checked."""
        return msgspec.convert(data, type=cls)
