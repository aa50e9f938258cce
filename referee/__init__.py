"""The authority: it runs matches, keeps team code in sandboxes, scores, records and shows.

- `api`: the Python API (`referee.run_match`, `grade`, `tournament`, loaded on first use);
- rooms, each a subpackage whose `__init__` says what it holds: `match`, `sandbox`,
  `records`, `contest`, `media`, `gym`, `cli`;
- at the bottom: `errors`, `interrupts`, `terminal`, `threads`, `version`.

Imports: `levels`, `arena`, `robots` (docs/architecture.md; the contracts in pyproject.toml).
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
