"""The result's published JSON Schema, generated from the typed records (`results`):
`python -m referee.records.result_schema [FOLDER]` writes it to docs/schema/ (or FOLDER), in
the one text form the level format's schema has too (`levels.schema_file`), so a test can
hold the committed file to the generated one byte for byte."""

from __future__ import annotations

import inspect
from typing import Any

import msgspec

from levels import schema_file
from referee.records.results import RESULT_FORMAT, RESULT_VERSION, MatchResult

SCHEMA_FILE = f"result-v{RESULT_VERSION}.schema.json"


def schema() -> dict[str, Any]:
    """The JSON Schema of a result, generated from the records."""
    generated: dict[str, Any] = _cleaned(msgspec.json.schema(MatchResult))
    return {
        "$schema": schema_file.DRAFT,
        "title": f"{RESULT_FORMAT} version {RESULT_VERSION}",
        **generated,
    }


def _cleaned(node: Any) -> Any:
    """`node` with every description as `inspect.cleandoc` gives it: msgspec takes them from
    the records' docstrings, and its releases differ in whether they clean their indentation."""
    if isinstance(node, dict):
        return {
            k: inspect.cleandoc(v) if k == "description" and isinstance(v, str) else _cleaned(v)
            for k, v in node.items()
        }
    if isinstance(node, list):
        return [_cleaned(v) for v in node]
    return node


def schema_text() -> str:
    """The schema as the file in docs/schema/ holds it."""
    return schema_file.text(schema())


if __name__ == "__main__":
    raise SystemExit(schema_file.main(SCHEMA_FILE, schema()))
