"""The score table printed after a match (team names and texts made safe for a terminal)."""

from __future__ import annotations

from referee.records.faults import told
from referee.records.results import MatchResult
from referee.terminal import safe


def _mm(v: float | None) -> str:
    return "-" if v is None else f"{v * 1000:.1f}"


def _deg(v: float | None) -> str:
    return "-" if v is None else f"{v * 57.29577951308232:.2f}"


def _progress(task: dict) -> str:
    if task["kind"] in ("waypoints", "race"):
        text = f"{task['reached']}/{task['total']} waypoints"
    elif task["kind"] == "goto":
        d = task["final_distance"]
        text = f"goal at {d:.3f} m" if d is not None else "goal"
    else:
        text = "localize"
    return text + (f" in {task['finished']:.2f} s" if task["finished"] is not None else "")


FAULT_WIDTH = 200  # a fault's message under the table, cut to this many characters


def table(result: MatchResult, logs: dict[int, str] | None = None) -> str:
    """A fixed-width table: one row per robot with score, progress and localization error;
    under it each fault's message on one line, with the team's file and line where it raised,
    and where the faulted slot's log is (`logs`:
    None when no log is kept, which a line then says how to get)."""
    head = (
        f"{safe(result['level']['name'])}  seed {result['seed']}  ended at {result['end_time']:.3f} s "
        f"({result['end_reason'].replace('_', ' ')})"
    )
    cols = (
        "slot",
        "team",
        "score",
        "task",
        "pos rms mm",
        "pos max mm",
        "hdg rms deg",
        "hdg max deg",
        "est %",
        "quality",
        "fouls",
        "faults",
    )
    rows = [cols]
    for r in result["robots"]:
        loc = r["localization"]
        faults = ", ".join(f"{safe(f['kind'], 20)}@{f['time']:.2f}s" for f in r["faults"]) or "-"
        fouls = f"{len(r['fouls'])} (-{r['score']['penalties']:.1f})" if r["fouls"] else "-"
        rows.append(
            (
                str(r["slot"]),
                safe(r["team"], 60),
                f"{r['score']['total']:.1f}",
                _progress(r["task"]),
                _mm(loc["position_rms"]),
                _mm(loc["position_max"]),
                _deg(loc["heading_rms"]),
                _deg(loc["heading_max"]),
                f"{100 * loc['fraction']:.0f}",
                f"{loc['quality']:.2f}",
                fouls,
                faults,
            )
        )
    widths = [max(len(row[i]) for row in rows) for i in range(len(cols))]
    lines = [head] + ["  ".join(c.ljust(w) for c, w in zip(row, widths)).rstrip() for row in rows]
    for r in result["robots"]:
        for f in r["faults"]:
            lines.append(
                f"slot {r['slot']} {safe(f['kind'], 20)} at {f['time']:.2f} s: {safe(told(f, FAULT_WIDTH), 400)}"
            )
        if r["faults"] and logs and r["slot"] in logs:
            lines.append(f"slot {r['slot']} log: {safe(logs[r['slot']], 200)}")
    if logs is None and any(r["faults"] for r in result["robots"]):
        lines.append("(--logs DIR keeps each controller's output; the result has each traceback's tail)")
    return "\n".join(lines)
