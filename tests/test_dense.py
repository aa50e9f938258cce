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


def _outcome(solve, columns, b):
    """What a solve gives: its numbers' bytes, or the kind of error it raised."""
    try:
        return np.array(solve(columns, b)).tobytes()
    except np.linalg.LinAlgError:
        return "LinAlgError"


@pytest.mark.parametrize("direct", [True, False], ids=["LAPACK through ctypes", "through NumPy"])
def test_a_newton_steps_solver_is_np_linalg_lstsq_bit_for_bit(direct):
    g = np.random.default_rng(23)
    for m in range(3, 9):
        solve = dense.lstsq_solver(m, 3) if direct else dense._gufunc_solver(m, 3)
        if direct:  # NumPy's wheels: the routine itself is called (this test's point)
            assert isinstance(solve.__self__, dense._Dgelsd)
        for k in range(400):
            a = g.normal(size=(m, 3)) * g.choice([1e-6, 1e-3, 1.0, 1e3, 1e6], size=3)
            a[:, 2] = -1.0
            if k % 50 == 1:
                a[:, 1] = 2 * a[:, 0]  # rank deficient: x and y columns parallel
            if k % 50 == 2:
                a[g.integers(m), g.integers(2)] = np.nan  # (an infinity makes LAPACK itself loop forever)
            b = g.normal(size=m) * g.choice([1e-9, 1.0, 1e3])
            try:
                expected = np.linalg.lstsq(a, b, rcond=None)[0].tobytes()
            except np.linalg.LinAlgError:
                expected = "LinAlgError"
            assert _outcome(solve, a.T.ravel().tolist(), b.tolist()) == expected
            # again, with the same solver: its kept workspace holds nothing of the last system
            assert _outcome(solve, a.T.ravel().tolist(), b.tolist()) == expected


def test_without_numpys_own_routine_the_solver_goes_through_numpy(monkeypatch):
    """A NumPy built against another LAPACK (the routine not found), or a routine that
    disagrees with NumPy on the probe: the solver is NumPy's gufunc, with NumPy's bits."""
    g = np.random.default_rng(31)
    a, b = g.normal(size=(5, 3)), g.normal(size=5)
    expected = np.linalg.lstsq(a, b, rcond=None)[0].tobytes()
    solve_directly = dense._Dgelsd.solve
    cases = [
        ("_DGELSD", "no_such_routine_"),
        (
            "_Dgelsd",
            type("Off", (dense._Dgelsd,), {"solve": lambda s, c, r: tuple(v + 1e-9 for v in solve_directly(s, c, r))}),
        ),
    ]
    for name, value in cases:
        with monkeypatch.context() as patched:
            patched.setattr(dense, name, value)
            dense._per_thread.__dict__.clear()
            solve = dense.lstsq_solver(5, 3)
            assert not isinstance(getattr(solve, "__self__", None), dense._Dgelsd)
            assert np.array(solve(a.T.ravel().tolist(), b.tolist())).tobytes() == expected
    dense._per_thread.__dict__.clear()


def test_each_thread_has_solvers_of_its_own():
    """A solver keeps buffers: two threads solving at once must not share one."""
    import threading

    theirs = []
    worker = threading.Thread(target=lambda: theirs.append(dense.lstsq_solver(4, 3)))
    worker.start()
    worker.join(timeout=60)
    assert theirs and theirs[0] is not dense.lstsq_solver(4, 3)
    assert dense.lstsq_solver(4, 3) is dense.lstsq_solver(4, 3)
