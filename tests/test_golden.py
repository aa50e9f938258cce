"""The golden replay: a change detector, as the replay issue asks.

It fails when a change alters simulation results (physics, sensing, noise, controllers,
scoring) without a bump of the replay format version, of `referee.records.replay_format.BEHAVIOUR`
or of the result format it ends with (`referee.records.results.RESULT_VERSION`). After a
deliberate change, bump the one that changed and regenerate: `python tests/test_golden.py`.
"""

import gzip
import hashlib
import json
import sys
import tempfile
from pathlib import Path

from helpers import variant

from referee.match.loop import play_match
from referee.records.replay_format import BEHAVIOUR, VERSION
from referee.records.results import RESULT_VERSION
from referee.sandbox.teams import resolve

GOLDEN = Path(__file__).parent / "golden" / "replay.json"


def content_hash() -> str:
    """sha256 of the decompressed replay of a 6 s four-robot race with sensing noise."""
    level = variant("asabe-race", "levels/asabe-race.yaml", time_limit=6)
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "golden.replay"
        play_match(
            level,
            [resolve("ref:best"), resolve("ref:bac"), resolve("ref:dead-reckoning"), resolve("ref:starter")],
            seed=11,
            replay=path,
            isolate=False,
        )
        lines = gzip.open(path).read().splitlines()
    header = json.loads(lines[0])
    header.pop("software")  # the version string may change without the simulation changing
    for team in header["teams"]:
        team.pop("hash")  # source hashes change with comments; behaviour is what we guard
    body = b"\n".join([json.dumps(header, sort_keys=True).encode()] + lines[1:])
    return "sha256:" + hashlib.sha256(body).hexdigest()


def test_golden_replay():
    golden = json.loads(GOLDEN.read_text())
    assert (golden["format"], golden["behaviour"], golden["result"]) == (VERSION, BEHAVIOUR, RESULT_VERSION), (
        "the replay format, behaviour or result version changed: regenerate with `python tests/test_golden.py`"
    )
    assert content_hash() == golden["sha256"], (
        "simulation results changed without a version bump: if that is intended, bump "
        "referee.records.replay_format.BEHAVIOUR and regenerate with `python tests/test_golden.py`"
    )


if __name__ == "__main__":
    GOLDEN.write_text(
        json.dumps(
            {"format": VERSION, "behaviour": BEHAVIOUR, "result": RESULT_VERSION, "sha256": content_hash()}, indent=2
        )
        + "\n"
    )
    print(f"wrote {GOLDEN}", file=sys.stderr)
