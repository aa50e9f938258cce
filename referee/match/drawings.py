"""What a team's debug drawings and warnings may cost a match: drawings are kept up to a byte
budget per tick and per match (counted as the replay writes them), and whatever is set aside
is one warning per kind (first tick, count, first example), so neither the replay nor the
result grows with what a team sends (docs/rules.md, "Debug drawings")."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

from referee.records.canonical import dumps
from referee.records.results import WarningRecord
from referee.terminal import safe
from robots._host.protocol import drawing_problem

TICK_BYTES = 16 << 10  # a robot's `dbg` record in one tick, at most (bytes of the replay line)
MATCH_BYTES = 2 << 20  # a robot's `dbg` records over a match, at most
RECORD_BYTES = 64  # a `dbg` record's bytes besides its drawings, at most: {"d":[],"k":"dbg","r":..,"t":..}
MESSAGE = 200  # characters of a warning's example, at most


class Warnings:
    """One robot's warnings, one per kind however many times it happens: the first tick, the
    count, and the first example's text (one line, cut short)."""

    def __init__(self) -> None:
        self.kinds: dict[str, tuple[int, int, str]] = {}

    def add(self, kind: str, tick: int, message: str) -> None:
        seen = self.kinds.get(kind)
        self.kinds[kind] = (tick, 1, safe(message, MESSAGE)) if seen is None else (seen[0], seen[1] + 1, seen[2])

    def records(self) -> list[WarningRecord]:
        """The warnings as the result holds them, in the order their kinds first happened."""
        return [WarningRecord(kind=k, tick=t, count=n, message=m) for k, (t, n, m) in self.kinds.items()]


class DrawingBudget:
    """Which of one robot's drawings reach the replay: the drawable ones, in order, while the
    tick's record stays within TICK_BYTES and the match's within MATCH_BYTES."""

    def __init__(self, warnings: Warnings) -> None:
        self.warnings = warnings
        self.left = MATCH_BYTES

    def keep(self, tick: int, debug: Sequence[object]) -> list[dict]:
        """The drawings of `debug` to record (as the replay's plain data); each other one is
        counted under its warning: `drawing_dropped` (cannot be drawn), `drawing_over_tick`,
        `drawing_over_match` (past a budget: it and every later drawable one of the tick)."""
        kept: list[dict] = []
        size, over = RECORD_BYTES, ""
        for g in debug:
            problem = drawing_problem(g)
            if problem is not None:
                self.warnings.add("drawing_dropped", tick, problem)
                continue
            if not over:
                plain = dataclasses.asdict(g)  # type: ignore[call-overload]  # a Drawing: drawing_problem said so
                grown = size + len(dumps(plain, indent=None)) + 1  # its text and a comma
                over = "tick" if grown > TICK_BYTES else "match" if grown > self.left else ""
                if not over:
                    kept.append(plain)
                    size = grown
            if over:
                budget = TICK_BYTES if over == "tick" else MATCH_BYTES
                self.warnings.add(f"drawing_over_{over}", tick, f"drawings past the {budget} bytes a {over} may have")
        if kept:
            self.left -= size
        return kept
