"""The controller protocol cannot be crashed: whatever bytes a team writes, the referee sees a
`ProtocolError` (a typed fault for that slot) and the match goes on for everyone else."""

import gzip
import io
import json
import math
import random
import struct
import textwrap

import msgspec
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import levels
from levels.loader import parse_level
from referee.match.loop import play_match
from referee.sandbox.teams import resolve
from robots._host import protocol
from robots.api import Brief, Command, Drawing, Observation, SensorEvent


def frame(body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + body


VALID = [
    {"type": "ready"},
    {"type": "stop"},
    {"type": "fault", "kind": "exception", "message": "in step: ValueError"},
    {
        "type": "command",
        "tick": 7,
        "command": {
            "left": 0.1,
            "right": -0.2,
            "estimate": [1.0, 2.0, 3.0],
            "debug": [{"kind": "line", "points": [[0, 0], [1, 1]], "radius": 0.0, "text": "hi", "color": [1, 2, 3]}],
        },
    },
    {
        "type": "step",
        "obs": {
            "tick": 3,
            "time": 0.15,
            "events": [{"time": 0.1, "kind": "hit", "beacon": "A", "angle": 1.5, "samples": []}],
        },
    },
]


def decode_everything(data: bytes) -> None:
    """What each side does with a frame: the referee decodes a controller's message once
    (`answer`); a controller decodes the referee's envelope, then its payload. Each side either
    decodes a clean, finite, bounded value or raises ProtocolError; the first error is raised
    again when neither side takes the frame."""
    errors = []
    for side in (_as_the_referee, _as_a_controller):
        try:
            side(data)
        except protocol.ProtocolError as e:
            errors.append(e)
    if len(errors) == 2:
        raise errors[0]


def _as_the_referee(data: bytes) -> None:
    if isinstance(msg := protocol.answer(data), protocol.CommandMsg):
        _clean(msg.command)


def _as_a_controller(data: bytes) -> None:
    match protocol.parse(data):
        case protocol.CommandMsg(command=raw):
            _clean(protocol.decoded(raw, Command))
        case protocol.Step(obs=raw):
            protocol.decoded(raw, Observation)
        case protocol.Setup(brief=raw):
            protocol.decoded(raw, Brief)


def _clean(cmd: Command) -> None:
    assert protocol.command_problem(cmd) is None
    assert all(math.isfinite(v) and abs(v) <= protocol.LIMIT for v in (cmd.left, cmd.right))
    assert len(cmd.debug) <= protocol.MAX_DRAWINGS


def only_protocol_errors(data: bytes) -> None:
    try:
        decode_everything(data)
    except protocol.ProtocolError as e:
        assert str(e) and "\n" not in str(e)


def mutations(rng: random.Random, base: bytes) -> bytes:
    """A valid frame, damaged: bytes flipped, cut, repeated, or a number made enormous."""
    b = bytearray(base)
    choice = rng.randrange(6)
    if choice == 0 and b:
        for _ in range(rng.randint(1, 8)):
            b[rng.randrange(len(b))] = rng.randrange(256)
    elif choice == 1:
        b = b[: rng.randrange(len(b) + 1)]
    elif choice == 2:
        i = rng.randrange(len(b) + 1)
        b = b[:i] + b[i : i + rng.randint(1, 20)] * rng.randint(2, 50) + b[i:]
    elif choice == 3:
        b = bytearray(base.replace(b"0.1", b"1" + b"0" * rng.randint(300, 5000)))
    elif choice == 4:
        b = bytearray(
            base.replace(
                b"0.1", rng.choice([b"1e400", b"-1e309", b"NaN", b"Infinity", b"true", b'"0.1"', b"null", b"[]", b"{}"])
            )
        )
    else:
        depth = rng.randint(1000, 200_000)
        b = bytearray(base.replace(b"0.1", b"[" * depth + b"]" * depth))
    return bytes(b)


def a_setup_message() -> dict:
    from levels.loader import load_level
    from referee.match.views import brief_for

    return {"type": "setup", "brief": msgspec.to_builtins(brief_for(load_level(levels.path("asabe-race")), 1))}


def test_a_seeded_fuzzer_gets_nothing_but_protocol_errors():
    rng = random.Random(20261123)
    bases = [json.dumps({"v": 1, **m}).encode() for m in [*VALID, a_setup_message()]]
    for base in bases:
        decode_everything(base)  # undamaged, each one decodes
    for _ in range(3000):
        only_protocol_errors(mutations(rng, rng.choice(bases)))
    for _ in range(300):  # noise
        only_protocol_errors(bytes(rng.randrange(256) for _ in range(rng.randint(0, 200))))


@settings(max_examples=300, deadline=None)
@given(
    st.recursive(
        st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=20),
        lambda kids: st.lists(kids, max_size=5) | st.dictionaries(st.text(max_size=8), kids, max_size=5),
        max_leaves=40,
    )
)
def test_any_json_value_as_a_command_is_decoded_or_refused_by_name(value):
    try:
        body = json.dumps({"v": 1, "type": "command", "tick": 1, "command": value}).encode()
    except ValueError:
        return
    only_protocol_errors(body)
    with pytest.raises(protocol.ProtocolError) if not isinstance(value, dict) else _maybe():
        protocol.decoded(json.dumps(value).encode(), Command)  # the payload alone takes the same checks


class _maybe:
    def __enter__(self):
        return self

    def __exit__(self, kind, e, tb):
        return kind is protocol.ProtocolError


def test_every_refusal_names_the_field():
    def problem(command: bytes) -> str:
        msg = protocol.parse(b'{"v":1,"type":"command","tick":1,"command":' + command + b"}")
        with pytest.raises(protocol.ProtocolError) as e:
            protocol.decoded(msg.command, Command)
        return str(e.value)

    assert "command.left" in problem(b'{"left":1' + b"0" * 400 + b',"right":0}')
    assert "command.right" in problem(b'{"left":0,"right":1e400}')
    assert "command.estimate" in problem(b'{"left":0,"right":0,"estimate":[1,2]}')
    assert "command.debug[0].points[0][1]" in problem(b'{"left":0,"right":0,"debug":[{"kind":"x","points":[[0,1e9]]}]}')
    assert "command.debug[0].color[2]" in problem(b'{"left":0,"right":0,"debug":[{"kind":"x","color":[0,0,256]}]}')
    assert "unknown field" in problem(b'{"left":0,"right":0,"x":1}')
    with pytest.raises(protocol.CommandError, match="at `command.debug"):  # the referee's one decoding says the same
        protocol.answer(
            b'{"v":1,"type":"command","tick":1,"command":{"left":0,"right":0,"debug":[{"kind":"x","points":[[0,1e9]]}]}}'
        )
    with pytest.raises(protocol.ProtocolError, match="nested too deeply"):
        protocol.parse(b'{"v":1,"type":"command","tick":1,"command":' + b"[" * 100_000 + b"]" * 100_000 + b"}")


def test_frames_over_the_limit_are_refused_before_reading_them():
    huge = struct.pack(">I", protocol.MAX_FRAME + 1)
    with pytest.raises(protocol.ProtocolError, match="over the"):
        protocol.read(io.BytesIO(huge))
    with pytest.raises(protocol.ProtocolError, match="truncated"):
        protocol.read(io.BytesIO(frame(b"{}")[:-1]))
    with pytest.raises(protocol.ProtocolError, match="over the"):
        protocol.parse(b" " * (protocol.MAX_FRAME + 1))
    drawings = b",".join([b'{"kind":"point","points":[[0,0]]}'] * 100_000)  # 3.3 MB, under the frame limit
    msg = protocol.parse(
        b'{"v":1,"type":"command","tick":1,"command":{"left":0,"right":0,"debug":[' + drawings + b"]}}"
    )
    with pytest.raises(protocol.ProtocolError, match="command.debug"):
        protocol.decoded(msg.command, Command)


def test_numpy_scalars_are_numbers_on_the_wire():
    cmd = Command(
        np.float32(0.0625),
        np.float64(-0.125),
        tuple(np.array([1.5, 2.25, -0.5])),
        (Drawing("line", ((np.float32(1.0), np.int64(2)),), color=(np.int64(1), np.uint8(2), 3)),),
    )
    assert protocol.command_problem(cmd) is None
    buf = io.BytesIO()
    protocol.write(buf, protocol.CommandMsg(v=1, tick=1, command=cmd))
    msg = protocol.read(io.BytesIO(buf.getvalue()))
    assert isinstance(msg, protocol.CommandMsg) and msg.tick == 1
    back = protocol.decoded(msg.command, Command)
    assert back == protocol.wired(cmd)  # a controller in the referee's process: the same numbers
    assert back == Command(0.0625, -0.125, (1.5, 2.25, -0.5), (Drawing("line", ((1.0, 2.0),), color=(1, 2, 3)),))
    assert all(type(v) is float for v in (back.left, back.right, *back.estimate))


def test_a_step_frame_is_the_step_message_write_sends():
    obs = Observation(7, 0.35, (SensorEvent(0.3, "hit", "A", 1.25), SensorEvent(0.31, "scan", samples=(0, 255))), 2)
    sent = io.BytesIO()
    protocol.write(sent, protocol.Step(v=1, obs=obs))
    assert bytes(protocol.step_frame(obs, bytearray(b"old"))) == sent.getvalue()
    msg = protocol.read(io.BytesIO(sent.getvalue()))
    assert isinstance(msg, protocol.Step) and protocol.decoded(msg.obs, Observation) == obs


@pytest.mark.parametrize(
    "body,words",
    [
        (b'{"type":"ready"}', "missing required field `v`"),
        (b'{"v":2,"type":"ready"}', "message.v"),
        (b'{"v":1,"type":"ready","x":1}', "unknown field `x`"),
        (b'{"v":1,"type":"hello"}', "Invalid value 'hello'"),
        (b'{"v":1,"type":"loaded","api":-1}', "message.api"),
    ],
)
def test_a_bad_envelope_is_refused_by_name(body, words):
    with pytest.raises(protocol.ProtocolError, match="^message: ") as e:
        protocol.parse(body)
    assert words in str(e.value)


def test_a_payload_with_an_unknown_field_is_refused_at_any_depth():
    with pytest.raises(protocol.ProtocolError, match="unknown field `x` - at `obs.events\\[0\\]`"):
        protocol.decoded(b'{"tick":1,"time":0,"events":[{"time":0,"kind":"hit","x":1}]}', Observation)


def test_fault_kinds_are_their_names_on_the_wire():
    buf = io.BytesIO()
    protocol.write(buf, protocol.FaultMsg(v=1, kind=protocol.FaultKind.BAD_COMMAND, message="m"))
    assert buf.getvalue()[4:] == b'{"type":"fault","v":1,"kind":"bad_command","message":"m"}'
    assert {str(k) for k in protocol.REPORTED} == {"load", "exception", "memory", "bad_command"}


class Nasty:
    def __repr__(self):
        raise RuntimeError("no")

    def __float__(self):
        raise RuntimeError("no")


@pytest.mark.parametrize(
    "cmd",
    [
        Command(10**400, 0),
        Command(0, -(10**5000)),
        Command(float("nan"), 0),
        Command(0, float("inf")),
        Command(True, 0),
        Command("1", 0),
        Command(Nasty(), 0),
        Command(0, 0, (0, 0, 10**400)),
        Command(0, 0, "xyz"),
        Command(0, 0, None, "x"),
        Nasty(),
        None,
    ],
)
def test_command_problem_judges_without_raising(cmd):
    assert protocol.command_problem(cmd)


# ---- real hostile controllers against a real match ------------------------------------------

RAW_WRITER = """
import fcntl, os, stat, struct
from robots.api import Command, Controller

def protocol_fd():
    # the runner keeps the protocol on a private pipe; a hostile team finds it anyway
    for fd in range(3, 256):
        try:
            flags = fcntl.fcntl(fd, fcntl.F_GETFL)
        except OSError:
            continue
        if flags & os.O_ACCMODE == os.O_WRONLY and stat.S_ISFIFO(os.fstat(fd).st_mode):
            return fd
    raise RuntimeError("no protocol pipe")

class Raw(Controller):
    def step(self, obs):
        if obs.tick == 4:
            body = PAYLOAD.replace(b"TICK", str(obs.tick).encode())
            os.write(protocol_fd(), struct.pack(">I", len(body)) + body)
        return Command(0.05, 0.05)
"""


def race(seconds: int = 8):
    text = levels.path("asabe-race").read_text().replace("time_limit: 180", f"time_limit: {seconds}")
    return parse_level(text.encode(), "race.yaml")


def hostile(shared_dir, body: str, name: str = "hostile.py", isolate: bool = True, replay=None) -> dict:
    path = shared_dir / name
    path.write_text(textwrap.dedent(body))
    teams = [resolve(str(path))] + [resolve("ref:dead-reckoning")] * 3
    return play_match(race(), teams, seed=2, isolate=isolate, replay=replay)


STOPS_AT_4 = """
    from robots.api import Command, Controller
    class Stops(Controller):
        def step(self, obs):
            return Command(0.05, 0.05) if obs.tick < 4 else Command(0.0, 0.0)
"""


def contained(result, kind: str, shared_dir) -> str:
    """Slot 0 was stopped at tick 4 with one fault of `kind`; every other slot played exactly
    the match it plays beside an honest team that stops at tick 4 itself."""
    bad, *others = result["robots"]
    assert [f["kind"] for f in bad["faults"]] == [kind], bad["faults"]
    assert bad["stopped"] and bad["faults"][0]["tick"] == 4
    honest = hostile(shared_dir, STOPS_AT_4, "stops.py")["robots"][1:]
    assert others == honest
    assert all(not r["faults"] and r["localization"]["fraction"] == 1.0 for r in others)
    return bad["faults"][0]["message"]


def test_an_overflowing_number_written_raw_is_a_bad_command(shared_dir):
    body = RAW_WRITER.replace(
        "PAYLOAD", repr(b'{"v":1,"type":"command","tick":TICK,"command":{"left":1' + b"0" * 400 + b',"right":0}}')
    )
    assert "command.left" in contained(hostile(shared_dir, body), "bad_command", shared_dir)


def test_a_deeply_nested_frame_written_raw_is_refused_at_its_first_bracket(shared_dir):
    """200,000 nested lists where the schema wants an object: refused by type at the first
    bracket (no recursion), as the whole frame (protocol) or as its command (bad_command)."""
    deep = b"[" * 200_000 + b"]" * 200_000
    whole = RAW_WRITER.replace("PAYLOAD", repr(deep))
    assert "got `array`" in contained(hostile(shared_dir, whole), "protocol", shared_dir)
    inner = RAW_WRITER.replace("PAYLOAD", repr(b'{"v":1,"type":"command","tick":TICK,"command":' + deep + b"}"))
    assert "got `array` - at `command`" in contained(hostile(shared_dir, inner), "bad_command", shared_dir)


@pytest.mark.parametrize("isolate", [True, False])
def test_a_returned_overflowing_command_is_a_bad_command(shared_dir, isolate):
    result = hostile(
        shared_dir,
        """
        from robots.api import Command, Controller
        class Big(Controller):
            def step(self, obs):
                return Command(10 ** 400 if obs.tick == 4 else 0.05, 0.05)
    """,
        isolate=isolate,
    )
    assert "Command.left" in contained(result, "bad_command", shared_dir)


@pytest.mark.parametrize("isolate", [True, False])
def test_numpy_commands_drive_exactly_as_plain_floats(shared_dir, isolate):
    body = """
        import numpy as np
        from robots.api import Command, Controller, Drawing
        class Team(Controller):
            def step(self, obs):
                return Command(WRAP(0.0625), WRAP(0.125), estimate=ESTIMATE,
                               debug=(Drawing("line", ((WRAP(1.0), WRAP(0.5)), (0.0, 0.0))),))
    """
    numpy = hostile(
        shared_dir,
        body.replace("WRAP", "np.float32").replace("ESTIMATE", "tuple(np.array([1.0, 0.5, 0.25], np.float32))"),
        "np_team.py",
        isolate,
        shared_dir / "n.replay",
    )
    plain = hostile(
        shared_dir,
        body.replace("WRAP", "float").replace("ESTIMATE", "(1.0, 0.5, 0.25)"),
        "plain_team.py",
        isolate,
        shared_dir / "p.replay",
    )
    records = [gzip.open(shared_dir / f"{n}.replay").read().splitlines()[1:-1] for n in "np"]  # no header, result
    assert records[0] == records[1]  # every frame, estimate and drawing recorded alike
    assert not numpy["robots"][0]["faults"]
    assert numpy["robots"][0]["final_pose"] == plain["robots"][0]["final_pose"]
    assert numpy["robots"][0]["localization"] == plain["robots"][0]["localization"]
    assert numpy["robots"][0]["localization"]["fraction"] == 1.0


@pytest.mark.parametrize("isolate", [True, False])
@pytest.mark.parametrize(
    "version", [1, 3]
)  # written for the brief of old (a start as a tuple), or for a future referee
def test_a_controller_for_another_api_version_is_refused_in_one_line(tmp_path, isolate, version):
    team = tmp_path / "other.py"
    team.write_text(
        textwrap.dedent(f"""
        from robots.api import Command, Controller

        class Other(Controller):
            api_version = {version}

            def step(self, obs):
                return Command(0.1, 0.1)
    """)
    )
    level = parse_level(levels.path("bac-static").read_bytes(), "levels/bac-static.yaml")
    result = play_match(level, [resolve(str(team))], isolate=isolate)
    (fault,) = result["robots"][0]["faults"]
    assert fault["kind"] == "load" and fault["tick"] == 0
    assert fault["message"] == f"the team's controller speaks API version {version}, this referee speaks 2"
    assert result["robots"][0]["stopped"]


@pytest.mark.parametrize(
    "drawing,words",
    [
        (Drawing("point", ((0, 1e300),)), "finite"),
        (Drawing("point", ((0, 1),), color=(0, 0, 300)), "color"),
        (Drawing("x", ((0, 1),)), "kind 'x'"),
        ("x", "not a Drawing"),
    ],
)
def test_a_bad_drawing_is_dropped_not_fatal(drawing, words):
    assert words in protocol.drawing_problem(drawing)
    cmd = protocol.sendable(Command(0, 0, None, (drawing, Drawing("point", ((0, 1),)))))
    assert protocol.command_problem(cmd) is None  # the controller goes on
    assert [g.kind for g in cmd.debug] == [protocol.DROPPED, "point"] and words in cmd.debug[0].text
