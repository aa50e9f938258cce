"""The install's warm-up (`python -P -m referee.match.warm`, decision 0040) compiles every
kernel a match calls: after it, with its cache alone (a cache folder of the test's own), other
matches of every level, with noise and ideal, their replays written, load every kernel and compile none, so a user's
first match never waits for the compiler. They load them without readying numba to compile
(decision 0045), nor numpy.ma for their arguments' types, and numba still compiles what is
new afterwards. Without it, the first
`laserarena run` says, before anything else, that it compiles and how long that takes; a
warmed one does not."""

import json
import os
import select
import subprocess
import sys
from pathlib import Path

import numpy as np

from referee.cli.commands import COMPILING_S

ROOT = Path(__file__).resolve().parent.parent
LASERARENA = str(Path(sys.executable).parent / "laserarena")
RUN = [LASERARENA, "run", "bac-static", "--team", "ref:idle"]

PROBE = """
import dataclasses
import sys
import tempfile
from pathlib import Path
import levels
import numpy as np
from numba import njit
from numba.core import base, event
from levels.loader import load_level
from referee.match.loop import play_match
from referee.sandbox.teams import resolve

refreshed = []  # numba readying its target context to compile
ready = base.BaseContext.refresh
base.BaseContext.refresh = lambda context: (refreshed.append(context), ready(context))[1]
with event.install_recorder("numba:compile") as compiled, tempfile.TemporaryDirectory() as folder:
    for name in levels.names():
        level = load_level(levels.path(name))
        level = dataclasses.replace(level, time_limit=min(level.time_limit, 8.0))
        teams = [resolve(level.default_controller)] * len(level.robots)
        for ideal in (False, True):
            play_match(level, teams, seed=7, ideal=ideal, isolate=False, replay=Path(folder) / "m.replay")
print("numpy.ma imported:", "numpy.ma" in sys.modules)
print("readied to compile:", len(refreshed))
print("a new function:", njit(lambda a: np.sum(a * 2.0))(np.arange(4.0)), "readied:", len(refreshed) > 0)
print(sorted({e.data["dispatcher"].py_func.__qualname__ for _, e in compiled.buffer if e.is_start}))
"""


def first_error_line(command: list[str], env: dict[str, str], cwd: Path) -> str:
    """The first line `command` writes to stderr (or '' if it ends first); then it is stopped."""
    proc = subprocess.Popen(command, env=env, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        ready, _, _ = select.select([proc.stderr], [], [], 600)
        return proc.stderr.readline() if ready else ""
    finally:
        proc.kill()
        proc.wait(timeout=60)


def test_after_the_warm_up_a_match_compiles_nothing(tmp_path):
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    # a cold cache: the command's first word is that it compiles, before the match can end
    notice = first_error_line(RUN, env, tmp_path)
    assert notice.startswith("laserarena: compiling the simulator's kernels") and f"{COMPILING_S} s" in notice
    warm = subprocess.run([sys.executable, "-P", "-m", "referee.match.warm"], env=env, capture_output=True, text=True)
    assert warm.returncode == 0, warm.stderr
    assert "compiled kernels ready" in warm.stderr
    probe = subprocess.run([sys.executable, "-P", "-c", PROBE], env=env, capture_output=True, text=True, timeout=600)
    assert probe.returncode == 0, probe.stderr
    lines = probe.stdout.splitlines()
    assert lines[-1] == "[]", probe.stdout  # the kernels it had to compile
    assert lines[-4] == "numpy.ma imported: False", probe.stdout  # numba's typeof of an array would import it
    assert lines[-3] == "readied to compile: 0", probe.stdout
    assert lines[-2] == "a new function: 12.0 readied: True", probe.stdout
    # warmed: a run says nothing of compiling (the table on stdout, nothing on stderr)
    done = subprocess.run(RUN, env=env, cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0 and "ref:idle" in done.stdout, done.stderr
    assert "compiling" not in done.stderr


def test_the_notice_says_what_was_measured():
    """The seconds the notice gives are those the performance report measured for a first run,
    within half again (the machine it runs on may be another)."""
    measured = json.loads((ROOT / "docs" / "performance.json").read_text())["first-run"]["cold_wall_s"]
    assert COMPILING_S / 1.5 <= measured <= COMPILING_S * 1.5


LINKED = """
import sys
import numpy as np
import levels
from levels.loader import load_level
from arena.rng import RandomTree
from arena.sensing.pipeline import Sensing
from arena.sensing.spin import first_order
from arena.world import World

def alone():
    y0, drive = np.array([0.4, -1.0]), np.arange(10.0).reshape(5, 2)
    powers = np.ones((5, 2)) * 0.5 ** np.arange(1, 6)[:, None]  # a^1..a^5 per row, as the spin passes them
    return first_order(0.5, powers, y0, drive)

def sensing():
    Sensing(World(load_level(levels.path("asabe"))), RandomTree(1))

if sys.argv[1] == "alone first":
    alone()
    sensing()
else:
    sensing()
print(alone().tolist())
"""


def test_a_kernel_another_links_in_still_returns_its_arrays_alone():
    """A kernel linked into another (`spin.first_order`, in `sweep.sense` through the laser's
    phases) and called on its own after that one was loaded from numba's cache returns its
    arrays (decision 0045: one environment per function, with the longer list of constants)."""
    y, want = np.array([0.4, -1.0]), []
    for k in range(5):  # the recursion itself: y[k] = a y[k-1] + drive[k]
        y = 0.5 * y + np.arange(10.0).reshape(5, 2)[k]
        want.append(y.tolist())
    for order in ("alone first", "sensing first"):  # the first caches both kernels, if need be
        run = subprocess.run([sys.executable, "-c", LINKED, order], capture_output=True, text=True, timeout=600)
        assert run.returncode == 0, run.stderr
        assert np.allclose(json.loads(run.stdout), want, rtol=1e-12, atol=1e-12), run.stdout


KERNEL = """
import numpy as np
from arena.compiled import compiled

@compiled()
def doubled(a):
    out = np.empty(a.shape[0])  # an array returned: the runtime's reference counts at work
    for i in range(a.shape[0]):
        out[i] = 2.0 * a[i]
    return out
"""

RUNTIME = """
import sys
from numba.core.runtime import nrtdynmod
compile_module = nrtdynmod.create_nrt_module
made = []
nrtdynmod.create_nrt_module = lambda context: (made.append(1), compile_module(context))[1]
sys.path.insert(0, sys.argv[1])
import numpy as np
from kernel import doubled
print(doubled.dispatcher(np.arange(3.0)).tolist(), "compiled the runtime:", bool(made))  # numba's way
"""


def test_the_runtime_s_functions_are_compiled_once_then_loaded_from_the_cache(tmp_path):
    """numba's runtime compiles a few LLVM functions in each process that loads a kernel; here
    the first process that looks in a kernel's cache leaves them there (arena.compiled), and
    the next loads them from there. A file cut short is compiled again, and its kernels still
    return their arrays."""
    (tmp_path / "kernel.py").write_text(KERNEL)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}

    def run() -> str:
        done = subprocess.run(
            [sys.executable, "-c", RUNTIME, str(tmp_path)], env=env, capture_output=True, text=True, timeout=300
        )
        assert done.returncode == 0, done.stderr
        return done.stdout.strip()

    assert run() == "[0.0, 2.0, 4.0] compiled the runtime: True"  # as the cache was looked in; the kernel compiled too
    (kept,) = (tmp_path / "cache").glob("*/numba-runtime-*.nbo")  # beside the kernel
    assert run() == "[0.0, 2.0, 4.0] compiled the runtime: False"  # both loaded
    kept.write_bytes(kept.read_bytes()[:100])  # a write cut short
    assert run() == "[0.0, 2.0, 4.0] compiled the runtime: True"
    assert run() == "[0.0, 2.0, 4.0] compiled the runtime: False"


LINKING = """
import sys
import numpy as np
from llvmlite import binding
sys.path.insert(0, sys.argv[1])
parsed = []
parse = binding.parse_bitcode
binding.parse_bitcode = lambda data, *a: (parsed.append(len(data)), parse(data, *a))[1]
from numba.core import entrypoints
from linking import inner, outer
print(inner(3.0), len(parsed), entrypoints._already_initialized)  # loaded from the cache: its bitcode untouched
print(outer(3.0), len(parsed) > 0, entrypoints._already_initialized)  # compiled, linking the loaded one: its bitcode parsed now
"""

LINKING_KERNELS = """
from arena.compiled import compiled

@compiled()
def inner(x):
    return 2.0 * x + 1.0

@compiled()
def outer(x):
    return inner(x) * 10.0
"""


def test_a_kernel_loaded_from_the_cache_is_linked_into_one_compiled_after_it(tmp_path):
    """A cached kernel's machine code loads without its LLVM bitcode parsed, nor numba's
    extensions loaded (arena.compiled); a kernel compiled later that calls it still links it
    in, the bitcode parsed then, and the extensions loaded before it compiles."""
    (tmp_path / "linking.py").write_text(LINKING_KERNELS)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    first = subprocess.run([sys.executable, "-c", LINKING, str(tmp_path)], env=env, capture_output=True, text=True)
    assert first.returncode == 0, first.stderr  # both compiled and cached
    for kept in (tmp_path / "cache").glob("*/linking.outer-*"):
        kept.unlink()  # `outer` compiles again; `inner` loads
    again = subprocess.run(
        [sys.executable, "-c", LINKING, str(tmp_path)], env=env, capture_output=True, text=True, timeout=300
    )
    assert again.returncode == 0, again.stderr
    assert again.stdout.split("\n")[:2] == ["7.0 0 False", "70.0 True True"], again.stdout


FIRST_CALL = """
import sys
from pathlib import Path
sys.path.insert(0, sys.argv[1])
from linking import inner, outer
cache = Path(sys.argv[2])
print(sorted(p.name for p in cache.rglob("*")))
print(inner(3.0))
print(sorted(p.suffix for p in cache.rglob("linking.inner-*")), sorted(p.name for p in cache.rglob("linking.outer-*")))
"""


def test_a_kernel_s_cache_is_made_at_its_first_call(tmp_path):
    """numba makes a kernel's cache by looking for a folder it may write and writing a file
    there: made at a kernel's first call (arena.compiled), a run pays it for the few kernels it
    calls, not for every kernel it imports. The kernel's table (arena._machine) is written
    beside it then."""
    (tmp_path / "linking.py").write_text(LINKING_KERNELS)
    cache = tmp_path / "cache"
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    done = subprocess.run(
        [sys.executable, "-c", FIRST_CALL, str(tmp_path), str(cache)], env=env, capture_output=True, text=True,
        timeout=300,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines() == ["[]", "7.0", "['.machine', '.nbc', '.nbi'] []"], done.stdout


SYMBOLS = """
import json
import levels
from llvmlite import binding
from arena import _elf, _machine, _numba
from levels.loader import load_level
from referee.match.loop import play_match
from referee.sandbox.teams import resolve

seen = []
load = _numba._from_object

def spy(codegen, serialized):
    name, kind, (code, bitcode) = serialized
    module = binding.parse_bitcode(bitcode)
    listed = {g.name for gs in (module.functions, module.global_variables) for g in gs if not g.is_declaration}
    seen.append((name, sorted(_elf.defined_symbols(code)), sorted(listed)))
    return load(codegen, serialized)

_numba._from_object = spy
_machine.read = lambda py_func: None  # no table: numba's way
_machine.write = lambda py_func, table: None  # and the install's tables are left whole
level = load_level(levels.path("asabe"))
play_match(level, [resolve(level.default_controller)], isolate=False)
print(json.dumps(seen))
"""


def test_the_symbols_read_from_a_kernel_s_machine_code_are_those_llvm_lists():
    """arena._elf's reading of an object file's symbol table against LLVM's own list of what
    the kernel's module defines, for every library a match loads from the install's cache
    (numba's runtime and each kernel; the largest defines hundreds)."""
    run = subprocess.run([sys.executable, "-P", "-c", SYMBOLS], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    seen = json.loads(run.stdout)
    assert len(seen) >= 5 and max(len(listed) for _, _, listed in seen) > 100, [name for name, _, _ in seen]
    for name, read, listed in seen:
        assert read == listed, name


def test_an_object_the_symbol_reader_cannot_read_is_left_to_llvm():
    """None, so the kernel loads numba's way: another format, or an ELF header whose tables run
    past the file."""
    import struct

    from arena._elf import defined_symbols

    assert defined_symbols(b"\xcf\xfa\xed\xfe" + bytes(60)) is None  # Mach-O
    assert defined_symbols(b"\x7fELF\x01\x01" + bytes(58)) is None  # 32-bit
    assert defined_symbols(b"\x7fELF\x02\x01" + bytes(10)) is None  # cut short in its header
    header = bytearray(b"\x7fELF\x02\x01" + bytes(58))
    struct.pack_into("<QIHHHHHH", header, 0x28, 1 << 20, 0, 64, 0, 0, 64, 3, 0)  # section headers past the end
    assert defined_symbols(bytes(header)) is None


TYPES = """
import sys
import numpy as np
from arena.sensing import sweep
base = np.arange(24.0).reshape(2, 3, 4)
readonly = np.zeros(5)
readonly.flags.writeable = False
arrays = [
    np.zeros(3), base, base[:, 1], np.asfortranarray(base[0]), base[..., ::2], readonly,
    np.zeros((2, 2), np.int64), np.zeros(4, np.bool_), np.zeros(2, np.uint64), np.zeros(3, np.complex128),
    np.zeros(0), np.zeros((0, 0)), np.float64(2.5), 3, True,
]
ours = [sweep.sense_period.dispatcher.typeof_pyval(a) for a in arrays]
print("numpy.ma imported:", "numpy.ma" in sys.modules)
from numba import typeof
from numba.core.typing.typeof import Purpose
print("as numba types them:", ours == [typeof(a, Purpose.argument) for a in arrays])
import numpy.ma
try:
    sweep.batch_poses(np.ma.zeros(3), np.zeros((0, 3)), 0.0, 0.0, 0.1, np.zeros((3, 1, 1)), np.zeros(1))
except Exception as e:
    print("a masked array:", type(e).__name__, "MaskedArray" in str(e))
"""


def test_a_kernel_types_its_array_arguments_as_numba_does_without_numpy_ma():
    """The kernels type an array argument they have not met yet as numba does, without
    importing numpy.ma (numba imports it to refuse masked arrays): every layout, dtype and
    flag alike; once numpy.ma is loaded, a masked array is refused with numba's own error."""
    out = subprocess.run([sys.executable, "-c", TYPES], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    assert out.stdout.splitlines() == [
        "numpy.ma imported: False",
        "as numba types them: True",
        "a masked array: NumbaTypeError True",
    ], out.stdout
