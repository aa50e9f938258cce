"""A controller's fault as the result and the replay record it. The sandbox reports a `Fault`
and never imports records; the match, which imports both, makes the record, its message made
terminal-safe here, once, whatever sent it (a team's own exception text, a protocol error
naming a team's field)."""

from __future__ import annotations

from referee.records.results import FaultRecord
from referee.sandbox.fault import Fault
from referee.terminal import safe

MESSAGE = 500  # characters of a fault's message kept


def fault_record(fault: Fault) -> FaultRecord:
    """The record of `fault`: its traceback only when there is one."""
    message = safe(fault.message, MESSAGE)
    if fault.traceback is None:
        return FaultRecord(tick=fault.tick, time=fault.time, kind=fault.kind.value, message=message)
    return FaultRecord(
        tick=fault.tick, time=fault.time, kind=fault.kind.value, message=message, traceback=fault.traceback
    )
