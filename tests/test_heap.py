"""arena.heap: what a process keeps to its end is frozen out of the collector's way, and the
collector comes back on as it was."""

from __future__ import annotations

import gc
import subprocess
import sys
import textwrap

from helpers import MINI_LEVEL

from arena.heap import lasting


class Node:
    def __init__(self) -> None:
        self.me = self  # a cycle: only the cyclic collector frees it


def test_objects_made_inside_are_frozen_and_the_collector_comes_back_on():
    assert gc.isenabled()
    before = gc.get_freeze_count()
    try:
        with lasting():
            assert not gc.isenabled()  # paused while the lasting objects are made
            kept = [Node() for _ in range(1000)]
        assert gc.isenabled()
        assert gc.get_freeze_count() >= before + len(kept)
    finally:
        gc.unfreeze()  # this test process's heap back to the collector


def test_nested_the_outer_one_turns_the_collector_back_on_and_off_stays_off():
    try:
        with lasting():
            with lasting():
                pass
            assert not gc.isenabled()  # the inner one found it off: it leaves it off
        assert gc.isenabled()
        gc.disable()
        try:
            with lasting():
                pass
            assert not gc.isenabled()  # a caller that had it off keeps it off
        finally:
            gc.enable()
    finally:
        gc.unfreeze()


def test_an_exception_inside_still_turns_the_collector_back_on():
    try:
        try:
            with lasting():
                raise ValueError("inside")
        except ValueError:
            pass
        assert gc.isenabled()
    finally:
        gc.unfreeze()


def test_a_command_imports_only_what_it_needs_and_freezes_it(tmp_path):
    """A command that plays no match (`levels`) never imports numba; one that does (`run`)
    loads the kernels' machine code (without numba, from the install's tables) frozen: no
    collection walks it (gc.get_objects lists what collections see)."""
    (tmp_path / "level.yaml").write_text(MINI_LEVEL)
    probe = textwrap.dedent(
        """
        import gc, io, sys, contextlib
        from referee.cli.main import main
        with contextlib.redirect_stdout(io.StringIO()):
            assert main(["levels"]) == 0
        print("numba imported for levels:", "numba" in sys.modules)
        with contextlib.redirect_stdout(io.StringIO()):
            assert main(["run", "level.yaml", "--team", "ref:idle", "--in-process", "--quiet"]) == 0
        from arena.sensing import sweep
        seen = {id(o) for o in gc.get_objects()}
        loaded = [form[1] for kernel in vars(sweep).values() for form in getattr(kernel, "_forms", {}).values()]
        print("numba imported for run:", "numba.core" in sys.modules)
        print("kernels loaded:", len(loaded) > 0, "seen:", any(id(o) in seen for o in loaded))
        print("collector on:", gc.isenabled())
        """
    )
    proc = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "numba imported for levels: False" in proc.stdout
    assert "numba imported for run: False" in proc.stdout
    assert "kernels loaded: True seen: False" in proc.stdout
    assert "collector on: True" in proc.stdout


def test_a_first_sensing_leaves_its_kernels_out_of_the_collectors_sight():
    """The kernels a user's process loads with its first Sensing are frozen too, loaded from
    their tables or by numba."""
    probe = textwrap.dedent(
        """
        import gc, sys
        import levels
        from levels.loader import load_level
        from arena import _machine
        from arena.rng import RandomTree
        from arena.sensing import sweep
        from arena.sensing.pipeline import Sensing
        from arena.world import World
        if sys.argv[1] == "numba":
            _machine.read = lambda py_func: None  # no table: numba loads them from its cache
            _machine.write = lambda py_func, table: None  # and the install's tables are left whole
        world = World(load_level(levels.path("asabe")))
        Sensing(world, RandomTree(1))
        loaded = [form[1] for kernel in vars(sweep).values() for form in getattr(kernel, "_forms", {}).values()]
        made = [getattr(kernel, "_dispatcher", None) for kernel in vars(sweep).values()]
        loaded += [o for dispatcher in made if dispatcher is not None for o in dispatcher.overloads.values()]
        seen = {id(o) for o in gc.get_objects()}
        print("kernels loaded:", len(loaded) > 0, "seen:", any(id(o) in seen for o in loaded))
        print("collector on:", gc.isenabled())
        """
    )
    for way in ("tables", "numba"):
        proc = subprocess.run([sys.executable, "-c", probe, way], capture_output=True, text=True, timeout=120)
        assert proc.returncode == 0, proc.stderr
        assert "kernels loaded: True seen: False" in proc.stdout, way
        assert "collector on: True" in proc.stdout
