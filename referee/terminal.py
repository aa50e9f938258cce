"""Text from teams (names, fault messages) made safe to print on a terminal or in a table."""

from __future__ import annotations


def safe(text: object, limit: int = 200) -> str:
    """`text` on one line with every control or invisible character (ANSI escapes, newlines,
    bidirectional overrides) shown as an escape such as `\\x1b`, cut to `limit` characters."""
    s = str(text)
    out = "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in s[:limit])
    return out + ("..." if len(s) > limit else "")
