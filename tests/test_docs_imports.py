"""Every import the docs show works: each `from M import a, b` and `import M` of our packages in
any fenced block of the README and docs/ (fragments included, which no other test runs), and
each name the toolkit page's table says a module provides."""

from __future__ import annotations

import ast
import importlib
import re

import pytest
from test_docs_run import DOCS, FENCE, ROOT

OURS = ("robots", "referee", "arena", "levels")


def _imports() -> list[tuple[str, str, tuple[str, ...]]]:
    """(doc, module, names) for every import of one of our packages in a fenced block."""
    found = []
    for doc in DOCS:
        for block in FENCE.finditer(doc.read_text(encoding="utf-8")):
            for line in block["code"].splitlines():
                try:
                    node = ast.parse(line.strip()).body[0] if line.strip().startswith(("from ", "import ")) else None
                except (SyntaxError, IndexError):
                    continue
                if isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] in OURS:
                    found.append((doc.name, node.module, tuple(a.name for a in node.names if a.name != "*")))
                elif isinstance(node, ast.Import):
                    found += [(doc.name, a.name, ()) for a in node.names if a.name.split(".")[0] in OURS]
    return sorted(set(found))


@pytest.mark.parametrize("doc, module, names", _imports(), ids=lambda v: v if isinstance(v, str) else None)
def test_every_import_a_doc_shows_works(doc, module, names):
    imported = importlib.import_module(module)
    missing = [n for n in names if not hasattr(imported, n) and importlib.util.find_spec(f"{module}.{n}") is None]
    assert not missing, f"{doc}: {module} has no {', '.join(missing)}"


def _toolkit_rows() -> list[tuple[str, str]]:
    """(module, name) for each name a row of docs/toolkit.md's table names outside parentheses."""
    rows = []
    for line in (ROOT / "docs" / "toolkit.md").read_text(encoding="utf-8").splitlines():
        cells = line.split(" | ")
        if not line.startswith("| `") or len(cells) < 2:
            continue
        module = cells[0].strip("| `")
        text, depth, kept = cells[1], 0, []
        for c in text:  # the cell without what its parentheses explain
            depth += c == "("
            kept.append(c if depth == 0 else "")
            depth -= c == ")" and depth > 0
        rows += [(module, name) for name in re.findall(r"`([A-Za-z_]\w*)`", "".join(kept))]
    return rows


def test_the_toolkit_table_is_read():
    assert ("angles", "wrap") in _toolkit_rows() and ("steering", "HeadingProbe") in _toolkit_rows()


@pytest.mark.parametrize("module, name", _toolkit_rows())
def test_every_name_the_toolkit_table_gives_is_in_its_module(module, name):
    # in the module, or a method of a class its row names (`BearingEKF`'s `hit`)
    found = importlib.import_module(f"robots.toolkit.{module}")
    classes = [
        getattr(found, n) for m, n in _toolkit_rows() if m == module and isinstance(getattr(found, n, None), type)
    ]
    assert hasattr(found, name) or any(hasattr(c, name) for c in classes), f"robots.toolkit.{module} has no {name}"
