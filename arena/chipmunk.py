"""Direct calls into pymunk's chipmunk library for the hottest per-step operations.

pymunk's Python wrappers (properties, Vec2d results, the checks of `Space.step`) cost more
than chipmunk's own work for a small world. The world steps, reads and sets its bodies
through these few functions instead; they compute the same numbers. Where pymunk's internals
are not as expected (another major version), `lib` is None and the public API is used.
"""

from __future__ import annotations

import pymunk

try:
    from pymunk._chipmunk import lib  # type: ignore[import-not-found]
except ImportError:  # pragma: no cover - a pymunk without the cffi module
    lib = None


def step(space: pymunk.Space, dt: float) -> None:
    """`space.step(dt)`, through chipmunk directly when nothing is waiting to be added or
    checked (bodies added since the last step: pymunk's own step handles them)."""
    if lib is None or space._bodies_to_check or space._add_later:
        space.step(dt)
        return
    space._locked = True  # callbacks must not add or remove shapes meanwhile, as in Space.step
    try:
        lib.cpSpaceStep(space._space, dt)
        space._removed_shapes.clear()
    finally:
        space._locked = False


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
