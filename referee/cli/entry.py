"""The `laserarena` console script: the early interrupt handler before anything loads, then
the command (`referee.cli.main.main`), and the process's end with its code (referee.interrupts)."""

from __future__ import annotations

from referee import interrupts


def run() -> None:
    """Run the command named by `sys.argv` and end the process with its exit code."""
    interrupts.first()
    from referee.cli.main import main

    interrupts.finish(main())
