"""What a team's answers can cost the referee: an answer is bounded in bytes from its header
(before it is read or decoded), and the referee's decoding of it is paid from the team's own
think budget; a team that takes back from its protocol pipe the bytes the referee was told were
there stalls nobody (docs/protocol.md, docs/security.md)."""

import dataclasses
import json
import os
import select
import threading
import time

from hostile.hostile_kit import FAST, assert_contained, assert_others_unharmed, hostile_match
from referee.sandbox.channel import Channel, Trouble
from robots._host import protocol

# a team that replaces its own writer: every answer it sends is the message it builds here
WRITER = """
import robots._host.protocol as P

def frame(tick):
    return BODY.replace(b"TICK", str(tick).encode())

def write(stream, msg):
    if isinstance(msg, P.CommandMsg):
        data = frame(msg.tick)
        stream.write(len(data).to_bytes(4, "big") + data)
        stream.flush()
    else:
        SENT(stream, msg)

SENT, P.write = P.write, write

class Writer(Controller):
    def step(self, obs):
        return Command(0.0, 0.0)
"""


def largest_legal_answer(number: float) -> bytes:
    """A `command` message as large as the schema allows: every drawing at its caps, every
    character an escaped surrogate pair, every number `number` (TICK stands for the tick)."""
    emoji = "\U0001f600"
    drawing = {
        "kind": emoji * 16,
        "points": [[number, number]] * protocol.MAX_POINTS,
        "radius": abs(number),
        "text": emoji * protocol.MAX_TEXT,
        "color": [255, 255, 255],
    }
    command = {"left": number, "right": number, "estimate": [number] * 3, "debug": [drawing] * protocol.MAX_DRAWINGS}
    text = json.dumps({"type": "command", "v": 1, "tick": 0, "command": command}, separators=(",", ":"))
    return text.replace('"tick":0', '"tick":TICK').encode()


def writer(body: bytes) -> str:
    return f"BODY = {body!r}\n" + WRITER


def test_the_largest_legal_answer_is_exactly_the_bound():
    """The bound follows from the schema: the largest message Python's own JSON encoder makes
    within every cap (numbers of 24 characters, 12 bytes a character) is exactly as long, and
    decodes; one byte of padding more is past it."""
    body = largest_legal_answer(-1.2345678901234567e-300).replace(b"TICK", str(1 << 40).encode())
    assert len(body) == protocol.answer_bound()
    assert isinstance(protocol.answer(body), protocol.CommandMsg)
    assert len(body + b" ") > protocol.answer_bound()


def test_a_frame_over_the_bound_is_a_protocol_fault_that_names_it(tmp_path):
    padded = largest_legal_answer(0.5) + b" " * protocol.answer_bound()  # valid JSON, too long
    bad = assert_contained(hostile_match(tmp_path, writer(padded)), "protocol", "bound")
    assert f"over the {protocol.answer_bound()}-byte bound of an answer" in bad["faults"][0]["message"]
    assert bad["faults"][0]["tick"] == 0


SLOW_NUMBER = -1.2345678901234567e-300  # the slowest kind of number to read (an extreme exponent)


def decoding(body: bytes) -> float:
    """CPU seconds the referee's decoding of the answer `body` takes on this machine (the
    median of three)."""
    frame, took = body.replace(b"TICK", b"1"), []
    for _ in range(3):
        start = time.process_time()
        protocol.answer(frame)
        took.append(time.process_time() - start)
    return sorted(took)[1]


def test_decoding_a_legal_answer_is_paid_from_the_senders_think_budget(tmp_path):
    """Answers within the bound whose decoding takes the referee long: the sender, not the
    referee or the others, pays for it, until its think budget is spent. The same team sending
    small answers, after building the same bytes, thinks within its budget. The budget is 40
    decodings of the match's 100, whatever this machine's decoder takes for one (msgspec 0.22
    read the largest answer in 0.3 s here, 0.23 in 10 ms)."""
    big = largest_legal_answer(SLOW_NUMBER)
    limits = dataclasses.replace(FAST, think_budget=40 * decoding(big) / 20.0)  # per simulated s of 20
    bad = assert_contained(hostile_match(tmp_path, writer(big), seconds=20.0, limits=limits), "timeout", "in step")
    assert bad["faults"][0]["tick"] < 50  # of 100: the overage bank or the think budget ran out
    small = largest_legal_answer(0.5).split(b',"debug"')[0] + b"}}"
    calm = hostile_match(tmp_path, f"UNSENT = {big!r}\n" + writer(small), seconds=20.0, limits=limits)
    assert calm["robots"][0]["faults"] == []
    assert_others_unharmed(calm)


def test_bytes_taken_back_from_the_pipe_stall_only_their_own_answer():
    """A controller may reopen its own output pipe (/proc/self/fd) and read back what it wrote
    after the referee's select() saw it: the referee's read then finds nothing and returns at
    once (the pipe still open), and the answer times out at its deadline, never later."""
    theirs_r, theirs_w = os.pipe()  # the controller's input
    ours, its_output = os.pipe()  # its output, which the referee reads
    channel = Channel(open(theirs_w, "wb"), open(ours, "rb"))
    os.write(its_output, b"\0\0")  # half a frame header
    assert select.select([channel.fileno()], [], [], 1.0)[0]  # the referee sees it
    thief = os.open(f"/proc/self/fd/{ours}", os.O_RDONLY)  # as a controller reopens its pipe
    assert os.read(thief, 16) == b"\0\0"  # and takes it back
    got: list = []
    worker = threading.Thread(target=lambda: got.append((channel.read(), channel.receive(0.5))), daemon=True)
    worker.start()
    worker.join(10.0)
    assert not worker.is_alive(), "the referee blocked on a read"
    assert got == [(True, Trouble.TIMEOUT)]  # nothing read, the stream not ended; no answer by the deadline
    for fd in (thief, theirs_r, its_output):
        os.close(fd)
    channel.close()


STALLER = """
import array, fcntl, struct, termios
from robots._host import protocol

def pipes():
    found = {}
    for fd in range(3, 64):
        try:
            mode = fcntl.fcntl(fd, fcntl.F_GETFL) & os.O_ACCMODE
        except OSError:
            continue
        if os.readlink(f"/proc/self/fd/{fd}").startswith("pipe:"):
            found.setdefault(mode, fd)
    return found[os.O_RDONLY], found[os.O_WRONLY]

def waiting(fd):
    buf = array.array("i", [0])
    fcntl.ioctl(fd, termios.FIONREAD, buf)
    return buf[0]

def frame(msg):
    data = protocol._ENCODER.encode(msg)
    return struct.pack(">I", len(data)) + data

class Staller(Controller):
    # it leaves its input unread, answering each observation the moment it lands; once the
    # pipe is full the referee cannot write the next, and the staller empties it only just
    # before the step's deadline: the referee waited, on the staller's clock
    def setup(self, brief):
        pin, pout = pipes()
        os.write(pout, frame(protocol.Ready(v=1)))
        try:
            fcntl.fcntl(pin, 1031, 4096)  # F_SETPIPE_SZ: one page (refused in a sandbox)
        except OSError:
            pass
        os.set_blocking(pin, False)
        tick, seen = 0, 0
        while True:
            begun = time.monotonic()
            while waiting(pin) <= seen:
                time.sleep(0.0002)
                if time.monotonic() - begun > 0.2:  # stuck: the referee cannot write; empty the pipe late
                    while True:
                        try:
                            if not os.read(pin, 65536):
                                os._exit(0)
                        except BlockingIOError:
                            break
                    seen, begun = -1, time.monotonic() + 30
            seen = waiting(pin)
            os.write(pout, frame(protocol.CommandMsg(v=1, tick=tick, command=Command(0.0, 0.0))))
            tick += 1

    def step(self, obs):
        return Command(0.0, 0.0)
"""


def test_an_observation_written_late_is_its_readers_time(tmp_path):
    """The clock of an answer starts before its observation is written: a controller that lets
    its input fill and empties it late pays the referee's wait from its own allowance (it is
    stopped for time; or, answering an observation the referee had not finished writing, for
    the protocol), and no other controller waits for its observation meanwhile."""
    result = hostile_match(tmp_path, STALLER, seconds=120.0)
    assert_others_unharmed(result)
    (fault,) = result["robots"][0]["faults"]
    assert fault["tick"] < 600 and result["robots"][0]["stopped"]
    assert fault["kind"] == "timeout" or fault["message"] == "in step: it answers without reading its observations"
