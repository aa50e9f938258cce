"""A rogue Dask worker, as a `dask worker --preload` module: it holds the organizer's worker
key but answers each match as the file named by ROGUE_MODE says:

- `pickle`: a result whose unpickling runs code (it appends the loading process's pid and uid
  to ROGUE_MARKER, unless that process is one of the rogue worker's own);
- `raise`: no result but an exception whose unpickling runs the same code;
- `forge`: the real match with the robot's total score set to 999.0 in the result only;
- `forge-both`: the same, in the result and in the replay's last record alike;
- anything else: an honest reply.
"""

import gzip
import json
import os

import referee.contest.runner as runner

MARKER = os.environ["ROGUE_MARKER"]
PAYLOAD = (  # run where it is loaded, but in the rogue worker's own processes (they know ROGUE_MODE)
    "import os\n"
    "if 'ROGUE_MODE' not in os.environ:\n"
    f"    with open({MARKER!r}, 'a') as f: f.write(f'{{os.getpid()}} {{os.getuid()}}\\n')"
)


class Loaded:
    """Runs PAYLOAD wherever it is unpickled."""

    def __reduce__(self):
        return (exec, (PAYLOAD,))


class Loud(Exception):
    """An exception that runs PAYLOAD wherever it is unpickled."""

    def __reduce__(self):
        return (exec, (PAYLOAD,))


def _mode() -> str:
    with open(os.environ["ROGUE_MODE"]) as f:
        return f.read().strip()


def rogue_serve(job):
    mode = _mode()
    if mode == "pickle":
        return Loaded()
    if mode == "raise":
        raise Loud("a rogue worker's exception")
    played = runner.play(job)  # (this module may be imported twice: never call `runner.serve`, now this)
    reply = {"result": played.result, "replay": played.replay, "wall": played.wall}
    if mode in ("forge", "forge-both"):
        from referee.records.canonical import dumps

        data = json.loads(reply["result"])
        data["robots"][0]["score"]["total"] = 999.0
        reply["result"] = dumps(data)
        if mode == "forge-both":
            lines = gzip.decompress(reply["replay"]).splitlines(keepends=True)
            last = json.loads(lines[-1])
            last["result"] = data
            lines[-1] = (json.dumps(last, separators=(",", ":"), sort_keys=True) + "\n").encode()
            reply["replay"] = gzip.compress(b"".join(lines), mtime=0)
    return reply


runner.serve = rogue_serve
