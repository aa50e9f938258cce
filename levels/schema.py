"""The level format as a JSON Schema, for editors (`# yaml-language-server: $schema=...`).

Made from the loader itself: the built-in levels are read with `levels.yaml_reader.SHAPES` set,
so every mapping records the keys it allows, the converter each key went through, which keys it
required and which held lists; each converter has its JSON Schema fragment here. A key no
built-in level exercises is still listed (the loader allows it), with any value. The loader
stays the authority: the schema checks what an editor can check (keys, types, signs), not the
geometry (`laserarena check` does). `python -m levels.schema [FOLDER]` writes it to
docs/schema/ (tests/test_level_schema.py holds the committed file to this).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

import yaml

import levels
from levels import _geometry, loader, schema_file
from levels import yaml_reader as yr

SCHEMA_FILE = "level.schema.json"
NUMBER: dict[str, Any] = {"type": "number"}
POINT = {"type": "array", "items": NUMBER, "minItems": 2, "maxItems": 2}
FRAGMENTS: dict[Callable[..., Any], dict[str, Any]] = {  # each converter's values
    yr.number: NUMBER,
    yr.length_signed: NUMBER,
    yr.positive: {"type": "number", "exclusiveMinimum": 0},
    yr.length: {"type": "number", "exclusiveMinimum": 0},
    yr.nonnegative: {"type": "number", "minimum": 0},
    yr.half_turn: {"type": "number", "minimum": 0, "maximum": 180},
    yr.integer: {"type": "integer"},
    yr.count: {"type": "integer", "minimum": 0},
    yr.text: {"type": "string", "minLength": 1},
    yr.flag: {"type": "boolean"},
    yr.point: POINT,
    yr.size: {**POINT, "items": {"type": "number", "exclusiveMinimum": 0}},
    _geometry.pose: {"type": "array", "items": NUMBER, "minItems": 3, "maxItems": 3},
    yr.rectangle: {"type": "array", "items": POINT, "minItems": 2, "maxItems": 2},
    yr.points: {"type": "array", "items": POINT, "minItems": 1},
}

BY_HAND: dict[tuple[str, str], dict[str, Any]] = {  # keys the loader reads without a converter
    ("task", "goal"): {"type": "array", "items": NUMBER, "minItems": 2, "maxItems": 3},  # a point, or a pose
    ("task.trials", "headings"): {"type": "array", "items": NUMBER, "minItems": 1},
}


def _fragment(conv: Callable[..., Any]) -> dict[str, Any]:
    """The values a converter accepts: its fragment, an enum for a `choice`, else any."""
    if conv in FRAGMENTS:
        return FRAGMENTS[conv]
    if conv.__qualname__ == "choice.<locals>.conv" and conv.__closure__:
        return {"type": "string", "enum": list(conv.__closure__[0].cell_contents)}
    return {}


def shapes() -> dict[str, yr.Shape]:
    """What reading the built-in levels recorded, by mapping path; then each key no level
    explored is tried, in each level, as an empty mapping and as a list of one, in a mapping
    whose other known keys hold sample values (each choice of a `kind` in turn), until
    nothing new is learnt: the loader records a key's converter before it checks the value,
    and a mapping's keys as it opens it. Which keys are required is learnt from the levels
    alone (a probe stops at its first error)."""
    found: dict[str, yr.Shape] = {}
    docs = [yaml.safe_load(levels.path(name).read_text(encoding="utf-8")) for name in levels.names()]
    token = yr.SHAPES.set(found)
    try:
        for doc in docs:
            _read(doc)
        # what is required comes from the levels as they are; a probe fails before it reads all
        counted = {path: (shape.reads, dict(shape.required)) for path, shape in found.items()}
        tried: set[tuple[str, str]] = set()
        while todo := [pk for pk in _unexplored(found) if pk not in tried and pk not in BY_HAND]:
            for path, key in todo:
                tried.add((path, key))
                for doc in docs:
                    probes: tuple[Any, ...] = ({}, [{}])
                    for probe in probes:
                        for variant in _probes(doc, path, key, probe, found[path]):
                            _read(variant)
    finally:
        yr.SHAPES.reset(token)
    for path, shape in found.items():
        shape.reads, shape.required = counted.get(path, (shape.reads, {}))
    return found


def _unexplored(found: dict[str, yr.Shape]) -> list[tuple[str, str]]:
    """(mapping path, key) of every key allowed with nothing known of its value."""
    out = []
    for path, shape in list(found.items()):
        for key in sorted(shape.keys):
            child = f"{path}.{key}" if path else key
            if key not in shape.converters and child not in found and f"{child}[]" not in found:
                out.append((path, key))
    return out


def _sample(fragment: dict[str, Any]) -> Any:
    """A value a fragment accepts (geometry aside)."""
    if "enum" in fragment:
        return fragment["enum"][0]
    kind = str(fragment.get("type"))
    if kind == "array":
        return [_sample(fragment["items"])] * fragment.get("minItems", 1)
    return {"number": 0.1, "integer": 1, "string": "x", "boolean": False}.get(kind, 0.1)


def _probes(doc: Any, path: str, key: str, value: Any, shape: yr.Shape) -> list[Any]:
    """Copies of the level document `doc` with `key` set to `value` in the mapping at `path`
    (made where missing; the first item of each list on the way), its other known keys given
    sample values where absent, once per choice of its first choice-valued key."""
    copy = json.loads(json.dumps(doc))
    here = copy
    for part in filter(None, path.split(".")):
        name, listed = part.removesuffix("[]"), part.endswith("[]")
        if not isinstance(here, dict):
            return []
        if listed:
            if not isinstance(here.get(name), list) or not here[name]:
                here[name] = [{}]
            here = here[name][0]
        else:
            here = here.setdefault(name, {})
    if not isinstance(here, dict):
        return []
    fragments = {k: _fragment(c[0]) for k, c in shape.converters.items()}
    for k, fragment in fragments.items():
        if k not in here and fragment:
            here[k] = _sample(fragment)
    here[key] = value
    choices = [k for k, f in fragments.items() if "enum" in f and k != key]
    if not choices:
        return [copy]
    out = []
    for option in fragments[choices[0]]["enum"]:
        here[choices[0]] = option
        out.append(json.loads(json.dumps(copy)))
    return out


def _read(doc: Any) -> None:
    """Read a level document, recording its shapes; a document the loader refuses still
    taught what was read before it failed."""
    try:
        loader.parse_level(yaml.safe_dump(doc).encode(), "probe.yaml")
    except loader.LevelError:
        pass


def _object(path: str, found: dict[str, yr.Shape]) -> dict[str, Any]:
    shape = found[path]
    properties = {}
    for key in sorted(shape.keys):
        child = f"{path}.{key}" if path else key
        if child in found:
            properties[key] = _object(child, found)
        elif f"{child}[]" in found:
            properties[key] = {"type": "array", "items": _object(f"{child}[]", found)}
        elif key in shape.converters:
            forms: list[dict[str, Any]] = []
            for conv in shape.converters[key]:  # a `choice` is a new function at each call: one form each
                if _fragment(conv) not in forms:
                    forms.append(_fragment(conv))
            properties[key] = forms[0] if len(forms) == 1 else {"anyOf": forms}
        elif (path, key) in BY_HAND:
            properties[key] = BY_HAND[path, key]
        else:
            properties[key] = {"type": "array"} if key in shape.lists else {}
    out: dict[str, Any] = {"type": "object", "properties": properties, "additionalProperties": False}
    required = shape.always_required()
    return {**out, "required": required} if required else out


def schema() -> dict[str, Any]:
    """The level format's JSON Schema (draft 2020-12)."""
    return {
        "$schema": schema_file.DRAFT,
        "title": "LaserArena level",
        "description": "A level file (docs/levels.md); `laserarena check FILE` checks what a schema cannot.",
        **_object("", shapes()),
    }


def schema_text() -> str:
    """The schema as the file in docs/schema/ holds it."""
    return schema_file.text(schema())


if __name__ == "__main__":
    raise SystemExit(schema_file.main(SCHEMA_FILE, schema()))
