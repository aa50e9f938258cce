"""The compiled hit passes (arena.sensing.sweep) against the kind modules' NumPy forms: on random
trajectories, for every detector kind, `candidates` keeps the crossings that `find_crossings`,
the occlusion kernel and `hardware.visible` keep, with `hardware.sensitivity`'s response, and
`response` fires those `optics.optics` fires with the same log-normal light, taking each robot's
draws in order from its row of a block (normals.Normals). The arc functions
differ in the last bit (the C library's against NumPy's: decisions 0041, 0050), so floats are compared
to 1e-12 and decisions exactly."""

import math

import numpy as np
import pytest
from helpers import BEACONS, random_trajectory

from arena.rng import RandomTree
from arena.sensing import crossings, hardware, occlusion, optics, spin, sweep
from arena.sensing.crossings import bearings, find_crossings
from arena.sensing.normals import Normals
from arena.sensing.pipeline import Sensing
from arena.world import World
from levels.loader import find_level

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
        c.x, c.y, bx, by, c.beacon, radius, c.robot, c.step, c.s, traj.x, traj.y, reach, silhouette
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
            traj.x, traj.y, traj.h, traj.phi, traj.t, *bearings(traj.x, traj.y, bx, by), traj.x, traj.y, bx, by, FACING,
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


def test_bearings_are_the_c_librarys_atan2_within_an_ulp_of_numpys():
    """The grid's bearings are the C library's `atan2` (decision 0050), the same on every
    processor; NumPy's own `arctan2` (which may take SIMD code) agrees to the last bit or one."""
    g = np.random.default_rng(5)
    traj = random_trajectory(g, robots=3)
    bx, by = BEACONS
    dx, dy, bearing = bearings(traj.x, traj.y, bx, by)
    np.testing.assert_array_equal(dx, bx[None, None, :] - traj.x[:, :, None])
    np.testing.assert_array_equal(dy, by[None, None, :] - traj.y[:, :, None])
    libm = np.vectorize(math.atan2)(dy, dx)
    assert np.array_equal(bearing, libm)
    assert np.all(np.abs(bearing - np.arctan2(dy, dx)) <= np.spacing(np.abs(libm)))


def sensing_case(g, kind, trial):
    """A random batch: a trajectory whose beams leave off the bodies (a tilted floor), the
    spin's drive and state, the kind's hardware, and draws for the light and the timing."""
    p = KINDS[kind]
    traj = random_trajectory(g, robots=int(g.integers(1, 5)))
    robots, steps = traj.x.shape[1], traj.x.shape[0] - 1
    omega = g.choice([-1.0, 1.0], robots) * g.uniform(30, 90, robots)
    noise = g.normal(size=(robots, steps + 7)) if trial % 2 else np.zeros((0, 0))  # each robot's draws, a row
    powers = [np.broadcast_to(a ** np.arange(1, steps + 1)[:, None], (steps, robots)).copy() for a in (0.9, 0.8)]
    lag_decay, coupled = (0.8, 0.05) if trial % 3 else (-1.0, 0.0)
    bx, by = BEACONS
    gain = g.uniform(0.5, 1.2, len(FACING)) if trial % 2 else np.zeros(0)
    reach, silhouette = g.uniform(0.05, 0.3, robots), g.uniform(0.02, 0.12, robots)
    code = sweep.KIND_CODES[kind]
    return {
        "traj": traj, "x": traj.x + 0.001, "y": traj.y - 0.001, "omega": omega,
        "drive": (noise, 0.01, 0.9, powers[0], lag_decay, coupled, powers[1]),
        "noise_at": g.integers(0, 7, robots) if trial % 2 else np.zeros(0, np.int64),
        "state": [g.uniform(-50, 50, robots), g.normal(0, 0.01, robots), g.normal(0, 0.1, robots), g.normal(0, 1, robots)],
        "hardware": (bx, by, FACING, gain, np.zeros(0), reach, silhouette, code, sweep.gates(p, 0.02)),
        "light": g.normal(size=(robots, 400)), "timing": g.normal(size=(robots, 400)),
        "clock": np.array([1e-5, traj.t[0], traj.t[-1], 0.0, math.nextafter(traj.t[0], math.inf)]),
        "fire": (p.get("light_noise", 0.0), np.array(sweep.hardware(p))),
        "merging": (np.sign(omega), np.array([0.0, len(bx), 0.0]), np.uint64(7)),
    }  # fmt: skip


def fire_case(c, robot, beacon, rows, at):
    """`sweep.fire` of a case's crossings, its draws taken from the positions `at`, as `sense`
    returns it: `pulse_rows`' two blocks, then the counts."""
    sigma, optics_ = c["fire"]
    direction, merging, key = c["merging"]
    bx, by, code = c["hardware"][0], c["hardware"][1], c["hardware"][7]
    rows, shift, source, robot, beacon, times, phase, counts = sweep.fire(
        robot, beacon, rows, code, c["light"], at[0], sigma, optics_, c["timing"], at[1], c["clock"], c["omega"],
        direction, merging, key,
    )  # fmt: skip
    ids, told = sweep.pulse_rows(rows, shift, source, robot, beacon, times, phase, bx, by)
    assert ids.dtype == np.int64 and np.array_equal(ids, np.array([robot, beacon]).reshape(2, -1))
    by_numpy = [times, phase, rows[1, source], rows[2, source], bx[beacon], by[beacon], shift[source]]
    assert np.array_equal(told, np.array(by_numpy).reshape(7, -1))
    return ids, told, counts


def staged(c):
    """The stages one by one: `laser_phases`, `bearings`, `candidates`, `fire`."""
    traj, x, y = c["traj"], c["x"], c["y"]
    robots = traj.x.shape[1]
    moved = [v.copy() for v in c["state"]]
    noise_at = c["noise_at"].copy()
    phi = spin.laser_phases(c["omega"], 1 / 240, moved[0], traj.h, *drive(c, noise_at), *moved[1:])
    bx, by, facing, gain, offset, reach, silhouette, code, gates = c["hardware"]
    robot, beacon, _, _, rows = sweep.candidates(
        x, y, traj.h, phi, traj.t, *bearings(x, y, bx, by), traj.x, traj.y, bx, by, facing, gain, offset,
        reach, silhouette, code, gates,
    )  # fmt: skip
    at = [np.zeros(robots, np.int64), np.zeros(robots, np.int64)]
    return (phi, *fire_case(c, robot, beacon, rows, at)), [phi[-1], *moved[1:], noise_at], at


def one_call(c, split):
    """`sense` in one call, or (`split`) `sense_candidates` then `fire`."""
    traj = c["traj"]
    robots = traj.x.shape[1]
    moved = [v.copy() for v in c["state"]]
    noise_at = c["noise_at"].copy()
    at = [np.zeros(robots, np.int64), np.zeros(robots, np.int64)]
    motion = (
        c["x"],
        c["y"],
        traj.h,
        traj.t,
        traj.x,
        traj.y,
        c["omega"],
        1 / 240,
        moved[0],
        *drive(c, noise_at),
        *moved[1:],
    )
    if not split:
        sigma, optics_ = c["fire"]
        out = sweep.sense(
            *motion, *c["hardware"], c["light"], at[0], sigma, optics_, c["timing"], at[1], c["clock"], *c["merging"]
        )
        return out, [*moved, noise_at], at
    phi, robot, beacon, rows = sweep.sense_candidates(*motion, *c["hardware"])
    return (phi, *fire_case(c, robot, beacon, rows, at)), [*moved, noise_at], at


def drive(c, noise_at):
    """The case's spin drive as `laser_phases` takes it: the wobble's draws, their positions
    (`noise_at`, moved on in place), then the rest."""
    return (c["drive"][0], noise_at, *c["drive"][1:])


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_one_call_senses_what_the_stages_do(kind):
    """`sense` (the phases, the bearings, `candidates` and `fire` in one compiled call) gives
    what the stages give called one by one, and moves the spin's state on as `laser_phases`
    does; `sense_candidates` then `fire` (the path with obstacles between) gives the same."""
    g = np.random.default_rng(23)
    pulses_seen = 0
    for trial in range(12):
        c = sensing_case(g, kind, trial)
        want, want_state, want_at = staged(c)
        pulses_seen += want[1].shape[1]
        for split in (False, True):
            got, got_state, got_at = one_call(c, split)
            assert all(np.array_equal(w, v) for w, v in zip(want[:3], got[:3]))  # phases, the pulses
            assert all(np.array_equal(w, v) for w, v in zip(want[3], got[3]))  # counts, ties
            assert all(np.array_equal(w, v) for w, v in zip(want_state, got_state))
            assert all(np.array_equal(w, v) for w, v in zip(want_at, got_at))
    assert pulses_seen > 0


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_a_period_in_one_call_is_batch_poses_then_sense(kind):
    """`sense_period` (the state it moves on packed in blocks) gives what `batch_poses` then
    `sense` give, bit for bit: the poses, the phases, the pulses, the counts, and the spin's
    state, the draws' positions and the last state moved on alike; with and without gains,
    beam offsets, wobble, spin lag, timing noise and an event clock."""
    g = np.random.default_rng(31)
    pulses_seen = 0
    for trial in range(12):
        c = sensing_case(g, kind, trial)
        traj, dt = c["traj"], 1 / 240
        robots, steps = traj.x.shape[1], traj.x.shape[0] - 1
        states = np.stack([traj.x, traj.y, traj.h], axis=2).reshape(steps + 1, 3 * robots)
        t0, t_end = float(traj.t[0]), float(traj.t[0]) + steps * dt + 1e-13
        bx, by, facing, gain, _, reach, silhouette, code, gates = c["hardware"]
        offset = g.uniform(-0.01, 0.01, robots) if trial % 4 == 1 else np.zeros(0)
        noise, scale, decay, powers, lag_decay, coupled, lag_powers = c["drive"]
        sigma, optics_ = c["fire"]
        direction, merging, key = c["merging"]
        merging = np.array([float(kind == "sensor_array"), len(bx), 0.3 if trial % 3 == 2 else 0.0])
        timing_scale, clock_hz = (1e-5, 0.0) if trial % 2 else (0.0, 50.0)  # a coarse clock: its first tick matters
        # by the stages: the poses laid out, the clock's window and first tick, then `sense`
        last, xyh, t = states[0].copy(), np.empty((3, steps + 1, robots)), np.empty(steps + 1)
        sweep.batch_poses(last, states[1:], t0, t_end, dt, xyh, t)
        first = (math.floor(t[0] * clock_hz + 1e-6) + 1) / clock_hz if clock_hz else math.nextafter(t[0], math.inf)
        clock = np.array([timing_scale, t[0], t[-1], clock_hz, first])
        state = [v.copy() for v in c["state"]]
        at = [c["noise_at"].copy(), np.zeros(robots, np.int64), np.zeros(robots, np.int64)]
        want = sweep.sense(
            *xyh, t, xyh[0], xyh[1], c["omega"], dt, state[0], noise, at[0], scale, decay, powers, lag_decay,
            coupled, lag_powers, *state[1:], bx, by, facing, gain, offset, reach, silhouette, code, gates,
            c["light"], at[1], sigma, optics_, c["timing"], at[2], clock, direction, merging, key,
        )  # fmt: skip
        pulses_seen += want[1].shape[1]
        # in one call, over packed state
        live, places = np.array(c["state"]), np.zeros((4, robots), np.int64)
        places[0, : len(c["noise_at"])] = c["noise_at"]
        poses, times, counts = (
            np.full((4, steps + 1, robots), np.nan),
            np.full(steps + 1, np.nan),
            np.zeros((2, robots), np.int64),
        )
        needs = (steps, steps * len(bx))
        params = sweep.period_params(
            dt, (scale, decay, lag_decay, coupled), code, sigma, timing_scale, clock_hz, merging,
            (len(gain) > 0, len(offset) > 0), gates, optics_, needs, 0.0,
        )  # fmt: skip
        packed_robots = np.array(
            [c["omega"], direction, reach, silhouette, offset if len(offset) else np.zeros(robots)]
        )
        packed_beacons = np.array([bx, by, facing, gain if len(gain) else np.ones(len(bx))])
        first, room = states[0].copy(), steps * robots * len(bx)
        ids, told = np.full((2, room), -1, np.int64), np.full((7, room), np.nan)
        m, short, quiet = sweep.sense_period(
            first, states[1:], t0, t_end, poses, times, live, places, noise, c["light"], c["timing"], np.zeros((0, 0)),
            powers, lag_powers, packed_robots, packed_beacons, params, counts, ids, told, key,
        )  # fmt: skip
        assert quiet  # no clocks
        assert m == want[1].shape[1]
        # short: some robot's row of some block now holds less than a period's need
        blocks = zip((noise, c["light"], c["timing"]), places, (needs[0], needs[1], needs[1]))
        assert short == any(len(v) and (v.shape[1] - at < need).any() for v, at, need in blocks)
        ids, told = ids[:, :m], told[:, :m]
        assert np.array_equal(poses[:3], xyh) and np.array_equal(times, t) and np.array_equal(first, last)
        assert np.array_equal(poses[3], want[0])
        assert np.array_equal(ids, want[1]) and np.array_equal(told, want[2]) and np.array_equal(counts, want[3])
        assert np.array_equal(live, np.array(state))
        assert np.array_equal(places[0, : len(at[0])], at[0]) and np.array_equal(places[1:3], np.array(at[1:]))
    assert pulses_seen > 0


@pytest.mark.parametrize("robots, steps", [(1, 48), (3, 5), (2, 0)])
def test_a_batch_s_poses_and_times_are_the_states_laid_out_by_numpy(robots, steps):
    """`batch_poses` lays a batch out as NumPy would: the last state then each step's, as x, y
    and heading (steps + 1, robots) each; times `t0 + i dt`, the last exactly the world's; and it
    moves `last` on to the batch's last state (kept as it was when the batch has no step)."""
    g = np.random.default_rng(robots + steps)
    last, states = g.normal(size=3 * robots), g.normal(size=(steps, 3 * robots))
    t0, dt = 12.345, 1 / 240
    t_end = t0 + steps * dt + 1e-13  # where the world's clock stands, not quite the sum
    xyh, t = np.full((3, steps + 1, robots), np.nan), np.full(steps + 1, np.nan)
    before = last.copy()
    sweep.batch_poses(last, states, t0, t_end, dt, xyh, t)
    poses = np.vstack([before, states]).reshape(-1, robots, 3)
    assert np.array_equal(xyh, poses.transpose(2, 0, 1))
    want_t = t0 + np.arange(steps + 1) * dt
    want_t[-1] = t_end
    assert np.array_equal(t, want_t)
    assert np.array_equal(last, states[-1] if steps else before)


@pytest.mark.parametrize("ahead", [2, 16])
def test_draws_taken_from_the_block_are_each_stream_s_own_in_order(ahead):
    """What a kernel takes from `Normals`' block, batch after batch (`need` at most, any part of
    it), is each robot's stream drawn directly, in order: refills keep what was left and draw on
    (normals.Normals; the spin's wobble, the light and the timing take their draws so)."""
    seeds = (4, 9, 17)
    block = Normals([np.random.default_rng(s) for s in seeds], ahead=ahead)
    taken: list[list[float]] = [[] for _ in seeds]
    g = np.random.default_rng(3)
    for _ in range(300):
        need = int(g.integers(1, 40))
        values, at = block.ready(need)
        for r in range(len(seeds)):
            assert values.shape[1] - at[r] >= need  # looked at or not, the need is there
            k = need if g.random() < 0.5 else int(g.integers(0, need + 1))  # all its need, or any part
            taken[r] += values[r, at[r] : at[r] + k].tolist()
            at[r] += k
    for r, s in enumerate(seeds):
        assert taken[r] == np.random.default_rng(s).standard_normal(len(taken[r])).tolist()


def test_passes_looked_at_near_the_beacons_only_are_the_whole_grid_s():
    """`near_passes` takes a bearing only where a beam may pass its beacon; it finds the very
    passes and first guesses that `passes` finds on the whole grid of bearings, bit for bit:
    on wandering robots, on beams that point exactly at a beacon at a step's end (d = 0), on
    turns of up to 3 rad a step, on phases of up to 10^6 rad, and beside a beacon at a millimetre."""
    g = np.random.default_rng(8)
    bx, by = BEACONS
    found = exact = 0
    for trial in range(300):
        traj = random_trajectory(g, steps=int(g.integers(2, 60)), robots=int(g.integers(1, 5)))
        x, y, h, phi = traj.x.copy(), traj.y.copy(), traj.h, traj.phi.copy()
        if trial % 3 == 1:  # turns of up to 3 rad a step, far from phase 0: up to 10^6 rad, hours of spinning
            turn = np.broadcast_to(g.uniform(-3, 3, x.shape[1]), x.shape)  # rad a step, each robot its own
            far = g.choice([-1.0, 1.0], x.shape[1]) * 10 ** g.uniform(2, 6, x.shape[1])
            phi = far + np.cumsum(turn, axis=0)
        if trial % 5 == 2:  # a laser a millimetre from a beacon
            x[:, 0], y[:, 0] = bx[1] - 1e-3, by[1] + 1e-3 * g.uniform(-1, 1, len(x))
        dx, dy, grid = bearings(x, y, bx, by)
        beam = h + phi
        if trial % 2:  # some beams exactly on a beacon's bearing at step ends: d = 0 there
            for i in g.integers(0, len(x), 4):
                j, m = g.integers(0, x.shape[1]), g.integers(0, len(bx))
                turns = np.rint(beam[i, j] / (2 * math.pi)) + g.integers(-3, 4)  # as far from 0 as the beam
                beam[i, j] = grid[i, j, m] + 2 * math.pi * turns
                exact += wrap_angle_numpy(beam[i, j] - grid[i, j, m]) == 0.0
        want = crossings.passes(beam, grid, np.empty((0, 0, 0)), False)
        got = crossings.near_passes(beam, dx, dy)
        for w, v in zip(want, got):
            assert w.dtype == v.dtype and np.array_equal(w, v)
        found += len(want[0])
    assert found > 500 and exact > 100  # the cases tell something


def wrap_angle_numpy(a: float) -> float:
    return a - 2 * math.pi * np.rint(a / (2 * math.pi))


@pytest.mark.parametrize("name, ahead", [("asabe", 1), ("asabe-race", 2), ("vannoy", 1)])
def test_a_match_s_draws_are_refilled_when_the_period_says_a_row_runs_short(name, ahead):
    """A match's periods look at their blocks of draws only when `sense_period` said a row ran
    short (Sensing._period): with blocks one or two periods' need wide, refilled every few
    periods, the detections are those of a match that refills every block before every
    period, and no period reads past a row's end. Each stream's draws are taken in order
    whenever its block is refilled (the test above), so a period that read a row past its
    refilled part, or a stale block, would read other numbers."""
    level = find_level(name)
    every, lean = (Sensing(World(level), RandomTree(8)) for _ in range(2))
    blocks = [b for b in (lean.spin._noise, lean._light, lean._timing) if b is not None]
    assert lean._plain and len(blocks) >= 2  # the wobble's draws, and the light's or the timing's
    for block in blocks:
        block.ahead = ahead
    refills = 0
    for sensing in (every, lean):
        for slot in range(len(level.robots)):
            sensing.world.command(slot, 0.05 + 0.02 * slot, 0.12)
    for _ in range(120):
        every._draws = ()  # made ready before every period
        got = []
        for sensing in (every, lean):
            states, _ = sensing.world.run(level.steps_per_control)
            sensing.record_many(states)
            refills += sensing is lean and not sensing._draws
            got.append(sensing.flush())
        assert got[0] == got[1]
        for block in blocks:
            assert (block.at <= block.values.shape[1]).all()
    assert refills >= 10
