"""A kit for reading a YAML file into typed values, every problem one line naming the file, the
line and the key: safe composing with each value's line, mappings that refuse unknown keys, and
converters of numbers, text, lists, points and sizes (in the file's length unit).

It knows nothing of what the file describes (levels/loader.py reads levels with it). While
`SHAPES` is set, every mapping read records what it allowed and how each key was converted:
levels/schema.py makes the published JSON Schema from that.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Callable
from contextvars import ContextVar
from dataclasses import dataclass
from typing import Any

import yaml

from levels.errors import LaserArenaError

# libyaml's parser where PyYAML's wheel has it (the same events and marks, several times faster
# than the pure-Python one a level file would otherwise take a noticeable part of a run to read)
SAFE_LOADER: type = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


class ReadError(LaserArenaError):
    """A problem in a file being read, printed as one line: `file:line: key: message`."""

    def __init__(self, source: str, line: int | None, key: str, message: str):
        self.source, self.line, self.key, self.message = source, line, key, message
        super().__init__(str(self))

    def __str__(self) -> str:
        where = f"{self.source}:{self.line}" if self.line else self.source
        return f"{where}: {self.key}: {self.message}" if self.key else f"{where}: {self.message}"

    def __reduce__(self) -> tuple[type[ReadError], tuple[str, int | None, str, str]]:
        """Pickled whole, so that one raised in a worker process reaches its caller as itself."""
        return (ReadError, (self.source, self.line, self.key, self.message))


@dataclass
class Node:
    """A YAML value with the 1-based line it starts on."""

    value: Any
    line: int


@dataclass
class MapValue:
    """A mapping's values by key, and the line each key stands on."""

    items: dict[str, Node]
    keylines: dict[str, int]


class Context:
    """The file being read: its name in errors, its length unit (metres per unit, set once the
    file has said which) and the `ReadError` class its problems are raised as."""

    def __init__(self, source: str, error: type[ReadError] = ReadError):
        self.source = source
        self.scale = 1.0
        self.error = error

    def fail(self, line: int | None, key: str, message: str) -> ReadError:
        return self.error(self.source, line, key, message)


Converter = Callable[[Context, Node, str], Any]  # (context, node, dotted key) -> value


def compose(ctx: Context, data: bytes) -> tuple[str, Node]:
    """The file's text and its root value, each value with its line. Only PyYAML's safe
    constructors run; bound the event stream first (aliases, depth), as composing trusts it."""
    try:
        content = data.decode("utf-8")
        try:
            root = yaml.compose(content, Loader=SAFE_LOADER)
        except yaml.YAMLError:  # said as PyYAML's own parser says it, with or without libyaml
            root = yaml.compose(content, Loader=yaml.SafeLoader)
    except UnicodeDecodeError as e:
        raise ctx.fail(None, "(file)", f"not UTF-8 text ({e.reason})") from None
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None) or getattr(e, "context_mark", None)
        reason = getattr(e, "problem", None) or str(e).splitlines()[0]
        raise ctx.fail(mark.line + 1 if mark else None, "(yaml)", f"malformed YAML: {reason}") from None
    if root is None:
        raise ctx.fail(1, "(top)", "the file is empty")
    return content, locate(ctx, root)


def locate(ctx: Context, node: yaml.Node) -> Node:
    """A composed YAML node as `Node`s: mappings keyed by text, each key once."""
    line = node.start_mark.line + 1
    if isinstance(node, yaml.MappingNode):
        out: dict[str, Node] = {}
        keylines: dict[str, int] = {}
        for knode, vnode in node.value:
            key = locate(ctx, knode).value
            if not isinstance(key, str):
                raise ctx.fail(knode.start_mark.line + 1, str(key), "keys must be text")
            if key in out:
                raise ctx.fail(knode.start_mark.line + 1, key, "duplicate key")
            out[key] = locate(ctx, vnode)
            keylines[key] = knode.start_mark.line + 1
        return Node(MapValue(out, keylines), line)
    if isinstance(node, yaml.SequenceNode):
        return Node([locate(ctx, n) for n in node.value], line)
    return Node(yaml.constructor.SafeConstructor().construct_object(node), line)


def line_of(root: Node, key: str) -> int | None:
    """The file line of a dotted key such as `robots[0].start` (the line of its deepest part
    in the file)."""
    node: Node | None = root
    line = root.line
    for name, index in re.findall(r"([^.\[\]]+)|\[(\d+)\]", key):
        if node is None:
            break
        if name and isinstance(node.value, MapValue) and name in node.value.items:
            line, node = node.value.keylines[name], node.value.items[name]
        elif index and isinstance(node.value, list) and int(index) < len(node.value):
            node = node.value[int(index)]
            line = node.line
        else:
            break
    return line


@dataclass
class Shape:
    """What was read at one mapping of a file (`levels/schema.py` makes the published JSON
    Schema from these): its allowed keys, each key's converters, how many times the mapping was
    read and each key required, and the keys that held lists."""

    keys: set[str] = dataclasses.field(default_factory=set)
    converters: dict[str, list[Callable[..., Any]]] = dataclasses.field(default_factory=dict)  # in first use order
    reads: int = 0
    required: dict[str, int] = dataclasses.field(default_factory=dict)
    lists: set[str] = dataclasses.field(default_factory=set)

    def note(self, key: str, conv: Callable[..., Any]) -> None:
        """`key` was read through `conv` (a key may take several forms: a number or a point)."""
        known = self.converters.setdefault(key, [])
        if conv not in known:
            known.append(conv)

    def always_required(self) -> list[str]:
        """The keys every reading of this mapping required (none that some reading let go)."""
        return sorted(k for k, n in self.required.items() if n == self.reads)


# while set (by the schema's maker), each mapping read records its Shape under its path, list
# positions written `[]`: the schema comes from the very calls that read the files
SHAPES: ContextVar[dict[str, Shape] | None] = ContextVar("SHAPES", default=None)


class Map:
    """A YAML mapping being read: typed getters, and unknown keys rejected up front."""

    def __init__(self, ctx: Context, node: Node, path: str, allowed: tuple[str, ...]):
        if not isinstance(node.value, MapValue):
            raise ctx.fail(node.line, path or "(top)", f"expected a mapping, got {kind(node.value)}")
        self.ctx, self.node, self.path = ctx, node, path
        shapes = SHAPES.get()
        self.shape = None if shapes is None else shapes.setdefault(re.sub(r"\[\d+\]", "[]", path), Shape())
        if self.shape is not None:
            self.shape.keys.update(allowed)
            self.shape.reads += 1
        for key in node.value.items:
            if key not in allowed:
                raise ctx.fail(
                    node.value.keylines[key], self.key(key), f"unknown key (expected one of: {', '.join(allowed)})"
                )

    def key(self, key: str) -> str:
        """The dotted key of one of this mapping's keys, as errors name it."""
        return f"{self.path}.{key}" if self.path else key

    def has(self, key: str) -> bool:
        return key in self.node.value.items

    def raw(self, key: str) -> Node:
        """A key's node as it stands; a missing key is an error."""
        if not self.has(key):
            raise self.ctx.fail(self.node.line, self.key(key), "missing required key")
        return self.node.value.items[key]

    def req(self, key: str, conv: Converter) -> Any:
        """A required key's value through `conv`."""
        if self.shape is not None:
            self.shape.note(key, conv)
            self.shape.required[key] = self.shape.required.get(key, 0) + 1
        return conv(self.ctx, self.raw(key), self.key(key))

    def opt(self, key: str, conv: Converter, default: Any) -> Any:
        """An optional key's value through `conv`, else `default`."""
        if self.shape is not None:
            self.shape.note(key, conv)
        return conv(self.ctx, self.raw(key), self.key(key)) if self.has(key) else default

    def sub(self, key: str, allowed: tuple[str, ...]) -> Map:
        """A key that holds a mapping, read with its own allowed keys."""
        return Map(self.ctx, self.raw(key), self.key(key), allowed)

    def seq(self, key: str) -> list[tuple[Node, str]]:
        """A key that holds a list: each item's node and dotted key."""
        if self.shape is not None:
            self.shape.lists.add(key)
        node = self.raw(key)
        if not isinstance(node.value, list):
            raise self.ctx.fail(node.line, self.key(key), f"expected a list, got {kind(node.value)}")
        return [(n, f"{self.key(key)}[{i}]") for i, n in enumerate(node.value)]


def kind(value: Any) -> str:
    """What a value is, as an error names it: `a mapping`, `nothing`, `str 'four'`."""
    if isinstance(value, MapValue):
        return "a mapping"
    if isinstance(value, list):
        return "a list"
    if value is None:
        return "nothing"
    return f"{type(value).__name__} {value!r}"


# ---- converters: (ctx, node, key) -> value ---------------------------------------------------


def number(ctx: Context, node: Node, key: str) -> float:
    v = node.value
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ctx.fail(node.line, key, f"expected a number, got {kind(v)}")
    if not math.isfinite(v):
        raise ctx.fail(node.line, key, "must be finite")
    return float(v)


def positive(ctx: Context, node: Node, key: str) -> float:
    v = number(ctx, node, key)
    if v <= 0:
        raise ctx.fail(node.line, key, f"must be positive, got {v:g}")
    return v


def nonnegative(ctx: Context, node: Node, key: str) -> float:
    v = number(ctx, node, key)
    if v < 0:
        raise ctx.fail(node.line, key, f"must not be negative, got {v:g}")
    return v


def integer(ctx: Context, node: Node, key: str) -> int:
    v = node.value
    if isinstance(v, bool) or not isinstance(v, int):
        raise ctx.fail(node.line, key, f"expected a whole number, got {kind(v)}")
    return v


def count(ctx: Context, node: Node, key: str) -> int:
    v = integer(ctx, node, key)
    if v < 0:
        raise ctx.fail(node.line, key, f"must not be negative, got {v}")
    return v


def text(ctx: Context, node: Node, key: str) -> str:
    if not isinstance(node.value, str) or not node.value.strip():
        raise ctx.fail(node.line, key, f"expected text, got {kind(node.value)}")
    return node.value


def flag(ctx: Context, node: Node, key: str) -> bool:
    if not isinstance(node.value, bool):
        raise ctx.fail(node.line, key, f"expected true or false, got {kind(node.value)}")
    return node.value


def scalar_id(ctx: Context, node: Node, key: str) -> str:
    """A name or a whole number, as text."""
    if isinstance(node.value, bool) or not isinstance(node.value, (str, int)):
        raise ctx.fail(node.line, key, f"expected a name or number, got {kind(node.value)}")
    return str(node.value)


def choice(*options: str) -> Converter:
    """A converter of text that must be one of `options` (a new function at every call)."""

    def conv(ctx: Context, node: Node, key: str) -> str:
        v = text(ctx, node, key)
        if v not in options:
            raise ctx.fail(node.line, key, f"must be one of {', '.join(options)}, got {v!r}")
        return v

    return conv


def numbers(ctx: Context, node: Node, key: str, n: int, what: str) -> list[float]:
    """A list of exactly `n` numbers; `what` names it in the error (`a point [x, y]`)."""
    if not isinstance(node.value, list) or len(node.value) != n:
        raise ctx.fail(node.line, key, f"expected {what}, got {kind(node.value)}")
    return [number(ctx, item, key) for item in node.value]


def length(ctx: Context, node: Node, key: str) -> float:
    return positive(ctx, node, key) * ctx.scale


def length_signed(ctx: Context, node: Node, key: str) -> float:
    return number(ctx, node, key) * ctx.scale


def point(ctx: Context, node: Node, key: str) -> tuple[float, float]:
    x, y = numbers(ctx, node, key, 2, "a point [x, y]")
    return (x * ctx.scale, y * ctx.scale)


def size(ctx: Context, node: Node, key: str) -> tuple[float, float]:
    w, h = numbers(ctx, node, key, 2, "a size [width, height]")
    if w <= 0 or h <= 0:
        raise ctx.fail(node.line, key, f"sizes must be positive, got [{w:g}, {h:g}]")
    return (w * ctx.scale, h * ctx.scale)


def rectangle(ctx: Context, node: Node, key: str) -> tuple[float, float, float, float]:
    """A rectangle [[xmin, ymin], [xmax, ymax]] as (xmin, ymin, xmax, ymax)."""
    if not isinstance(node.value, list) or len(node.value) != 2:
        raise ctx.fail(node.line, key, f"expected a rectangle [[xmin, ymin], [xmax, ymax]], got {kind(node.value)}")
    (x0, y0), (x1, y1) = (point(ctx, corner, key) for corner in node.value)
    if not (x0 < x1 and y0 < y1):
        raise ctx.fail(node.line, key, "the first corner must lie below and left of the second")
    return (x0, y0, x1, y1)


def half_turn(ctx: Context, node: Node, key: str) -> float:
    """An angular spread in degrees, 0..180 (180: any heading), in radians."""
    v = nonnegative(ctx, node, key)
    if v > 180:
        raise ctx.fail(node.line, key, f"must be at most 180 degrees (any heading), got {v:g}")
    return math.pi if v == 180 else math.radians(v)


def points(ctx: Context, node: Node, key: str) -> tuple[tuple[float, float], ...]:
    if not isinstance(node.value, list) or not node.value:
        raise ctx.fail(node.line, key, f"expected a list of points, got {kind(node.value)}")
    return tuple(point(ctx, item, f"{key}[{i}]") for i, item in enumerate(node.value))
