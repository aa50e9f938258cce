"""The solvers' direct LAPACK calls give np.linalg's own bits, and its errors."""

import numpy as np
import pytest

from robots.toolkit import dense


def test_least_squares_condition_and_inverse_are_np_linalgs_bit_for_bit():
    g = np.random.default_rng(17)
    for _ in range(2000):
        m = int(g.integers(3, 7))
        a = g.normal(size=(m, 3)) * g.choice([1e-3, 1.0, 1e3], size=3)
        a[:, 2] = -1.0  # the solvers' Jacobians: d(bearing)/d(x, y), and -1 for the heading
        b = g.normal(size=m)
        assert dense.lstsq(a, b).tobytes() == np.linalg.lstsq(a, b, rcond=None)[0].tobytes()
        assert dense.condition(a) == np.linalg.cond(a)
        square = a.T @ a
        assert dense.inverse(square).tobytes() == np.linalg.inv(square).tobytes()


def test_a_rank_deficient_system_reads_as_np_linalg_reads_it():
    a = np.array([[1.0, 2.0, -1.0], [2.0, 4.0, -1.0], [3.0, 6.0, -1.0]])  # x and y columns parallel
    assert dense.condition(a) == np.linalg.cond(a)  # huge or infinite, as NumPy says
    with pytest.raises(np.linalg.LinAlgError):
        np.linalg.inv(np.zeros((3, 3)))
    with pytest.raises(np.linalg.LinAlgError):
        dense.inverse(np.zeros((3, 3)))
    zero = np.zeros((3, 3))
    assert dense.condition(zero) == np.linalg.cond(zero) == np.inf  # 0/0: infinite, not NaN
