"""The level format's JSON Schema (docs/schema/level.schema.json), made from the loader's own
reading: committed as generated, every built-in level valid against it, and what the loader
refuses for a key's type or name refused by the schema too (an editor shows it as you type)."""

from __future__ import annotations

import json
from pathlib import Path

import jsonschema
import pytest
import yaml

import levels
from levels.loader import LevelError, parse_level
from levels.schema import BY_HAND, SCHEMA_FILE, _unexplored, schema_text, shapes

SCHEMA = Path(__file__).resolve().parent.parent / "docs" / "schema" / SCHEMA_FILE


@pytest.fixture(scope="module")
def validator():
    return jsonschema.Draft202012Validator(json.loads(SCHEMA.read_text()))


def test_the_committed_schema_is_the_generated_one():
    assert SCHEMA.read_text() == schema_text(), "run: python -m levels.schema docs/schema"


def test_a_key_of_several_forms_lists_each_once():
    def forms(node):
        if isinstance(node, dict):
            if "anyOf" in node:
                texts = [json.dumps(f, sort_keys=True) for f in node["anyOf"]]
                assert len(set(texts)) == len(texts) > 1, texts
            for value in node.values():
                forms(value)

    forms(json.loads(SCHEMA.read_text()))


def test_every_key_the_loader_allows_has_its_values_known():
    # a key read by hand, without a converter, must be described in BY_HAND
    assert set(_unexplored(shapes())) <= set(BY_HAND)


@pytest.mark.parametrize("name", levels.names())
def test_every_built_in_level_is_valid(validator, name):
    validator.validate(yaml.safe_load(levels.path(name).read_text()))


@pytest.mark.parametrize(
    "edit",
    [
        lambda d: d.update(time_limit="long"),  # a number
        lambda d: d.update(colour="red"),  # no such key
        lambda d: d["robots"][0].update(model="tank"),  # not a model
        lambda d: d.setdefault("limits", {}).update(memory_mb=-5),  # positive
        lambda d: d.setdefault("limits", {}).update(max_skip=3),  # misspelt
        lambda d: d["field"].update(size=[3.0]),  # two numbers
        lambda d: d["robots"][0].setdefault("drive", {}).update(gain_sd="small"),
        lambda d: d.pop("name"),  # required
    ],
)
def test_what_the_loader_refuses_the_schema_refuses(validator, edit):
    doc = yaml.safe_load(levels.path("bac-line").read_text())
    edit(doc)
    with pytest.raises(LevelError):
        parse_level(yaml.safe_dump(doc).encode(), "edited.yaml")
    assert list(validator.iter_errors(doc)), "the schema let it pass"
