"""The random tree: reproducible per named stream, independent between streams."""

import numpy as np

from arena.rng import RandomTree


def test_same_seed_and_path_same_numbers_across_instances():
    a = RandomTree(5).stream("robot", 1, "laser").random(8)
    b = RandomTree(5).stream("robot", 1, "laser").random(8)
    assert np.array_equal(a, b)


def test_streams_differ_by_path_and_seed_and_do_not_shift():
    t = RandomTree(5)
    x = t.stream("robot", 0, "laser").random(1000)
    y = t.stream("robot", 1, "laser").random(1000)
    z = RandomTree(6).stream("robot", 0, "laser").random(1000)
    assert abs(np.corrcoef(x, y)[0, 1]) < 0.1 and not np.array_equal(x, z)
    # drawing from another stream in between never changes what a stream gives
    t2 = RandomTree(5)
    t2.stream("robot", 1, "laser").random(50)
    assert np.array_equal(t2.stream("robot", 0, "laser").random(1000), x)
