"""The replay writer formats its hot records (frames, events, estimates) by hand, for speed.
Every line must be what JSON's own encoder (sorted keys, compact) writes for the same record:
checked here against `json.dumps` on values chosen to be awkward."""

import errno
import gzip
import io
import json
import math
import random

import pytest
from helpers import MINI_LEVEL
from hypothesis import given
from hypothesis import strategies as st

from levels.loader import parse_level
from referee.records.canonical import DECIMALS
from referee.records.replay_format import Header, TeamEntry
from referee.records.replay_writer import ReplayWriter

AWKWARD = [0.0, -0.0, 1e-07, -7.31e-07, 2.5e-05, 1e-05, 0.1, 1e16, 1.2345678901234568e17, 1e22, 5e-324, 123.456789012]
AWKWARD += [1e-4, -1e-4, 0.000099999999999, 0.0001000000005, 999999.9999999999, 1e6, -999999.999999999, 0.1 + 0.2]
AWKWARD += [2.0000000005, 2.0000000015, 0.0000000005, 123456.1234567895, 1.5, -3.0]


def floats(rng: random.Random, n: int) -> list[float]:
    return [
        rng.choice(AWKWARD) if rng.random() < 0.3 else rng.uniform(-10, 10) * 10 ** rng.randint(-9, 9) for _ in range(n)
    ]


def rounded(values):
    return [round(v, DECIMALS) for v in values]


def writer(path):
    """A replay writer of a mini level's match, to `path`."""
    level = parse_level(MINI_LEVEL.encode(), "mini.yaml")
    teams = (TeamEntry("a", "ref:idle", ""),)
    header = Header(
        level.name, level.hash, MINI_LEVEL, 1, False, level.record_rate, level.control_period, teams, "test"
    )
    return ReplayWriter(path, header)


def test_hot_records_are_what_json_writes(tmp_path):
    path = tmp_path / "r.replay"
    w = writer(path)
    rng = random.Random(7)
    expected = []
    for k in range(3000):
        t = abs(floats(rng, 1)[0])
        choice = k % 4
        if choice == 0:
            poses = [tuple(floats(rng, 3)) for _ in range(rng.randint(0, 4))]
            w.frame(t, poses)
            rec = {"k": "f", "t": round(t, DECIMALS), "p": [rounded(p) for p in poses]}
        elif choice == 1:
            beam = None if rng.random() < 0.2 else tuple(floats(rng, 4))
            if k % 8 == 1:  # beacons repeat (the writer formats each once): zeros of both signs too
                beam = (*floats(rng, 2), *rng.choice([(0.0, 2.0), (-0.0, 2.0), (2.0, -0.0), (1.5, 2.5)]))
            beacon = rng.choice([None, "A", "n1", 'q"uote\\', "Öst", "\u2603 snow"])
            kind = rng.choice(["hit", "index", "scan"])
            r, s = rng.randint(0, 3), rng.randint(-1, 3)
            w.record("e", t=t, r=r, s=s, kind=kind, b=beacon, line=beam)
            rec = {"k": "e", "t": round(t, DECIMALS), "r": r, "s": s, "kind": kind, "b": beacon}
            rec["line"] = None if beam is None else rounded(beam)
        elif choice == 2:
            e = floats(rng, 3)
            w.record("est", t=t, r=1, e=e)
            rec = {"k": "est", "t": round(t, DECIMALS), "r": 1, "e": rounded(e)}
        else:  # values the fast path does not take: JSON's encoder writes them as it always did
            e = [math.nan, 1, True][k % 3 : k % 3 + 1] + [1.5, 2.5]
            w.record("est", t=t, r=2, e=e)
            rec = {"k": "est", "t": round(t, DECIMALS), "r": 2, "e": [round(v, DECIMALS) for v in e]}
        expected.append(json.dumps(rec, sort_keys=True, separators=(",", ":")))
    w.close({"done": True})
    lines = gzip.open(path).read().decode().splitlines()
    assert lines[1:-1] == expected
    assert json.loads(lines[-1]) == {"k": "result", "result": {"done": True}}


@given(st.floats(allow_nan=True, allow_infinity=True) | st.floats(min_value=-2e6, max_value=2e6))
def test_a_number_is_what_json_writes_for_it_rounded(value):
    from referee.records.replay_lines import number

    rounded = round(value, DECIMALS)
    if math.isfinite(rounded):
        assert number(value) == json.dumps(rounded)
    else:
        try:
            number(value)
        except TypeError:
            return
        raise AssertionError("a non-finite value must go to JSON's own encoder")


@given(st.lists(st.floats(allow_nan=True, allow_infinity=True) | st.sampled_from(AWKWARD), max_size=40))
def test_numbers_at_once_are_each_number_as_json_writes_it(values):
    from referee.records.replay_lines import numbers

    if all(math.isfinite(v) for v in values):
        assert numbers(values) == [json.dumps(round(v, DECIMALS)) for v in values]
        return
    try:  # a NaN or an infinity anywhere: the encoder writes the record, as for one number
        numbers(values)
    except TypeError:
        return
    raise AssertionError("a non-finite value must go to JSON's own encoder")


def test_a_control_periods_records_at_once_are_what_json_writes(tmp_path):
    """Frames and every robot's detections, written a control period at a time."""
    from arena.sensing.events import Detection

    path = tmp_path / "r.replay"
    w = writer(path)
    rng = random.Random(11)
    expected = []
    for k in range(400):
        if k % 2:
            frames = [floats(rng, 12) + [abs(floats(rng, 1)[0])] for _ in range(rng.randint(1, 7))]
            if k % 10 == 1:  # a value only JSON's encoder writes: those frames go one by one
                frames[0][:3] = [math.inf, 1.0, 2.0]
            w.frames(frames)
            for frame in frames:
                poses = [frame[i : i + 3] for i in range(0, 12, 3)]
                rec = {"k": "f", "t": round(frame[-1], DECIMALS), "p": [rounded(p) for p in poses]}
                expected.append(json.dumps(rec, sort_keys=True, separators=(",", ":")))
            continue
        robots = [[] for _ in range(rng.randint(1, 4))]
        for slot, detections in enumerate(robots):
            for _ in range(rng.choice([0, 1, rng.randint(1, 12)])):
                beam = (
                    None
                    if rng.random() < 0.2
                    else (*floats(rng, 2), *rng.choice([(0.0, 2.0), (-0.0, 2.0), (1.5, 2.5)]))
                )
                d = Detection(
                    slot,
                    abs(floats(rng, 1)[0]),
                    rng.choice(["hit", "index"]),
                    rng.choice([None, "A", 'q"']),
                    None,
                    (),
                    rng.randint(-1, 3),
                    beam,
                )
                detections.append(d)
                rec = {"k": "e", "t": round(d.time, DECIMALS), "r": slot, "s": d.source, "kind": d.kind, "b": d.beacon}
                rec["line"] = None if beam is None else rounded(beam)
                expected.append(json.dumps(rec, sort_keys=True, separators=(",", ":")))
        w.events(robots)
    w.close({"done": True})
    lines = gzip.open(path).read().decode().splitlines()
    assert lines[1:-1] == expected


def test_a_write_that_fails_in_the_compressors_thread_is_raised_in_the_match_and_nothing_is_left(tmp_path):
    """The replay is compressed in a thread of its own; a full disk there is the match's error,
    and a discarded replay leaves no thread and no partial file behind."""

    class FullDisk(io.StringIO):
        def write(self, text):
            raise OSError(errno.ENOSPC, "No space left on device")

    w = writer(tmp_path / "r.replay")
    w.file = FullDisk()
    with pytest.raises(OSError, match="No space left"):
        for k in range(5000):  # a few chunks of records: the first one fails in the thread
            w.frame(k / 10, [(1.0, 2.0, 0.5)])
        w.close({})
    w.discard()
    assert w._compressor is not None and not w._compressor.is_alive()
    assert list(tmp_path.iterdir()) == []


def test_numbers_round_halfway_values_to_even_as_json_writes_them():
    """Floats exactly halfway between two nine-place decimals (odd multiples of 2**-10 and
    finer: 1e9 / 1024 ends in .5), and the floats next to them on both sides: the compiled
    formatter's exact product must choose as Python's correctly rounded `round` does."""
    from referee.records.replay_lines import numbers

    halfway = [m / 2**k for k in range(10, 40, 3) for m in range(1, 3001, 2)]
    values = [v for h in halfway for v in (h, math.nextafter(h, 0.0), math.nextafter(h, 1.0)) if 1e-4 <= v < 1e6]
    values += [-v for v in values]
    assert numbers(values) == [json.dumps(round(v, DECIMALS)) for v in values]


def test_numbers_of_random_floats_are_what_json_writes():
    """Floats of every magnitude the compiled formatter writes (1e-4 up to 1e6, both signs),
    their bits drawn at random, a thousand at a time, against Python's own rounding."""
    from referee.records.replay_lines import numbers

    rng = random.Random(3)
    for _ in range(100):
        values = [rng.choice((1, -1)) * rng.uniform(1, 10) * 10.0 ** rng.randint(-4, 5) for _ in range(1000)]
        assert numbers(values) == [json.dumps(round(v, DECIMALS)) for v in values]
