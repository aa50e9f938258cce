"""A run of physics steps in one compiled loop: every drive's update, chipmunk's step and the
read of every robot's pose, step after step, with no Python between them.

How it works, in detail: docs/internals.md, `arena/stepping.py`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from arena.compiled import compiled
from arena.drive import MOTION_CHANGED, MOTION_V, RATE, RATE_CHANGED, TARGET_L, TARGET_R, TURN, advance

# a servo change in its row of the `changes` table: when, whose, and its targets and turn factor
DUE, SLOT, NEW_TARGET_L, NEW_TARGET_R, NEW_TURN = range(5)
WORDS = 16  # doubles of a cpBody read or written (the layout's places are below 16)


def _doubles_at(typingctx, address):
    """The doubles at memory `address` (an integer), as a pointer: `_doubles(address)`."""
    from llvmlite import ir
    from numba import types

    if not isinstance(address, types.Integer):
        return None

    def codegen(context, builder, signature, args):
        return builder.inttoptr(args[0], ir.DoubleType().as_pointer())

    return types.CPointer(types.float64)(address), codegen


def _call_at(typingctx, function, space, dt):
    """Call `void function(void *space, double dt)` (chipmunk's cpSpaceStep) at its address:
    `_call_step(function, space, dt)`."""
    from llvmlite import ir
    from numba import types

    if not (isinstance(function, types.Integer) and isinstance(space, types.Integer)):
        return None

    def codegen(context, builder, signature, args):
        address, space_address, step = args
        pointer = ir.IntType(8).as_pointer()
        kind = ir.FunctionType(ir.VoidType(), [pointer, ir.DoubleType()])
        builder.call(builder.inttoptr(address, kind.as_pointer()), [builder.inttoptr(space_address, pointer), step])
        return context.get_dummy_value()

    return types.void(function, space, types.float64), codegen


def _from_numba() -> dict[str, Any]:
    """What `run_steps` names from numba: its array over a pointer, and the two intrinsics
    above (made where numba compiles it; its machine code runs without numba)."""
    from numba import carray
    from numba.extending import intrinsic

    return {"carray": carray, "_doubles": intrinsic(_doubles_at), "_call_step": intrinsic(_call_at)}


def _numba_only(*args: Any) -> Any:
    raise RuntimeError("numba's own: bound where numba compiles run_steps (_from_numba)")


carray = _doubles = _call_step = _numba_only


@compiled(names=_from_numba)
def run_steps(
    step_function: int,
    space: int,
    dt: float,
    bodies: np.ndarray,
    controls: np.ndarray,
    drives: np.ndarray,
    layout: np.ndarray,
    changes: np.ndarray,
    tick: int,
    clock: np.ndarray,
    watch: np.ndarray,
    near: float,
    states: np.ndarray,
    velocities: np.ndarray,
) -> int:
    """Up to `len(states)` physics steps from `tick`: the servo changes come due (rows of
    `changes`, in order of their due ticks), each drive's equations (`arena.drive.advance` on
    its row of `drives`, updated in place), chipmunk's step, then every robot's x, y and heading into
    `states` (and velocity into `velocities`, if it has rows). `clock[0]` holds the tick of
    the step under way, for the collision callbacks. Stops after a step where a robot of
    `watch` (rows of state index, x, y) stands within sqrt(`near`) of its point; returns the
    steps run, negative if it stopped so (a stop at the last step must still be told)."""
    px, vx, a, w = layout[0], layout[1], layout[2], layout[3]
    n = bodies.shape[0]
    record_velocities = velocities.shape[0] > 0
    change = 0
    for k in range(states.shape[0]):
        while change < changes.shape[0] and changes[change, DUE] <= tick + k:
            d = drives[int(changes[change, SLOT])]
            d[TARGET_L] = changes[change, NEW_TARGET_L]
            d[TARGET_R] = changes[change, NEW_TARGET_R]
            d[TURN] = changes[change, NEW_TURN]
            change += 1
        for r in range(n):
            body = carray(_doubles(bodies[r]), WORDS)
            heading = body[a]
            d = drives[r]
            changed = advance(d, heading)  # the drive's equations (arena.drive)
            control = carray(_doubles(controls[r]), WORDS)
            if changed & RATE_CHANGED:
                control[w] = d[RATE]
            if changed & MOTION_CHANGED:
                v = d[MOTION_V]
                control[vx] = v * math.cos(heading)
                control[vx + 1] = v * math.sin(heading)
        clock[0] = tick + k
        _call_step(step_function, space, dt)
        row = states[k]
        for r in range(n):
            body = carray(_doubles(bodies[r]), WORDS)
            row[3 * r] = body[px]
            row[3 * r + 1] = body[px + 1]
            row[3 * r + 2] = body[a]
            if record_velocities:
                velocities[k, 2 * r] = body[vx]
                velocities[k, 2 * r + 1] = body[vx + 1]
        for i in range(watch.shape[0]):
            dx = row[int(watch[i, 0])] - watch[i, 1]
            dy = row[int(watch[i, 0]) + 1] - watch[i, 2]
            if dx * dx + dy * dy <= near:
                return -(k + 1)
    return states.shape[0]
