"""The terminal's side of every command: text from teams (names, fault messages) made safe to
print, to open as a spreadsheet (CSV) or to render as Markdown, and the one progress bar every
long command shows."""

from __future__ import annotations

import csv
import io
import re
import sys
from collections.abc import Iterable, Sequence

FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")  # what a spreadsheet may read as a formula
NUMBER = re.compile(r"[+-]?[0-9]+(\.[0-9]+)?([eE][+-]?[0-9]+)?")  # a number written as text: no formula


def safe(text: object, limit: int = 200) -> str:
    """`text` on one line with every control or invisible character (ANSI escapes, newlines,
    bidirectional overrides) shown as an escape such as `\\x1b`, cut to `limit` characters."""
    s = str(text)
    out = "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in s[:limit])
    return out + ("..." if len(s) > limit else "")


def csv_cell(value: object) -> object:
    """`value` as a CSV cell no spreadsheet runs: text starting with `=`, `+`, `-`, `@`, a tab
    or a carriage return gets a leading `'` (OWASP's rule), then its control characters are
    escaped as `safe` shows them (a lone CR would otherwise end the row); numbers, and text
    that is a plain number (a rating formatted as `-6.2844`), stay numbers."""
    if not isinstance(value, str) or NUMBER.fullmatch(value):
        return value
    return safe("'" + value if value.startswith(FORMULA_STARTS) else value, len(value) + 1)


def csv_text(header: Sequence[str], rows: Iterable[Sequence[object]]) -> str:
    """A CSV table (header, then rows), every cell through `csv_cell`."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow([csv_cell(h) for h in header])
    w.writerows([csv_cell(v) for v in row] for row in rows)
    return buf.getvalue()


MARKDOWN_ENTITIES = {"&": "&amp;", "<": "&lt;", ">": "&gt;"}  # no tag, no entity of the text's own
MARKDOWN_PUNCTUATION = frozenset("\\`*_[]|~")  # emphasis, code, links and images, table cells, strikeout


def markdown_text(value: object, limit: int = 200) -> str:
    """`value` as Markdown that renders as the text itself, in a table cell or a paragraph:
    control characters shown as `safe` shows them (one line: a newline would end the row);
    `&`, `<` and `>` as HTML entities (no raw HTML, no autolink); backslash, backtick, `*`,
    `_`, `[`, `]`, `|` and `~` escaped with a backslash (no emphasis, code, link, image or
    extra cell). Every Markdown file the product writes puts team, level and file text
    through it."""
    return "".join(
        MARKDOWN_ENTITIES.get(c) or ("\\" + c if c in MARKDOWN_PUNCTUATION else c) for c in safe(value, limit)
    )


class Progress:
    """A progress bar on stderr (tqdm): items done, rate and ETA, the item just finished. It
    shows only on a terminal and vanishes when done: a log or a pipe gets no bar lines."""

    def __init__(self, total: int, unit: str, quiet: bool, already: int = 0):
        from tqdm import tqdm

        self.bar = tqdm(
            total=total,
            initial=already,
            unit=unit,
            leave=False,
            file=sys.stderr,
            disable=quiet or not sys.stderr.isatty(),
            dynamic_ncols=True,
        )

    def tick(self, label: str = "") -> None:
        if label:
            self.bar.set_postfix_str(safe(label, 40), refresh=False)
        self.bar.update(1)

    def close(self) -> None:
        """Take the bar off the terminal."""
        self.bar.close()
