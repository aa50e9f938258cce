"""pymunk through one door: every use of pymunk's private parts is in this module.

pymunk's Python wrappers (properties, Vec2d results, the checks of `Space.step`) cost more
than chipmunk's own work for a small world. The world steps, reads and sets its bodies
through these few functions instead; they compute the same numbers. Where pymunk's internals
are not as expected (another major version), `lib` is None and the public API is used;
`body_layout` probes a body's memory before the compiled stepping reads it.
"""

from __future__ import annotations

import functools

import numpy as np
import pymunk

try:
    from pymunk._chipmunk import ffi, lib  # type: ignore[import-not-found]
except ImportError:  # pragma: no cover - a pymunk without the cffi module
    ffi = lib = None


def settled(space: pymunk.Space) -> bool:
    """Whether nothing waits to be added to `space` or checked (bodies added since its last
    step, which pymunk's own step handles): chipmunk may then be stepped directly."""
    return lib is not None and not space._bodies_to_check and not space._add_later


class locked:
    """Steps taken directly in chipmunk: callbacks must not add or remove shapes meanwhile, as
    in `Space.step`, and shapes removed during them are forgotten after, as it does. A class,
    not a generator: it is entered at every control period."""

    __slots__ = ("space",)

    def __init__(self, space: pymunk.Space):
        self.space = space

    def __enter__(self) -> None:
        self.space._locked = True

    def __exit__(self, *exc: object) -> None:
        self.space._locked = False
        self.space._removed_shapes.clear()


def step(space: pymunk.Space, dt: float) -> None:
    """`space.step(dt)`, through chipmunk directly when the space is `settled`."""
    if not settled(space):
        space.step(dt)
        return
    with locked(space):
        lib.cpSpaceStep(space._space, dt)


def poses(bodies: list[pymunk.Body]) -> tuple[float, ...]:
    """Every body's x, y and angle, flat, as pymunk's `position` and `angle` give them."""
    out: list[float] = []
    if lib is not None:  # the same numbers, without pymunk's wrappers
        get_position, get_angle = lib.cpBodyGetPosition, lib.cpBodyGetAngle
        for body in bodies:
            c = body._body
            p = get_position(c)
            out += (p.x, p.y, get_angle(c))
        return tuple(out)
    for body in bodies:
        p = body.position
        out += (p.x, p.y, body.angle)
    return tuple(out)


def set_velocity(body: pymunk.Body, vx: float, vy: float) -> None:
    """`body.velocity = (vx, vy)`."""
    if lib is None:
        body.velocity = (vx, vy)
    else:
        lib.cpBodySetVelocity(body._body, (vx, vy))


def set_angular_velocity(body: pymunk.Body, w: float) -> None:
    """`body.angular_velocity = w`."""
    if lib is None:
        body.angular_velocity = w
    else:
        lib.cpBodySetAngularVelocity(body._body, w)


def address(obj: pymunk.Body | pymunk.Space) -> int:
    """The memory address of a body's or a space's chipmunk struct."""
    return int(ffi.cast("uintptr_t", obj._body if isinstance(obj, pymunk.Body) else obj._space))


@functools.cache
def step_function() -> int:
    """The address of chipmunk's `cpSpaceStep(space, dt)` in pymunk's library."""
    return int(ffi.cast("uintptr_t", ffi.addressof(lib, "cpSpaceStep")))


# Where chipmunk 7 keeps a body's position, velocity, angle and turn rate, in doubles from
# the struct's start (cpBody: two function pointers, m, m_inv, i, i_inv, cog, p, v, f, a, w).
LAYOUT = (8, 10, 14, 15)


@functools.cache
def body_layout() -> tuple[int, int, int, int] | None:
    """`LAYOUT`, if a body's memory holds what chipmunk's getters give at those places: a
    probe body is given distinct values through pymunk, then read back both ways. None where
    it does not (another chipmunk), or without the compiled module."""
    if lib is None:
        return None
    body = pymunk.Body(2.0, 3.0)
    body.position, body.velocity = (0.125, -7.5), (11.25, -2.0625)
    body.angle, body.angular_velocity = 0.3, 0.875
    words = np.frombuffer(ffi.buffer(ffi.cast("double *", body._body), 8 * 16), np.float64)
    p, v, a, w = LAYOUT
    seen = (words[p], words[p + 1], words[v], words[v + 1], words[a], words[w])
    wanted = (*body.position, *body.velocity, body.angle, body.angular_velocity)
    return LAYOUT if seen == wanted else None
