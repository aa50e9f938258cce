"""Replay writes put off until the controllers compute: a control period's frames and events
are written while the controllers think about the next one, in the order they were known, so
the replay's bytes are those written at once (docs/decisions/0028)."""

from __future__ import annotations

from collections.abc import Callable


class Deferral:
    """Writes held (`pending`) once `hold()` is called, written by `flush()`; before that
    (a step-wise driver that shows the replay as it grows) each is written at once."""

    def __init__(self) -> None:
        self.pending: list[Callable[[], None]] | None = None

    def hold(self) -> None:
        """From now on, put writes off until `flush()`."""
        self.pending = []

    def put(self, write: Callable[[], None]) -> None:
        """Write now, or once the controllers are computing."""
        if self.pending is None:
            write()
        else:
            self.pending.append(write)

    def flush(self) -> None:
        """Write, in order, what was put off."""
        if self.pending:
            for write in self.pending:
                write()
            self.pending.clear()
