"""The per-tick cost of the controller protocol on this machine, checks included.

Run: python benchmarks/protocol.py [--n 20000]
Prints microseconds per message for what crosses the pipe every control tick -- the referee
encoding an observation and decoding, checking a command; the runner the reverse -- and, as
a yardstick measured in the same run, the stdlib's bare `json.dumps`/`json.loads` of the same
bytes with no checks at all.
"""

from __future__ import annotations

import argparse
import io
import json
import time

from robots._host import protocol
from robots.api import Command, Observation, SensorEvent

OBS = Observation(120, 6.0, tuple(SensorEvent(5.9 + 0.01 * i, "hit", "A", 1.0 + i) for i in range(4)))
CMD = Command(0.1, 0.12, (0.5, 0.4, 1.2))


def per_call(n: int, f) -> float:
    start = time.perf_counter()
    for _ in range(n):
        f()
    return (time.perf_counter() - start) / n * 1e6


def measure(n: int) -> dict:
    def frame(msg: protocol.Message) -> bytes:
        buf = io.BytesIO()
        protocol.write(buf, msg)
        return buf.getvalue()[4:]

    obs_bytes = frame(protocol.Step(v=1, obs=OBS))
    cmd_bytes = frame(protocol.CommandMsg(v=1, tick=120, command=CMD))
    obs_plain, cmd_plain = json.loads(obs_bytes), json.loads(cmd_bytes)
    step_buffer = bytearray()

    def referee() -> None:
        protocol.step_frame(OBS, step_buffer)
        msg = protocol.parse(cmd_bytes)
        assert isinstance(msg, protocol.CommandMsg)
        protocol.command_problem(protocol.decoded(msg.command, Command))

    def runner() -> None:
        msg = protocol.parse(obs_bytes)
        assert isinstance(msg, protocol.Step)
        protocol.decoded(msg.obs, Observation)
        protocol.write(io.BytesIO(), protocol.CommandMsg(v=1, tick=120, command=CMD))

    def bare() -> None:
        json.loads(cmd_bytes), json.loads(obs_bytes)
        json.dumps(obs_plain).encode(), json.dumps(cmd_plain).encode()

    return {"referee_us": per_call(n, referee), "runner_us": per_call(n, runner), "bare_json_us": per_call(n, bare)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=20000)
    m = measure(ap.parse_args().n)
    print("controller protocol, one control tick (4 sensor events, a command with an estimate)")
    print(f"  referee: encode obs, decode + check command   {m['referee_us']:6.2f} us")
    print(f"  runner:  decode obs, encode command           {m['runner_us']:6.2f} us")
    print(
        f"  stdlib json, both messages both ways, no checks {m['bare_json_us']:6.2f} us "
        f"(typed + checked / bare: {(m['referee_us'] + m['runner_us']) / m['bare_json_us']:.2f})"
    )


if __name__ == "__main__":
    main()
