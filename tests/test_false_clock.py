"""The false pulses' clock drawn ahead (readout.FalseClock) against NumPy drawing each window
itself (`readout.false_times`): the same times, window after window, from two Generators of
one seed, with the caller's own draws (an array's label per pulse) between windows, for quiet
rates, busy ones, means of 10 and over (NumPy's other Poisson method) and empty windows; and
the quiet windows a compiled pass takes (`readout.quiet`) against the clocks' own."""

import numpy as np
import pytest

from arena.sensing.readout import FalseClock, false_times, quiet


def windows(seed: int, count: int, longest: float) -> list[tuple[float, float]]:
    """`count` consecutive windows of random lengths up to `longest`, some of them empty."""
    g = np.random.default_rng(seed)
    lengths = g.uniform(0.0, longest, count) * (g.random(count) > 0.05)
    ends = np.cumsum(lengths)
    return list(zip((ends - lengths).tolist(), ends.tolist()))


@pytest.mark.parametrize(
    ("rate", "longest", "ahead"),
    [(0.02, 0.2, 256), (3.0, 0.2, 256), (40.0, 0.5, 8), (5.0, 0.3, 2), (0.5, 30.0, 256)],
)
def test_the_same_times_as_drawing_each_window(rate: float, longest: float, ahead: int):
    spans = windows(int(rate * 100) + ahead, 3000, longest)
    direct, ahead_g = np.random.default_rng(11), np.random.default_rng(11)
    clock = FalseClock(ahead_g, rate, ahead)
    busy = 0
    for t0, t1 in spans:
        want, got = false_times(direct, rate, t0, t1), clock.times(t0, t1)
        assert got.tolist() == want.tolist(), (t0, t1)
        if len(want):  # the caller draws from the stream too, as an array's false pulse does
            busy += 1
            assert ahead_g.integers(7, size=len(got)).tolist() == direct.integers(7, size=len(want)).tolist()
    assert 0 < busy < len(spans)  # both kinds of window were tried


@pytest.mark.parametrize(("rate", "clocks", "ahead"), [(0.02, 1, 256), (2.0, 4, 8), (30.0, 3, 4), (60.0, 2, 16)])
def test_compiled_quiet_windows_are_the_clocks_own(rate: float, clocks: int, ahead: int):
    """`quiet` (what a period's kernel asks of its robots' clocks) takes a window only where
    every clock's `times` would find it quiet, taking the same uniform: clocks whose quiet
    windows it took, and `times` for the rest, give each window what clocks left to `times`
    alone give, drawing alike. Rates from rare to busy; means of 10 and over; blocks used up."""
    seeds = range(5, 5 + clocks)
    alone = [FalseClock(np.random.default_rng(s), rate, ahead) for s in seeds]
    blocks, used = np.zeros((clocks, ahead)), np.zeros(clocks, np.int64)
    shared = [
        FalseClock(np.random.default_rng(s), rate, ahead, blocks[r], used[r : r + 1]) for r, s in enumerate(seeds)
    ]
    taken = 0
    for t0, t1 in windows(clocks + ahead, 2000, 0.4 if rate < 50 else 0.3):
        want = [clock.times(t0, t1).tolist() for clock in alone]
        if quiet(blocks, used, rate, t0, t1):
            taken += 1
            got = [[] for _ in shared]
        else:
            got = [clock.times(t0, t1).tolist() for clock in shared]
        assert got == want, (t0, t1)
        for a, b, pulses in zip(alone, shared, want):  # the caller draws for each pulse, alike
            assert a.g.integers(7, size=len(pulses)).tolist() == b.g.integers(7, size=len(pulses)).tolist()
    assert 0 < taken < 2000
