"""How a level's match runs: its clocks (`physics_rate`, `control_period`, `record_rate`), the
`limits` on controllers and the `rules` fouls are judged by (docs/levels.md, docs/rules.md)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

from levels import yaml_reader as yr
from levels._frozen import reduce_proxies

DEFAULT_RECORD_RATE = 30  # replay frames per second
RULE_KEYS = ("speed_limit", "min_impulse", "position_scale", "heading_scale", "penalties")
LIMIT_KEYS = (
    "setup_time",
    "step_time",
    "step_deadline",
    "overage_bank",
    "max_skips",
    "think_budget",
    "memory_mb",
    "log_kb",
)


@dataclass(frozen=True)
class ControllerLimits:
    """What each controller may use: set-up time, time per step, an overage bank for
    occasional slow steps, consecutive skipped ticks before disqualification, a think budget
    for the whole match (so no team can stretch a grade without limit), memory."""

    setup_time: float = 10.0  # s for start-up, imports and setup()
    step_time: float = 0.1  # s per control step; slower answers draw on the bank
    step_deadline: float = 1.0  # s; later answers are skipped ticks
    overage_bank: float = 5.0  # s, summed over the match
    max_skips: int = 5  # consecutive skipped ticks
    think_budget: float = 0.25  # s of answer time per simulated second of the time limit, summed over the match
    memory: int = 1 << 30  # bytes of address space (0: none)
    log_bytes: int = 1 << 20  # stdout + stderr kept per controller; more is an output flood (0: none)


@dataclass(frozen=True)
class Rules:
    """The level's rules: what counts as a foul and what each costs (points off the score)."""

    speed_limit: float = 0.0  # m/s; 0 = none
    min_impulse: float = 0.02  # N s: lighter touches are not collisions
    # the localization score's scales (docs/rules.md): an estimate this far off in position,
    # or this far off in heading, earns half the points of a perfect one at that tick
    position_scale: float = 0.01  # m
    heading_scale: float = 0.05  # rad: Bac's dead band, "more than 0.05 radians"
    penalties: Mapping[str, float] = field(
        default_factory=lambda: MappingProxyType(
            {
                "robot_collision": 2.0,
                "wall_collision": 1.0,
                "obstacle_collision": 1.0,
                "beacon_collision": 5.0,
                "leave_field": 10.0,
                "speeding": 1.0,
                "skipped_tick": 0.5,
                "fault": 25.0,
            }
        )
    )

    __reduce__ = reduce_proxies


def clocks(top: yr.Map) -> tuple[int, float, int]:
    """(physics_rate, control_period, record_rate): a control period of whole physics steps,
    and replay frames that fall on physics steps."""
    physics_rate = top.opt("physics_rate", yr.integer, 240)
    if physics_rate <= 0:
        raise top.ctx.fail(top.raw("physics_rate").line, "physics_rate", "must be positive")
    control_period = top.req("control_period", yr.positive)
    steps = control_period * physics_rate
    if abs(steps - round(steps)) > 1e-6 or round(steps) < 1:
        raise top.ctx.fail(
            top.raw("control_period").line,
            "control_period",
            f"{control_period:g} s is not a whole multiple of the physics step 1/{physics_rate} s",
        )
    record_rate = top.opt("record_rate", yr.integer, DEFAULT_RECORD_RATE)
    if record_rate <= 0 or physics_rate % record_rate:
        raise _rate_problem(top, physics_rate, record_rate)
    return physics_rate, control_period, record_rate


def _rate_problem(top: yr.Map, physics_rate: int, record_rate: int) -> yr.ReadError:
    """record_rate must divide physics_rate; when it was left at its default, the fault is the
    physics_rate the file does give, so say that rather than blame a key that is not there."""
    divisors = [d for d in range(1, physics_rate + 1) if physics_rate % d == 0 and 10 <= d <= 60]
    hint = f" (e.g. {' or '.join(map(str, divisors[:3]))})" if divisors else ""
    if not top.has("record_rate"):
        return top.ctx.fail(
            top.raw("physics_rate").line,
            "physics_rate",
            f"{physics_rate} Hz is not a multiple of the default record_rate {record_rate} Hz; "
            f"give a physics_rate that is, or set record_rate to a divisor of {physics_rate}{hint}",
        )
    return top.ctx.fail(
        top.raw("record_rate").line,
        "record_rate",
        f"{record_rate} Hz must be positive and divide physics_rate {physics_rate} Hz{hint}",
    )


def rules(m: yr.Map) -> Rules:
    """The rules: the defaults, with the keys the level gives replaced."""
    d = Rules()
    penalties = dict(d.penalties)
    if m.has("penalties"):
        pm = m.sub("penalties", tuple(d.penalties))
        for name in d.penalties:
            penalties[name] = pm.opt(name, yr.nonnegative, penalties[name])
    return Rules(
        speed_limit=m.opt("speed_limit", yr.nonnegative, 0.0) * m.ctx.scale,
        min_impulse=m.opt("min_impulse", yr.nonnegative, d.min_impulse),
        position_scale=m.opt("position_scale", yr.length, d.position_scale),
        heading_scale=math.radians(m.opt("heading_scale", yr.positive, math.degrees(d.heading_scale))),
        penalties=MappingProxyType(penalties),
    )


def limits(m: yr.Map) -> ControllerLimits:
    """The controllers' limits: the defaults, with the keys the level gives replaced."""
    d = ControllerLimits()
    skips = m.opt("max_skips", yr.count, d.max_skips)
    if skips < 1:
        raise m.ctx.fail(m.raw("max_skips").line, m.key("max_skips"), "must be at least 1")
    step_time = m.opt("step_time", yr.positive, d.step_time)
    deadline = m.opt("step_deadline", yr.positive, max(d.step_deadline, step_time))
    if deadline < step_time:
        raise m.ctx.fail(m.raw("step_deadline").line, m.key("step_deadline"), "must not be below step_time")
    return ControllerLimits(
        setup_time=m.opt("setup_time", yr.positive, d.setup_time),
        step_time=step_time,
        step_deadline=deadline,
        overage_bank=m.opt("overage_bank", yr.nonnegative, d.overage_bank),
        max_skips=skips,
        think_budget=m.opt("think_budget", yr.positive, d.think_budget),
        memory=int(m.opt("memory_mb", yr.positive, d.memory / 2**20) * 2**20),
        log_bytes=int(m.opt("log_kb", yr.positive, d.log_bytes / 1024) * 1024),
    )
