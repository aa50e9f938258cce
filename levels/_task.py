"""A level file's `task`: its kind, the path or goal it names, and a localize task's trials
(docs/levels.md, docs/rules.md)."""

from __future__ import annotations

import math

from levels import yaml_reader as yr
from levels._geometry import inside, pose
from levels.model import Field, Pose, Task, Trials

TASK_KINDS = ("waypoints", "goto", "localize", "race")
TASK_KEYS = ("kind", "radius", "path", "goal", "trials", "settle", "accuracy")
SETTLE = 1.0  # s a goto robot stands to arrive, where its level does not say
TRIALS_KEYS = ("count", "positions", "region", "headings", "heading_spread")


def task(m: yr.Map, fld: Field) -> tuple[Task, tuple[tuple[float, float], ...]]:
    """The task, and the path it gives every robot (empty: each robot names its own)."""
    ctx = m.ctx
    kind = m.req("kind", yr.choice(*TASK_KINDS))
    path: tuple[tuple[float, float], ...] = ()
    goal = None
    radius = 0.0
    if kind in ("waypoints", "goto", "race"):
        radius = m.req("radius", yr.length)
    if kind == "waypoints":
        path = m.opt("path", yr.points, ())  # else each robot names its own
    elif kind == "goto":
        g = m.raw("goal")
        vals = g.value if isinstance(g.value, list) else None
        goal = (
            pose(ctx, g, m.key("goal"))
            if vals is not None and len(vals) == 3
            else Pose(*yr.point(ctx, g, m.key("goal")), math.nan)
        )
        inside(ctx, fld, (goal.x, goal.y), g.line, m.key("goal"), "goal")
    settle, accuracy = 0.0, 0.0
    if kind == "goto":
        settle = m.opt("settle", yr.positive, SETTLE)
        accuracy = m.opt("accuracy", yr.length, radius)
    elif kind in ("waypoints", "race"):  # none: every waypoint reached counts whole
        accuracy = m.opt("accuracy", yr.length, 0.0)
    followed = ("waypoints", "race", "goto")
    for key, allowed in (("path", ("waypoints",)), ("goal", ("goto",)), ("settle", ("goto",)), ("accuracy", followed)):
        if m.has(key) and kind not in allowed:
            raise ctx.fail(m.raw(key).line, m.key(key), f"not used by a {kind} task")
    if kind == "localize" and m.has("radius"):
        raise ctx.fail(m.raw("radius").line, m.key("radius"), "not used by a localize task")
    for i, p in enumerate(path):
        inside(ctx, fld, p, m.raw("path").line, f"{m.key('path')}[{i}]", "waypoint")
    trials = Trials()
    if m.has("trials"):
        if kind != "localize":
            raise ctx.fail(m.raw("trials").line, m.key("trials"), f"not used by a {kind} task (only by localize)")
        trials = _trials(m.sub("trials", TRIALS_KEYS), fld)
    return Task(kind=kind, radius=radius, goal=goal, trials=trials, settle=settle, accuracy=accuracy), path


def _trials(m: yr.Map, fld: Field) -> Trials:
    """A localize task's trials: how many, and where their secret poses come from."""
    ctx = m.ctx
    count = m.req("count", yr.count)
    if count < 1:
        raise ctx.fail(m.raw("count").line, m.key("count"), "at least one trial (the start)")
    if m.has("positions") and m.has("region"):
        raise ctx.fail(m.raw("region").line, m.key("region"), "give positions or a region, not both")
    if count > 1 and not (m.has("positions") or m.has("region")):
        raise ctx.fail(m.node.line, m.key("positions"), "trials after the first need positions or a region")
    positions = m.opt("positions", yr.points, ())
    for i, p in enumerate(positions):
        inside(ctx, fld, p, m.raw("positions").line, f"{m.key('positions')}[{i}]", "trial position")
    region = m.opt("region", yr.rectangle, None)
    if region is not None:
        for corner in (region[:2], region[2:]):
            inside(ctx, fld, corner, m.raw("region").line, m.key("region"), "corner")
    headings: tuple[float, ...] = ()
    if m.has("headings"):
        node = m.raw("headings")
        if not isinstance(node.value, list) or not node.value:
            raise ctx.fail(
                node.line, m.key("headings"), f"expected a list of headings (deg), got {yr.kind(node.value)}"
            )
        headings = tuple(math.radians(yr.number(ctx, n, f"{m.key('headings')}[{i}]")) for i, n in enumerate(node.value))
    if m.has("heading_spread") and m.has("headings"):
        raise ctx.fail(
            m.raw("heading_spread").line, m.key("heading_spread"), "give headings or a heading_spread, not both"
        )
    spread = m.opt("heading_spread", yr.half_turn, None)
    return Trials(count=count, positions=positions, region=region, headings=headings, heading_spread=spread)
