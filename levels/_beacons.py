"""A level file's `beacons`: their hardware kind and its parameters (each with its quantity and
default), where each beacon stands and faces, and how the beacons share the light
(docs/levels.md; every parameter with its source in docs/sensors.md)."""

from __future__ import annotations

import math
from types import MappingProxyType

from levels import yaml_reader as yr
from levels._geometry import inside
from levels.model import Beacon, Beacons, Field

BEACONS_KEYS = ("kind", "radius", "params", "items", "crosstalk")
BEACON_KEYS = ("id", "at", "facing", "gain")

# Per-kind hardware parameters: name -> (quantity, default in SI units).
# Quantities: "length" and "speed" are converted from the file's units, "angle" from degrees.
COMMON_PARAMS: dict[str, tuple[str, float]] = {
    "quantization": ("count", 0),  # binary angle steps per turn; 0 = none
    "timing_noise": ("number", 0.0),  # s, std of the event clock
    "wobble": ("number", 0.0),  # relative std of the laser spin rate
    "wobble_time": ("number", 1.0),  # s, correlation time of the wobble
    "placement_error": ("length", 0.0),  # how far a beacon may really stand from its map position
    "spin_coupling": ("number", 0.0),  # steady loss of relative spin rate per unit body yaw rate
    "spin_time": ("number", 0.0),  # s, time the laser motor takes to recover from a turn; 0 = it never lags
}
# A finite beam sweeping a finite detector (docs/sensors.md, "Optics").
OPTICS_PARAMS: dict[str, tuple[str, float]] = {
    "beam_diameter": ("length", 0.0),
    "beam_divergence": ("angle", 0.0),  # full angle
    "aperture": ("length", 0.0),  # detector width across the beam
    "trigger_fraction": ("number", 0.0),  # fraction of the beam's power that fires the comparator
    "rise_time": ("number", 0.0),  # s the light must stay above the threshold
    "acceptance": ("angle", math.inf),  # incidence at which the detector's response halves
    "light_noise": ("number", 0.0),  # std of ln(light reaching the detector), sweep to sweep
}
OPTICS_KINDS = ("sensor_array", "flash_detector")  # the kinds whose detectors see a finite beam
BEACON_PARAMS: dict[str, dict[str, tuple[str, float]]] = {
    "reflector": {
        "range": ("length", math.inf),
        "max_incidence": ("angle", math.radians(90.0)),
        "false_rate": ("number", 0.0),  # false returns per second
    },
    "sensor_array": {
        **OPTICS_PARAMS,
        "merge_rate": ("number", 0.0),  # merged measurements per revolution
        "false_rate": ("number", 0.0),  # false pulses per second
        "clock_hz": ("number", 20e6),
    },
    "flash_detector": {
        **OPTICS_PARAMS,
        "counts_per_turn": ("count", 12500),
        "near_range": ("length", 0.3048),
        "near_incidence": ("angle", math.radians(44.0)),
        "far_range": ("length", 7 * 0.3048),
        "far_incidence": ("angle", math.radians(27.0)),
    },
    "light": {
        "samples_per_turn": ("count", 120),
        "beam_width": ("angle", math.radians(6.0)),
        "brightness_noise": ("number", 0.0),
        "servo_jitter": ("angle", 0.0),
        "saturation_range": ("length", 1.0),  # closer than this, a light saturates the sensor
    },
}
DEFAULT_BEACON_RADIUS = 0.02  # m


def beacons(m: yr.Map, fld: Field) -> Beacons:
    """The beacons: their kind's parameters (defaults replaced by the ones given), each beacon,
    their radius and crosstalk."""
    kind = m.req("kind", yr.choice(*BEACON_PARAMS))
    schema = {**COMMON_PARAMS, **BEACON_PARAMS[kind]}
    params = {name: default for name, (_, default) in schema.items()}
    if m.has("params"):
        pm = m.sub("params", tuple(schema))
        for name, (quantity, _) in schema.items():
            if not pm.has(name):
                continue
            if quantity == "count":
                params[name] = pm.req(name, yr.count)
            elif quantity == "angle":
                params[name] = math.radians(pm.req(name, yr.nonnegative))
            elif quantity in ("length", "speed"):
                params[name] = pm.req(name, yr.positive) * m.ctx.scale
            else:
                params[name] = pm.req(name, yr.nonnegative)
    items = _items(m, fld, kind)
    radius = m.opt("radius", yr.length, DEFAULT_BEACON_RADIUS)
    crosstalk = m.opt("crosstalk", yr.choice("coded", "shared"), "coded")
    if crosstalk == "shared" and kind != "sensor_array":
        raise m.ctx.fail(
            m.raw("crosstalk").line, m.key("crosstalk"), "shared crosstalk applies to sensor_array beacons only"
        )
    return Beacons(kind=kind, items=tuple(items), radius=radius, params=MappingProxyType(params), crosstalk=crosstalk)


def _items(m: yr.Map, fld: Field, kind: str) -> list[Beacon]:
    """Each beacon of `items`: a unique id, where it stands, where it faces, its gain."""
    ctx = m.ctx
    items: list[Beacon] = []
    for node, key in m.seq("items"):
        b = yr.Map(ctx, node, key, BEACON_KEYS)
        bid = str(b.req("id", yr.scalar_id))
        if any(o.id == bid for o in items):
            raise ctx.fail(b.raw("id").line, b.key("id"), f"duplicate beacon id {bid!r}")
        at = b.req("at", yr.point)
        inside(ctx, fld, at, b.raw("at").line, b.key("at"), "beacon")
        facing = _facing(b, at, fld.center)
        if b.has("gain") and kind not in OPTICS_KINDS:
            raise ctx.fail(
                b.raw("gain").line, b.key("gain"), "a gain applies to sensor_array and flash_detector beacons"
            )
        items.append(Beacon(bid, at[0], at[1], facing, b.opt("gain", yr.positive, 1.0)))
    if not items:
        raise ctx.fail(m.raw("items").line, m.key("items"), "at least one beacon is required")
    return items


def _facing(b: yr.Map, at: tuple[float, float], center: tuple[float, float]) -> float:
    """A beacon faces a direction in degrees, or towards a point [x, y]; default: the field centre."""
    if not b.has("facing"):
        target = center
    elif isinstance(b.raw("facing").value, list):
        target = b.req("facing", yr.point)
    else:
        return math.radians(b.req("facing", yr.number))
    if math.dist(target, at) < 1e-12:
        raise b.ctx.fail(b.node.line, b.key("facing"), "a beacon cannot face the point it stands on")
    return math.atan2(target[1] - at[1], target[0] - at[0])
