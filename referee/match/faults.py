"""A controller's fault as the result and the replay record it. The sandbox reports a `Fault`
and never imports records; the match, which imports both, makes the record."""

from __future__ import annotations

from referee.records.results import FaultRecord
from referee.sandbox.fault import Fault


def fault_record(fault: Fault) -> FaultRecord:
    """The record of `fault`: its traceback only when there is one."""
    if fault.traceback is None:
        return FaultRecord(tick=fault.tick, time=fault.time, kind=fault.kind.value, message=fault.message)
    return FaultRecord(
        tick=fault.tick, time=fault.time, kind=fault.kind.value, message=fault.message, traceback=fault.traceback
    )
