"""Replays: everything that happened in a match, streamable, compact, re-simulatable.

Format `laserarena-replay` version 1 (docs/replay.md): gzip-compressed JSON lines (gzip's
timestamp fixed at 0, so the same match gives the same bytes). The first line is the header
(software, level name, hash and full text, seed, ideal, record rate, teams with controller
hashes); then records in the order they were known, each with a kind `k`:
`f` frame (true poses), `e` sensor event with its beam line, `est` estimate, `dbg` debug
drawings, `trial` (a localize trial began: the robots were carried to new poses), `foul`,
`fault`; the last line is the result. `load()` reads one back.

Replays are organizer files (0600): a graded one holds the match's noise key. Reading is
bounded: a replay is at most `MAX_REPLAY` bytes, compressed and decompressed (counted as it
streams, so a gzip bomb stops there), a record at most `MAX_RECORD` bytes, nested JSON cannot
exhaust the stack, and the header has a fixed, typed schema (its level text is parsed as
safely as a level file). What a match writes is bounded by its level (frames, sensor events,
one estimate a tick), by the drawing budgets (referee.match.drawings) and by one record per
foul and fault; docs/replay.md gives the sum, far below `MAX_REPLAY` for the built-in levels.
"""

from __future__ import annotations

import functools
import gzip
import io
import json
import math
import os
import queue
import re
import tempfile
import threading
import zlib
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Annotated, Any

import msgspec

from arena.level import Level
from referee.errors import ReplayError
from referee.records.canonical import DECIMALS, dumps

FORMAT, VERSION = "laserarena-replay", 1
BEHAVIOUR = 10  # bump when a change alters simulation results (the golden-replay test says so)
_QUEUED = 8  # chunks of records waiting for the compressor at most (then the match waits)
MAX_RECORD = 1 << 23  # bytes in one record line: a header with a 1 MiB level, or a result, fit
MAX_REPLAY = 64 << 20  # bytes of a whole replay, decompressed (and its file): what readers accept

_Text = Annotated[str, msgspec.Meta(max_length=4096)]


class _LevelRef(msgspec.Struct):
    name: _Text
    text: Annotated[str, msgspec.Meta(max_length=MAX_RECORD)]
    hash: _Text = ""


class _TeamRef(msgspec.Struct):
    label: _Text
    spec: _Text
    hash: _Text = ""


class _Header(msgspec.Struct):
    """The header's schema: what a reader may rely on (other fields are allowed and ignored)."""

    format: str
    version: int
    level: _LevelRef
    seed: Annotated[int, msgspec.Meta(ge=-(1 << 63), le=(1 << 63) - 1)]
    ideal: bool
    record_rate: Annotated[int, msgspec.Meta(gt=0, le=100_000)]
    control_period: Annotated[float, msgspec.Meta(gt=0, le=1e6)]
    teams: Annotated[list[_TeamRef], msgspec.Meta(min_length=1, max_length=64)]
    software: _Text = ""
    behaviour: int = 0
    noise_key: Annotated[str, msgspec.Meta(pattern="^[0-9a-f]{64}$")] | None = None


class _Frame(msgspec.Struct):
    k: str
    t: Annotated[float, msgspec.Meta(ge=0, le=1e7)]
    p: Annotated[list[tuple[float, float, float]], msgspec.Meta(max_length=64)]


class _Trial(msgspec.Struct):
    k: str
    t: Annotated[float, msgspec.Meta(ge=0, le=1e7)]
    n: Annotated[int, msgspec.Meta(ge=1)]


_FIXED = f"%.{DECIMALS}f"


def _number(value: float) -> str:
    """A float rounded to DECIMALS places as JSON writes it: the repr of `round(value,
    DECIMALS)`; TypeError unless it is a finite float. Between 1e-4 and 1e6 in size, `%.9f`
    gives the same decimal as round() (both are correctly rounded), and with at most 15
    significant digits that decimal, trailing zeros dropped, is also repr's shortest form."""
    if type(value) is float and 1e-4 <= abs(value) < 1e6:
        text = (_FIXED % value).rstrip("0")
        return text + "0" if text[-1] == "." else text
    text = float.__repr__(round(value, DECIMALS))
    if "n" in text:  # nan, inf
        raise TypeError("not finite")
    return text


_TRAILING_ZEROS = re.compile("0+\n")


def _numbers(values: list[float]) -> list[str]:
    """`_number` of each value, formatted at once: one `%` for all of them and one pass to
    drop their trailing zeros; the few outside the fast range (a heading near 0) one by one."""
    if not values or not all(type(v) is float for v in values):
        return list(map(_number, values))
    text = _TRAILING_ZEROS.sub("\n", (_FIXED + "\n") * len(values) % tuple(values)).replace(".\n", ".0\n")
    if "n" in text:  # nan, inf
        raise TypeError("not finite")
    texts = text.split("\n")
    if not (1e-4 <= min(map(abs, values)) and max(map(abs, values)) < 1e6):
        for i, v in enumerate(values):
            if not 1e-4 <= abs(v) < 1e6:
                texts[i] = _number(v)
    return texts[:-1]


@functools.cache
def _string(value: str | None) -> str:
    """A string (beacon ids, event kinds: a handful per match) or None as JSON."""
    return json.dumps(value)


@functools.lru_cache(maxsize=1024)
def _place(x: float, y: float, x_sign: float, y_sign: float) -> str:
    """A point as two `_number`s: a beam's far end, formatted once per beacon. The signs are
    part of the key, since 0.0 and -0.0 are one key but two texts."""
    return _number(x) + "," + _number(y)


def _floats(values: Iterable[float]) -> str:
    return "[" + ",".join(map(_number, values)) + "]"


def _rounded(values: Iterable[float]) -> list[float]:
    return [round(v, DECIMALS) for v in values]


def _event_line(f: dict[str, Any]) -> str:
    """An `e` record as `json.dumps(sort_keys=True)` writes it, without its generic encoder."""
    if len(f) != 6:
        raise KeyError("fields")
    beam = f["line"]
    if beam is not None:
        x, y, bx, by = beam
        beam = _beam(_number(x), _number(y), bx, by)
    return _EVENT % (_string(f["b"]), _string(f["kind"]), beam or "null", _int(f["r"]), _int(f["s"]), _number(f["t"]))


_EVENT = '{"b":%s,"k":"e","kind":%s,"line":%s,"r":%s,"s":%s,"t":%s}'


def _beam(x: str, y: str, bx: float, by: float) -> str:
    """A beam as JSON: the laser's place (formatted) and its far end, a beacon's place: a
    handful per match, each formatted once."""
    return "[" + x + "," + y + "," + _place(bx, by, math.copysign(1.0, bx), math.copysign(1.0, by)) + "]"


def _event_lines(slot: int, detections: Sequence[Any]) -> list[str]:
    """The `e` records of one robot's detections, as `_event_line` writes each: their numbers
    formatted at once (`_numbers`). TypeError or ValueError where the encoder must write them."""
    if type(slot) is not int:
        raise TypeError("not an int")
    values: list[float] = []
    for d in detections:
        values.append(d.time)
        if d.beam is not None:
            values += d.beam[:2]
    numbers = iter(_numbers(values))
    r, lines = int.__repr__(slot), []
    for d in detections:
        t, beam = next(numbers), d.beam
        if beam is not None:
            beam = _beam(next(numbers), next(numbers), *beam[2:])
        if type(d.source) is not int:
            raise TypeError("not an int")
        lines.append(_EVENT % (_string(d.beacon), _string(d.kind), beam or "null", r, int.__repr__(d.source), t) + "\n")
    return lines


def _estimate_line(f: dict[str, Any]) -> str:
    """An `est` record as `json.dumps(sort_keys=True)` writes it."""
    if len(f) != 3:
        raise KeyError("fields")
    return '{"e":' + _floats(f["e"]) + ',"k":"est","r":' + _int(f["r"]) + ',"t":' + _number(f["t"]) + "}"


def _int(value: int) -> str:
    if type(value) is not int:
        raise TypeError("not an int")
    return int.__repr__(value)


def controller_hash(spec: str) -> str:
    """sha256 of a controller's code, found without running it (`referee.sandbox.teams.Team.code_hash`)."""
    from referee.sandbox.teams import code_hash

    return code_hash(spec)


class ReplayWriter:
    """Writes one match's replay as it runs: to a private file (0600) beside the target,
    moved into place only when the match has ended, so no controller can read it meanwhile.
    `teams` holds each slot's (label, spec, code hash): the hash of the code that ran, which
    may have been shipped from a machine where the spec's files live."""

    def __init__(
        self,
        path: str | Path,
        level: Level,
        level_text: str,
        seed: int,
        ideal: bool,
        teams: list[tuple[str, str, str]],
        software: str,
        noise_key: str | None = None,
    ):
        self.path = Path(path)
        fd, self.partial = tempfile.mkstemp(dir=self.path.resolve().parent, prefix=".laserarena-", suffix=".part")
        raw = os.fdopen(fd, "wb")
        self.gz = gzip.GzipFile(filename="", mode="wb", fileobj=raw, mtime=0, compresslevel=6)
        self.raw = raw
        self.file: IO[str] = io.TextIOWrapper(self.gz, encoding="utf-8", newline="\n")
        self._lines: list[str] = []  # records not yet handed to the compressor
        # the compressor's own thread: zlib lets go of the GIL, so it compresses while the
        # match runs on (the same chunks in the same order: the same bytes)
        self._chunks: queue.Queue[str | None] = queue.Queue(maxsize=_QUEUED)
        self._failure: BaseException | None = None
        self._compressor: threading.Thread | None = None  # started with the first chunk
        self._write(
            {
                "format": FORMAT,
                "version": VERSION,
                "behaviour": BEHAVIOUR,
                "software": software,
                "level": {"name": level.name, "hash": level.hash, "text": level_text},
                "seed": seed,
                "ideal": ideal,
                "record_rate": level.record_rate,
                "control_period": level.control_period,
                "teams": [{"label": label, "spec": spec, "hash": code} for label, spec, code in teams],
                **({"noise_key": noise_key} if noise_key else {}),
            }
        )

    def _write(self, obj: dict[str, Any]) -> None:
        self._lines.append(dumps(obj, indent=None) + "\n")

    def _hot(self, line: str | None, record: Callable[[], dict[str, Any]]) -> None:
        """A hot record (frame, event, estimate), formatted by hand the way JSON's encoder with
        sorted keys writes it, floats rounded to DECIMALS places (None: a value was not a
        finite float, an int, a string or None, so the encoder itself writes `record()`)."""
        if line is None:
            line = json.dumps(record(), sort_keys=True, separators=(",", ":"))
        self._lines.append(line + "\n")
        if len(self._lines) >= 512:
            self._flush()

    def _flush(self) -> None:
        """Hand the records so far to the compressor's thread (its failure, if any, is raised here)."""
        if self._failure is not None:
            raise self._failure
        if self._compressor is None:
            self._compressor = threading.Thread(target=self._compress, name="replay-compressor", daemon=True)
            self._compressor.start()
        self._chunks.put("".join(self._lines))
        self._lines.clear()

    def _compress(self) -> None:
        while (chunk := self._chunks.get()) is not None:
            if self._failure is None:
                try:
                    self.file.write(chunk)
                except BaseException as e:  # a full disk: raised in the match's thread, at its next flush
                    self._failure = e

    def _finish(self) -> None:
        """Let the compressor's thread write what it was given, and end it."""
        if self._compressor is not None and self._compressor.is_alive():
            self._chunks.put(None)
            self._compressor.join()

    def frame(self, time: float, poses: list[tuple[float, float, float]]) -> None:
        self.frames([(time, poses)])

    def _frame(self, time: float, poses: list[tuple[float, float, float]]) -> None:
        line: str | None
        try:
            line = '{"k":"f","p":[' + ",".join(map(_floats, poses)) + '],"t":' + _number(time) + "}"
        except TypeError:
            line = None
        self._hot(line, lambda: {"k": "f", "t": round(time, DECIMALS), "p": [_rounded(p) for p in poses]})

    def frames(self, frames: list[tuple[float, list[tuple[float, float, float]]]]) -> None:
        """Frames (time, every robot's pose), their numbers formatted at once."""
        try:
            if any(len(p) != 3 for _, poses in frames for p in poses):
                raise ValueError("a pose is (x, y, heading)")
            numbers = iter(_numbers([v for time, poses in frames for v in (time, *(u for p in poses for u in p))]))
            lines = []
            for _, poses in frames:
                t = next(numbers)
                p = ",".join("[" + next(numbers) + "," + next(numbers) + "," + next(numbers) + "]" for _ in poses)
                lines.append('{"k":"f","p":[' + p + '],"t":' + t + "}\n")
        except (TypeError, ValueError):  # a value the encoder must write: one frame at a time
            for time, poses in frames:
                self._frame(time, poses)
            return
        self._lines += lines
        if len(self._lines) >= 512:
            self._flush()

    def events(self, slot: int, detections: Sequence[Any]) -> None:
        """The `e` records of robot `slot`'s detections (arena.sensing.events.Detection), at once."""
        try:
            self._lines += _event_lines(slot, detections)
        except (TypeError, ValueError):  # a value the encoder must write: one record at a time
            for d in detections:
                self.record("e", t=d.time, r=slot, s=d.source, kind=d.kind, b=d.beacon, line=d.beam)
            return
        if len(self._lines) >= 512:
            self._flush()

    def record(self, record_kind: str, **fields: Any) -> None:
        if record_kind not in ("e", "est"):
            self._write({"k": record_kind, **fields})
            return
        text: str | None
        try:
            text = _event_line(fields) if record_kind == "e" else _estimate_line(fields)
        except (TypeError, KeyError):
            text = None

        def rounded() -> dict[str, Any]:
            line, est = fields.get("line"), fields.get("e")
            fields["t"] = round(fields["t"], DECIMALS)
            if line is not None:
                fields["line"] = _rounded(line)
            if est is not None:
                fields["e"] = _rounded(est)
            return {"k": record_kind, **fields}

        self._hot(text, rounded)

    def discard(self) -> None:
        """Drop the unfinished replay (the match did not end): no `.part` file is left behind."""
        self._failure = self._failure or ReplayError("discarded")  # nothing more is compressed
        try:
            self._finish()
            self.file.close()
            self.raw.close()
        except (OSError, ValueError):
            pass
        finally:  # even if a second interrupt cuts the wait for the compressor short
            Path(self.partial).unlink(missing_ok=True)

    def close(self, result: dict[str, Any]) -> None:
        self._write({"k": "result", "result": result})
        self._flush()
        self._finish()
        if self._failure is not None:
            raise self._failure
        self.file.close()  # closes the gzip stream and the file beneath
        self.raw.close()
        os.replace(self.partial, self.path)  # still 0600 (mkstemp): an organizer file


class MemoryRecorder:
    """The ReplayWriter interface, recording into a `Replay` in memory (for live viewing)."""

    def __init__(self, level: Level, level_text: str, seed: int, ideal: bool, teams: list[tuple[str, str]]):
        self.replay = Replay(
            {
                "format": FORMAT,
                "version": VERSION,
                "level": {"name": level.name, "hash": level.hash, "text": level_text},
                "seed": seed,
                "ideal": ideal,
                "record_rate": level.record_rate,
                "control_period": level.control_period,
                "teams": [{"label": label, "spec": spec} for label, spec in teams],
            }
        )

    def frame(self, time: float, poses: list[tuple[float, float, float]]) -> None:
        self.replay.frames.append((time, [list(p) for p in poses]))

    def frames(self, frames: list[tuple[float, list[tuple[float, float, float]]]]) -> None:
        for time, poses in frames:
            self.frame(time, poses)

    def events(self, slot: int, detections: Sequence[Any]) -> None:
        for d in detections:
            self.record("e", t=d.time, r=slot, s=d.source, kind=d.kind, b=d.beacon, line=d.beam)

    def record(self, record_kind: str, **fields: Any) -> None:
        lists = {
            "e": self.replay.events,
            "est": self.replay.estimates,
            "dbg": self.replay.debug,
            "foul": self.replay.fouls,
            "fault": self.replay.faults,
            "trial": self.replay.trials,
        }
        lists[record_kind].append({"k": record_kind, **fields})

    def close(self, result: dict[str, Any]) -> None:
        self.replay.result = result


@dataclass
class Replay:
    """A replay read back: the header, the frames, and the other records by kind."""

    header: dict[str, Any]
    frames: list[tuple[float, list[list[float]]]] = field(default_factory=list)
    events: list[dict[str, Any]] = field(default_factory=list)
    estimates: list[dict[str, Any]] = field(default_factory=list)
    debug: list[dict[str, Any]] = field(default_factory=list)
    fouls: list[dict[str, Any]] = field(default_factory=list)
    faults: list[dict[str, Any]] = field(default_factory=list)
    trials: list[dict[str, Any]] = field(default_factory=list)  # {"t": when, "n": which} of each trial after the first
    result: dict[str, Any] | None = None

    @property
    def moves(self) -> list[float]:
        """The times at which the robots were carried to a new trial's poses."""
        return [float(r["t"]) for r in self.trials]

    @property
    def duration(self) -> float:
        return self.frames[-1][0] if self.frames else 0.0


def lines(path: str | Path) -> Iterator[bytes]:
    """Stream a replay's decompressed lines; ReplayError (a ValueError, one line) on a file or
    a decompressed whole over MAX_REPLAY bytes, a line over MAX_RECORD, or damaged gzip. No more
    than a line is held at a time, whatever the file holds."""
    if os.stat(path).st_size > MAX_REPLAY:
        raise ReplayError(f"{path}: a file over {MAX_REPLAY} bytes, more than a replay may be")
    with gzip.open(path, "rb") as f:
        n = total = 0
        while True:
            try:
                line = f.readline(MAX_RECORD + 1)
            except (OSError, EOFError, zlib.error) as e:
                raise ReplayError(f"{path}: a truncated or damaged replay ({e})") from None
            if not line:
                return
            n += 1
            total += len(line)
            if len(line) > MAX_RECORD:
                raise ReplayError(f"{path}: record {n} is over {MAX_RECORD} bytes")
            if total > MAX_REPLAY:
                raise ReplayError(f"{path}: over {MAX_REPLAY} bytes decompressed, more than a replay may hold")
            yield line


def records(path: str | Path) -> Iterator[dict[str, Any]]:
    """Stream a replay's records (dicts), header first; ReplayError (a ValueError, one line) as
    `lines` gives it, or on a record that is not JSON, nested too deeply or not an object."""
    for n, line in enumerate(lines(path), 1):
        try:
            rec = msgspec.json.decode(line)
        except msgspec.DecodeError as e:
            raise ReplayError(f"{path}: record {n} is not JSON ({e})") from None
        except RecursionError:
            raise ReplayError(f"{path}: record {n} is nested too deeply") from None
        if not isinstance(rec, dict):
            raise ReplayError(f"{path}: record {n} is not an object")
        yield rec


def _measure(path: str | Path) -> None:
    """Read `path` through once, a line at a time: ReplayError as `lines` gives it (the first
    line's as 'not a LaserArena replay')."""
    read = 0
    try:
        for _line in lines(path):
            read += 1
    except ReplayError as e:
        if read:
            raise
        raise ReplayError(f"{path}: not a LaserArena replay ({str(e).removeprefix(f'{path}: ')})") from None


def check_header(header: dict[str, Any], path: str | Path) -> None:
    """Raise ReplayError (one line) unless `header` is a replay header this version reads."""
    if header.get("format") != FORMAT:
        raise ReplayError(f"{path}: not a LaserArena replay")
    if header.get("version") != VERSION:
        raise ReplayError(f"{path}: replay format version {str(header.get('version'))[:20]}, this is {VERSION}")
    try:
        msgspec.convert(header, _Header)
    except msgspec.ValidationError as e:
        raise ReplayError(f"{path}: a damaged replay header ({e})") from None


def load(path: str | Path, keep: bool = True) -> Replay:
    """Read a whole replay (ReplayError, one line, if it is not one or is damaged). Its size is
    checked first, a line at a time, so a replay over MAX_REPLAY is refused before anything is
    kept. `keep=False` checks every record but keeps only the header, the last frame and the
    result: what `verify` and the web page need, in the memory of one record."""
    if keep:
        _measure(path)
    it = records(path)
    try:
        header = next(it)
    except StopIteration:
        raise ReplayError(f"{path}: not a LaserArena replay (empty)") from None
    except ValueError as e:
        raise ReplayError(f"{path}: not a LaserArena replay ({str(e).removeprefix(f'{path}: ')})") from None
    check_header(header, path)
    rep = Replay(header)
    slots = len(header["teams"])
    lists = {"e": rep.events, "est": rep.estimates, "dbg": rep.debug, "foul": rep.fouls, "fault": rep.faults}
    for rec in it:
        k = rec.get("k")
        if k == "f":
            try:
                frame = msgspec.convert(rec, _Frame)
            except msgspec.ValidationError as e:
                raise ReplayError(f"{path}: a damaged frame record ({e})") from None
            if len(frame.p) != slots:
                raise ReplayError(f"{path}: a frame with {len(frame.p)} robots, the header has {slots}")
            if keep:
                rep.frames.append((frame.t, rec["p"]))
            else:
                rep.frames[:] = [(frame.t, rec["p"])]
        elif k == "result":
            rep.result = rec.get("result")
        elif k == "trial":
            try:
                msgspec.convert(rec, _Trial)  # its time is read as a number (`Replay.moves`)
            except msgspec.ValidationError as e:
                raise ReplayError(f"{path}: a damaged trial record ({e})") from None
            if keep:
                rep.trials.append(rec)
        elif k in lists and keep:
            lists[k].append(rec)
    if not rep.frames:
        raise ReplayError(f"{path}: a replay without frames")
    return rep
