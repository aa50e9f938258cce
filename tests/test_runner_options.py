"""The controller process's command line (`robots._host.runner`), read by hand: what the referee
passes, in both option forms, and a clear error for anything else."""

import subprocess
import sys

import pytest

from robots._host.runner import options


def test_spec_and_limits():
    assert options(["ref:idle"]) == ("ref:idle", {}, {"--memory": 0, "--max-procs": 0})
    spec, text, limits = options(
        ["/team/a=b.py", "--memory", "1073741824", "--path=/team", "--max-procs", "64", "--join", "12,13"]
    )
    assert (spec, text) == ("/team/a=b.py", {"--path": "/team", "--join": "12,13"})
    assert limits == {"--memory": 1 << 30, "--max-procs": 64}
    assert options(["--memory", "5", "ref:idle"]) == ("ref:idle", {}, {"--memory": 5, "--max-procs": 0})


@pytest.mark.parametrize(
    "argv, words",
    [
        ([], "SPEC is missing"),
        (["ref:idle", "ref:best"], "unexpected argument 'ref:best'"),
        (["ref:idle", "--memory"], "--memory needs a value"),
        (["ref:idle", "--path"], "--path needs a value"),
        (["ref:idle", "--log-cap", "5"], "unexpected argument '--log-cap'"),
        (["ref:idle", "--memory", "lots"], "not a whole number: 'lots'"),
        (["ref:idle", "--cpu", "3"], "unexpected argument '--cpu'"),
    ],
)
def test_bad_command_lines(argv, words):
    with pytest.raises(SystemExit) as e:
        options(argv)
    assert words in str(e.value) and str(e.value).startswith("usage: python -m robots._host.runner SPEC")


def test_a_bad_command_line_exits_with_one_line_and_no_traceback():
    out = subprocess.run(
        [sys.executable, "-m", "robots._host.runner", "ref:idle", "--max-procs"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert out.returncode == 1
    assert "Traceback" not in out.stderr and "--max-procs needs a value" in out.stderr
