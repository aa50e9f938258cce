"""How a published JSON Schema is written to docs/schema/ (the result's, the level format's):
one text form, so a test can hold the committed file to the generated one byte for byte."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

DRAFT = "https://json-schema.org/draft/2020-12/schema"


def text(schema: dict[str, Any]) -> str:
    """The schema as the file in docs/schema/ holds it."""
    return json.dumps(schema, indent=2, sort_keys=True) + "\n"


def main(name: str, schema: dict[str, Any], argv: list[str] | None = None) -> int:
    """Write `schema` as `name` in docs/schema/ (or the folder the command line gives)."""
    args = sys.argv[1:] if argv is None else argv
    folder = Path(args[0]) if args else Path("docs") / "schema"
    folder.mkdir(parents=True, exist_ok=True)
    (folder / name).write_text(text(schema), encoding="utf-8")
    print(f"wrote {folder / name}")
    return 0
