"""A kernel's machine code run without numba (arena._machine, decision 0055): what numba
compiled, written to the kernel's table, runs in a later process that never imports numba,
with numba's own answers; a table made for other sources is ignored; arguments of other
types go numba's way; `type_name` names a value's type as numba does."""

import dataclasses
import functools
import hashlib
import os
import pickle
import subprocess
import sys
from pathlib import Path

import numba
import numpy as np
import pytest
from numba.core.typing.typeof import Purpose

from arena import _machine

CALLEE = """
from arena.compiled import compiled

SCALE = 2.0

@compiled()
def scaled(x):
    return SCALE * x + 1.0
"""

KERNELS = """
import numpy as np
from arena.compiled import compiled
from callee import scaled

@compiled()
def outer(x):
    return scaled(x) * 10.0  # a kernel of another module, linked in

@compiled()
def doubled(a):
    out = np.empty(a.shape[0])  # an array returned: boxed by numba's code, its type unpickled
    for i in range(a.shape[0]):
        out[i] = 2.0 * a[i]
    return out

@compiled()
def total(a, start, count):
    s = 0.0
    for i in range(start, start + count):
        s += a[i]
    return s

@compiled()
def checked(x):
    if x < 0.0:
        raise ValueError("negative", x)
    return x
"""

CALLS = """
import sys
import numpy as np
sys.path.insert(0, sys.argv[1])
from kernels import checked, doubled, outer, total

base = np.arange(12.0)
print("outer", outer(3.0))
print("doubled", doubled(np.arange(3.0)).tolist())
print("total", total(base, 2, 3), total(base[::2], 1, 2), total(base.astype(np.int64), 0, 4))
readonly = base.copy()
readonly.flags.writeable = False
print("readonly", total(readonly, 0, 3))
print("numba imported:", "numba.core" in sys.modules)
try:
    checked(-1.5)  # its exception unpickled as numba pickled it (which may import numba)
except ValueError as e:
    print("raised", e.args)
"""


def _run(folder: Path, env: dict, script: str = CALLS) -> list[str]:
    done = subprocess.run(
        [sys.executable, "-c", script, str(folder)], env=env, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr
    return done.stdout.splitlines()


ANSWERS = [  # by hand: (2 * 3 + 1) * 10; 2a; 2+3+4, 2+4, 0+1+2+3; 0+1+2; the exception's arguments
    "outer 70.0",
    "doubled [0.0, 2.0, 4.0]",
    "total 9.0 6.0 6.0",
    "readonly 3.0",
]
RAISED = "raised ('negative', -1.5)"

NEW_TYPE = """
import sys
import numpy as np
sys.path.insert(0, sys.argv[1])
from kernels import total
print(total(np.arange(5, dtype=np.float32), 0, 5), "numba imported:", "numba.core" in sys.modules)
"""


def _folder(tmp_path: Path) -> dict:
    (tmp_path / "callee.py").write_text(CALLEE)
    (tmp_path / "kernels.py").write_text(KERNELS)
    return {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}


def test_a_kernel_runs_from_its_table_without_numba_with_numba_s_answers(tmp_path):
    """The first process compiles (numba) and writes each kernel's table; the next makes the
    same calls from the tables alone: numba never imported, every answer as numba gave it
    (an array returned, an exception raised, a strided view, int64, read-only). Arguments of
    a type no table holds go numba's way, with numba's answer."""
    env = _folder(tmp_path)
    assert _run(tmp_path, env) == [*ANSWERS, "numba imported: True", RAISED]
    tables = sorted(p.name.split("-")[0] for p in (tmp_path / "cache").rglob(f"*{_machine.SUFFIX}"))
    assert tables == ["kernels.checked", "kernels.doubled", "kernels.outer", "kernels.total"]  # called from Python
    (doubled,) = (tmp_path / "cache").rglob(f"kernels.doubled-*{_machine.SUFFIX}")  # numba's np.empty linked in:
    assert not [f for f in pickle.loads(doubled.read_bytes()).sources if "numba" in Path(f).parts]  # its extensions'

    assert _run(tmp_path, env) == [*ANSWERS, "numba imported: False", RAISED]
    assert _run(tmp_path, env, NEW_TYPE) == ["10.0 numba imported: True"]


def test_a_table_made_for_other_sources_is_ignored_then_written_anew(tmp_path):
    """The table of `outer` holds the stamp of the module of `scaled`, linked into it: once
    that module changes, `outer` goes numba's way (numba imported), and its table is written
    again with the new stamp."""
    env = _folder(tmp_path)
    _run(tmp_path, env)
    assert _run(tmp_path, env)[-2] == "numba imported: False"
    callee = tmp_path / "callee.py"
    callee.write_text(CALLEE.replace("SCALE = 2.0", "SCALE = 3.0"))
    probe = "import sys; sys.path.insert(0, sys.argv[1]); from kernels import outer; outer(3.0); print('numba.core' in sys.modules)"
    assert _run(tmp_path, env, probe) == ["True"]
    (table,) = (tmp_path / "cache").rglob(f"kernels.outer-*{_machine.SUFFIX}")
    sources = pickle.loads(table.read_bytes()).sources
    assert sources[str(callee)] == hashlib.sha256(callee.read_bytes()).hexdigest()
    assert _run(tmp_path, env, probe) == ["False"]


VALUES = [
    np.zeros(3),
    np.zeros((2, 3)),
    np.zeros((2, 3))[:, 1],
    np.asfortranarray(np.zeros((2, 3))),
    np.zeros((2, 3, 4))[..., ::2],
    np.zeros(4, np.int64),
    np.zeros(4, np.uint8),
    np.zeros(4, np.bool_),
    np.zeros(2, np.float32),
    np.zeros(2, np.complex128),
    np.zeros(0),
    np.zeros((0, 3)),
    1.5,
    np.float64(2.5),
    np.float32(2.5),
    3,
    -(2**63),
    2**63 - 1,
    2**63,
    2**64 - 1,
    True,
    np.bool_(False),
    np.int64(7),
    np.uint64(7),
    np.int32(7),
    np.uint8(7),
]


@pytest.mark.parametrize("value", VALUES, ids=lambda v: f"{type(v).__name__}:{getattr(v, 'dtype', '')}")
def test_a_type_is_named_as_numba_names_it(value):
    assert _machine.type_name(value) == str(numba.typeof(value, Purpose.argument))


def test_a_readonly_array_is_named_as_numba_names_it():
    value = np.zeros(3)
    value.flags.writeable = False
    assert _machine.type_name(value) == str(numba.typeof(value, Purpose.argument)) == "readonly array(float64, 1d, C)"


@pytest.mark.parametrize(
    "value", [2**64, -(2**63) - 1, "text", (1.0, 2.0), None, np.zeros(2, ">f8"), np.zeros(2, "M8[s]"), [1.0]]
)
def test_what_it_does_not_name_goes_numba_s_way(value):
    assert _machine.type_name(value) is None


def test_a_call_reaches_the_code_only_with_arguments_of_its_types():
    """An entry's caller runs its code for arguments of its types alone, the rest go to
    `miss`: an array as the one last checked, or by dtype, dimensions, layout and
    writeability; a scalar of a kind numba types so."""
    a, b = np.zeros(3), np.zeros((2, 2), np.int64)
    types = (_machine.type_name(a), _machine.type_name(b), "float64", "int64", "uint64", "bool", "int32")
    scalars = (1.0, 3, 2**63, True, np.int32(1))
    method = _machine.caller(types, (a, b, *scalars), lambda *args: "code", lambda args, keywords: ("miss", len(args)))
    call = functools.partial(method, None)  # a method: its kernel first
    assert call(a, b, *scalars) == "code"
    assert call(a, b, np.float64(1.0), np.int64(3), np.uint64(1), np.bool_(True), np.int32(1)) == "code"
    assert call(np.ones(3), np.ones((5, 7), np.int64), *scalars) == "code"  # others of the types
    readonly = np.zeros(3)
    readonly.flags.writeable = False
    wrong = [np.zeros(3, np.float32), np.zeros((3, 1)), np.zeros(6)[::2], readonly, [0.0, 0.0, 0.0]]
    for other in wrong:
        assert call(other, b, *scalars) == ("miss", 7), other
    assert call(a, np.asfortranarray(np.zeros((2, 3), np.int64)), *scalars) == ("miss", 7)  # F, not C
    for i, other in enumerate([1, 2**63, 3, 1, np.int64(1)]):  # an int for a float; past int64;
        changed = list(scalars)  # an int numba types int64, not uint64; an int for a bool; int64 for int32
        changed[i] = other
        assert call(a, b, *changed) == ("miss", 7), (i, other)
    assert call(a, b, 1.0, True, 2**63, True, np.int32(1)) == ("miss", 7)  # a bool is no int64
    assert call(a, b, *scalars[:-1], a6=np.int32(1)) == ("miss", 6)  # by keyword: numba's way
    assert call(a, b) == ("miss", 2)  # too few: numba says so


def _read_only(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


KINDS = {  # a fresh array of each kind at every call
    "C": lambda: np.zeros((4, 6)),
    "F": lambda: np.asfortranarray(np.zeros((4, 6))),
    "A": lambda: np.zeros((4, 6))[:, ::2],
    "read-only C": lambda: _read_only(np.zeros((4, 6))),
    "read-only F": lambda: _read_only(np.asfortranarray(np.zeros((4, 6)))),
    "read-only A": lambda: _read_only(np.zeros((4, 6)))[::2],
}


def test_each_layout_and_a_read_only_array_pass_their_own_caller_alone():
    """Named as numba names them, each kind of array passes its own caller and no other's."""
    for kind, make in KINDS.items():
        name = _machine.type_name(make())
        assert name == str(numba.typeof(make(), Purpose.argument)), kind
        call = _machine.caller((name,), (None,), lambda *args: "code", lambda args, keywords: "miss")
        assert [call(None, other()) for other in KINDS.values()] == ["code" if k == kind else "miss" for k in KINDS], (
            kind
        )


def test_a_table_whose_code_is_not_its_entry_s_goes_numba_s_way(tmp_path):
    """Machine code that does not define the entry's wrapper and environments (a file
    damaged, or another's) is never handed to LLVM, which would crash on it: numba answers."""
    env = _folder(tmp_path)
    _run(tmp_path, env)
    (path,) = (tmp_path / "cache").rglob(f"kernels.outer-*{_machine.SUFFIX}")
    table = pickle.loads(path.read_bytes())
    damaged = {
        types: dataclasses.replace(entry, code=b"\x7fELF" + bytes(200)) for types, entry in table.entries.items()
    }
    path.write_bytes(pickle.dumps(dataclasses.replace(table, entries=damaged)))
    probe = "import sys; sys.path.insert(0, sys.argv[1]); from kernels import outer; print(outer(3.0), 'numba.core' in sys.modules)"
    assert _run(tmp_path, env, probe) == ["70.0 True"]
