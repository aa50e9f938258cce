"""The authority: it runs matches, keeps team code in sandboxes, scores, records and shows.

Rooms, each a subpackage whose `__init__` says what it holds and may import:
`match` (the lockstep loop, rules, tasks, scoring), `sandbox` (team specs and controller
processes), `records` (results, replays), `contest` (grading), `media` (video, viewer, plots,
maps), `gym` (RL environments, optional) and `cli` (the `laserarena` command). docs/architecture.md
draws the rooms and what flows between them.
"""

from referee.version import __version__

__all__ = ["__version__", "grade", "run_match", "tournament"]


def __getattr__(name: str) -> object:
    """`referee.run_match`, `grade` and `tournament`, imported when first used (importing
    `referee` loads nothing else)."""
    if name in ("grade", "run_match", "tournament"):
        from referee import api

        return getattr(api, name)
    raise AttributeError(f"module 'referee' has no attribute {name!r}")
