"""The compiled hit passes (arena.sensing.sweep) against the kind modules' NumPy forms: on random
trajectories, for every detector kind, `candidates` keeps the crossings that `find_crossings`,
the occlusion kernel and `hardware.visible` keep, with `hardware.sensitivity`'s response, and
`response` fires those `optics.optics` fires with the same log-normal light, taking each robot's
draws in order from its row of a block (normals.Normals). The arc functions
differ in the last bit (the C library's against NumPy's: decision 0041), so floats are compared
to 1e-12 and decisions exactly."""

import math

import numpy as np
import pytest
from helpers import BEACONS, random_trajectory

from arena.sensing import hardware, occlusion, optics, sweep
from arena.sensing.crossings import find_crossings

FACING = np.array([0.8, 2.4, -2.4, -0.8, -1.57])
KINDS = {
    "reflector": {"range": 1.6, "max_incidence": 1.0},
    "sensor_array": {
        "beam_diameter": 0.0015, "beam_divergence": 1e-3, "aperture": 0.003, "trigger_fraction": 0.5,
        "rise_time": 1.11e-5, "acceptance": 1.13, "light_noise": 0.05,
    },
    "flash_detector": {
        "beam_diameter": 0.002, "beam_divergence": 2e-3, "aperture": 0.004, "trigger_fraction": 0.4,
        "rise_time": 5e-6, "near_range": 0.3, "far_range": 2.1, "near_incidence": 0.77, "far_incidence": 0.47,
        "light_noise": 0.0,
    },
}  # fmt: skip


def numpy_hits(traj, kind, p, gain, reach, silhouette, radius, light):
    """What the kind modules say of a batch, in NumPy: kept crossings, their response, and which fire."""
    bx, by = BEACONS
    c = find_crossings(traj, bx, by)
    hidden, _, _ = occlusion.blocked(
        c.x, c.y, bx[c.beacon], by[c.beacon], radius, c.robot, c.step, c.s, traj.x, traj.y, reach, silhouette
    )
    keep = ~hidden & hardware.visible(kind, c, FACING, p)
    if kind == "reflector":
        return c, keep, np.ones(len(c)), keep
    inc = optics.incidence(c, FACING)
    sens = hardware.sensitivity(kind, c, inc, p, gain)
    ok, _ = optics.optics(c, inc, sens * light, p)
    return c, keep, sens, ok & keep


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_sweep_passes_keep_and_fire_what_the_kind_modules_do(kind):
    g = np.random.default_rng(11)
    p = KINDS[kind]
    sigma = p.get("light_noise", 0.0)
    fired = kept_total = 0
    for trial in range(80):
        traj = random_trajectory(g, robots=int(g.integers(1, 5)))
        robots = traj.x.shape[1]
        reach, silhouette = g.uniform(0.05, 0.3, robots), g.uniform(0.02, 0.12, robots)
        gain = g.uniform(0.5, 1.2, len(FACING)) if trial % 2 else None
        code, radius = sweep.KIND_CODES[kind], 0.02
        bx, by = BEACONS
        robot, beacon, step, s, rows = sweep.candidates(
            traj.x, traj.y, traj.h, traj.phi, traj.t, *sweep.bearings(traj.x, traj.y, bx, by), traj.x, traj.y, bx, by, FACING,
            np.zeros(0) if gain is None else gain, np.zeros(0), reach, silhouette, code, sweep.gates(p, radius),
        )  # fmt: skip
        keep = rows[11] > 0
        # each robot's standard normals in a row of its own, one per kept sweep in crossing order
        light, at = g.normal(size=(robots, 3 + int(keep.sum()))), g.integers(0, 3, robots)
        factor, taken = np.ones(len(s)), at.copy()
        if sigma:
            for i in np.nonzero(keep)[0]:
                factor[i] = np.exp(sigma * light[robot[i], taken[robot[i]]])
                taken[robot[i]] += 1
        c, want_keep, want_sens, want_fired = numpy_hits(traj, kind, p, gain, reach, silhouette, radius, factor)
        assert np.array_equal(robot, c.robot) and np.array_equal(beacon, c.beacon) and np.array_equal(step, c.step)
        np.testing.assert_allclose(
            rows[:7], np.array([c.t, c.x, c.y, c.phi, c.beam_rate, c.distance, c.bearing]), rtol=1e-12, atol=1e-12
        )
        assert np.array_equal(keep, want_keep)
        if kind != "reflector":
            np.testing.assert_allclose(rows[10], want_sens, rtol=1e-12)
            np.testing.assert_allclose(rows[9], np.cos(optics.incidence(c, FACING)), rtol=1e-12)
        detected, _ = sweep.response(robot, rows, light, at, sigma, kind != "reflector", sweep.hardware(p))
        assert at.tolist() == taken.tolist()  # the positions moved past what was taken
        assert np.array_equal(detected, want_fired)
        fired += int(detected.sum())
        kept_total += int(keep.sum())
    # the cases tell something: beams are blocked or gated, and some kept sweeps do not fire
    assert 0 < fired <= kept_total < 80 * 2.5 * 5 * 3
    if kind != "reflector":
        assert fired < kept_total


def test_gates_take_the_defaults_of_the_kind_modules():
    """A parameter a level leaves out reads as the kind modules read it."""
    g = sweep.gates({}, 0.05)
    assert g[-1] == 0.05 and math.isinf(g[0]) and math.isinf(g[7]) and g[2] == 0.0
