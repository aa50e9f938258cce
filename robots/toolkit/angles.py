"""From event times to angles: revolution bookkeeping, plausibility checks, BeAMS midpoints.

A revolution is the time between two index clicks (Vannoy, Simi) or between two hits of the
same beacon (Bac, where the robot has no index). Within it the laser turns 2 pi at a nearly
constant rate, so an event's angle is 2 pi times the fraction of the revolution elapsed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from robots.api import SensorEvent

TWO_PI = 2 * math.pi


def wrap(angle: float) -> float:
    """An angle wrapped to (-pi, pi] (-pi reads as pi, so equal headings read alike)."""
    r = math.remainder(angle, TWO_PI)
    return math.pi if r == -math.pi else r


@dataclass(frozen=True)
class Revolution:
    """One laser turn: its start and end times and its hits as (angle, beacon id or None).
    Angles are counter-clockwise from the revolution's start, [0, 2 pi)."""

    start: float
    end: float
    hits: tuple[tuple[float, str | None], ...]

    @property
    def period(self) -> float:
        return self.end - self.start


def angle_in(start: float, end: float, t: float) -> float:
    """Angle swept by a uniformly turning laser from `start` to `t`, if a full turn takes end - start."""
    return TWO_PI * (t - start) / (end - start)


def midpoint(entry: float, exit_: float) -> float:
    """BeAMS-style: a beacon seen from `entry` to `exit_` is at the middle of the two times,
    which cancels the beam's width and the detector's threshold."""
    return (entry + exit_) / 2


def plausible(rev: Revolution, nominal: float, tolerance: float, max_hits: int, min_hits: int = 3) -> bool:
    """The seeds' checks: a period within `tolerance` of the nominal one (Vannoy: "a reading
    not considered close should generate an error"; Bac: the revolution time against a set
    value), and a believable number of hits."""
    return abs(rev.period - nominal) <= tolerance and min_hits <= len(rev.hits) <= max_hits


class IndexRevolutions:
    """Revolutions between consecutive index clicks (the laser passing straight ahead): hit
    angles are then counter-clockwise from straight ahead. `sign` is the spin direction (+1
    counter-clockwise); where the hardware latches an angle itself (an encoder, a stepped
    head), that reading is used instead of the time fraction."""

    def __init__(self, sign: float = 1.0) -> None:
        self.sign = sign
        self.last_click: float | None = None
        self.pending: list[SensorEvent] = []

    def feed(self, events: tuple[SensorEvent, ...] | list[SensorEvent]) -> list[Revolution]:
        """Take events in time order; return the revolutions they complete."""
        done = []
        for e in events:
            if e.kind == "index":
                if self.last_click is not None:
                    hits = tuple(
                        (
                            h.angle
                            if h.angle is not None
                            else (self.sign * angle_in(self.last_click, e.time, h.time)) % TWO_PI,
                            h.beacon,
                        )
                        for h in self.pending
                    )
                    done.append(Revolution(self.last_click, e.time, hits))
                self.last_click, self.pending = e.time, []
            elif e.kind == "hit" and self.last_click is not None:
                self.pending.append(e)
        return done


class BeaconRevolutions:
    """Revolutions from repeated hits of the same reference beacon, for labelled hits and no
    index (Bac): each time `reference` is hit again a turn is complete. Angles are then measured
    from the reference beacon."""

    def __init__(self, reference: str) -> None:
        self.reference = reference
        self.last: float | None = None
        self.pending: list[SensorEvent] = []

    def feed(self, events: tuple[SensorEvent, ...] | list[SensorEvent]) -> list[Revolution]:
        done = []
        for e in events:
            if e.kind != "hit":
                continue
            if e.beacon == self.reference:
                if self.last is not None:
                    hits = ((0.0, self.reference),) + tuple(
                        (angle_in(self.last, e.time, h.time), h.beacon) for h in self.pending
                    )
                    done.append(Revolution(self.last, e.time, hits))
                self.last, self.pending = e.time, []
            elif self.last is not None:
                self.pending.append(e)
        return done


class TurnWindow:
    """The returns of the last turn of a standing robot, at every event: a fix need not wait for
    a turn that begins at an index click. Each hit's angle, counter-clockwise from straight
    ahead, is the head's own latched reading, else the time from the last index click in the
    window times the laser's rate (measured between the last two clicks, else nominal). The
    window is a turn and `tolerance` of a turn long, and a hit with another a turn (within
    `tolerance`) after it is that beacon seen again: it is dropped, so a `whole` window (the
    robot stood through all of it) holds every beacon once, and any stray return besides.
    Vannoy checks his laser's rate at each click ("The time from the first to second click was
    four seconds. This verifies that our laser is tracking at the correct speed. A reading not
    considered close should generate an error"): while the last two clicks were further apart
    than `tolerance` of a turn from the nominal period, timed angles are refused."""

    def __init__(self, sign: float, period: float, tolerance: float = 0.05) -> None:
        self.sign, self.period, self.tolerance = sign, period, tolerance * period
        self.span = period + self.tolerance
        self.rate = TWO_PI / period
        self.tracking = True  # the last two clicks were a plausible turn apart
        self.last_click: float | None = None
        self.since = -math.inf  # the robot stands from then on
        self.events: list[SensorEvent] = []  # those of the window, repeats dropped

    def restart(self, since: float) -> None:
        """Forget the returns before `since`: the robot moves until then."""
        self.since = since
        self.events = []

    @property
    def whole(self) -> bool:
        """Whether the robot stood through the whole window: it holds a whole turn."""
        return bool(self.events) and self.events[-1].time - self.since >= self.span

    def feed(self, e: SensorEvent) -> Revolution | None:
        """Take the next event; return the turn that ends with it if every hit in it has an
        angle, else None. `Revolution.hits` are in time order, so the last is `e` if a hit."""
        if e.kind == "index":
            if self.last_click is not None:
                interval = e.time - self.last_click
                self.tracking = abs(interval - self.period) <= self.tolerance
                if self.tracking:
                    self.rate = TWO_PI / interval
            self.last_click = e.time
        if e.kind not in ("index", "hit") or e.time < self.since:
            return None
        window = [old for old in self.events if old.time > e.time - self.span] + [e]
        self.events = [
            old
            for old in window
            if not any(
                new.kind == old.kind
                and new.beacon == old.beacon  # a labelled return is repeated by its own beacon only
                and abs(new.time - old.time - self.period) <= self.tolerance
                for new in window
            )
        ]
        clicks = [old.time for old in self.events if old.kind == "index"]
        hits = [old for old in self.events if old.kind == "hit"]
        if any(h.angle is None for h in hits) and (not clicks or not self.tracking):
            return None
        angles = tuple(
            (
                h.angle if h.angle is not None else (self.sign * self.rate * (h.time - clicks[-1])) % TWO_PI,
                h.beacon,
            )
            for h in hits
        )
        return Revolution(self.events[0].time, e.time, angles)
