"""Reading a replay back: its lines and records streamed (`lines`, `records`), or the whole
of it checked and kept (`load`).

Reading is bounded: a replay is at most `MAX_REPLAY` bytes, compressed and decompressed
(counted as it streams, so a gzip bomb stops there), a record at most `MAX_RECORD` bytes,
nested JSON cannot exhaust the stack, and the header has a fixed, typed schema (its level
text is parsed as safely as a level file). The result is read as its typed record when it is
of this software's result version (of another version, `Replay.result` is None).
"""

from __future__ import annotations

import gzip
import io
import os
import zlib
from collections.abc import Iterator
from pathlib import Path
from typing import Annotated, Any

import msgspec

from referee.errors import ReplayError
from referee.records.replay_format import FORMAT, MAX_RECORD, MAX_REPLAY, VERSION, Replay
from referee.records.results import RESULT_FORMAT, RESULT_VERSION, MatchResult

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


def lines(path: str | Path, data: bytes | None = None) -> Iterator[bytes]:
    """Stream a replay's decompressed lines; ReplayError (a ValueError, one line) on a file or
    a decompressed whole over MAX_REPLAY bytes, a line over MAX_RECORD, or damaged gzip. No more
    than a line is held at a time, whatever the file holds. With `data` (a replay's bytes held
    in memory, as a worker sent them), those are read, and `path` only names them."""
    if (os.stat(path).st_size if data is None else len(data)) > MAX_REPLAY:
        raise ReplayError(f"{path}: a file over {MAX_REPLAY} bytes, more than a replay may be")
    with gzip.open(path if data is None else io.BytesIO(data), "rb") as f:
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


def records(path: str | Path, data: bytes | None = None) -> Iterator[dict[str, Any]]:
    """Stream a replay's records (dicts), header first; ReplayError (a ValueError, one line) as
    `lines` gives it, or on a record that is not JSON, nested too deeply or not an object."""
    for n, line in enumerate(lines(path, data), 1):
        try:
            rec = msgspec.json.decode(line)
        except msgspec.DecodeError as e:
            raise ReplayError(f"{path}: record {n} is not JSON ({e})") from None
        except RecursionError:
            raise ReplayError(f"{path}: record {n} is nested too deeply") from None
        if not isinstance(rec, dict):
            raise ReplayError(f"{path}: record {n} is not an object")
        yield rec


def _measure(path: str | Path, data: bytes | None = None) -> None:
    """Read `path` through once, a line at a time: ReplayError as `lines` gives it (the first
    line's as 'not a LaserArena replay')."""
    read = 0
    try:
        for _line in lines(path, data):
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


def _result(rec: dict[str, Any], path: str | Path) -> MatchResult | None:
    """The result record's typed result; None for a result of another format or version (as
    an older replay holds), ReplayError (one line) for a damaged one of this version."""
    data = rec.get("result")
    if not isinstance(data, dict) or (data.get("format"), data.get("version")) != (RESULT_FORMAT, RESULT_VERSION):
        return None
    try:
        return MatchResult.from_dict(data)
    except msgspec.ValidationError as e:
        raise ReplayError(f"{path}: a damaged result record ({e})") from None


def load(path: str | Path, keep: bool = True, data: bytes | None = None) -> Replay:
    """Read a whole replay (ReplayError, one line, if it is not one or is damaged). Its size is
    checked first, a line at a time, so a replay over MAX_REPLAY is refused before anything is
    kept. `keep=False` checks every record but keeps only the header, the last frame and the
    result: what `verify` and the web page need, in the memory of one record. `data`: read
    these bytes, named `path` (as `lines`)."""
    if keep:
        _measure(path, data)
    it = records(path, data)
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
            rep.result = _result(rec, path)
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
