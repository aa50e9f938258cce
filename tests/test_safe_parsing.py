"""Hostile files (levels, replays) are refused in one line with bounded memory: YAML aliases
and deep nesting are refused, sizes are capped, a replay header has a typed schema."""

import gzip
import json
import subprocess
import sys

import pytest
from helpers import MINI_LEVEL, run_cli

BOMB = "".join(
    [
        "name: bomb\n",
        'a: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]\n',
        *(f"{b}: &{b} [{', '.join([f'*{a}'] * 9)}]\n" for a, b in zip("abcdefgh", "bcdefghi")),
    ]
)  # 9^9 = 387 million strings once expanded


def measured(*args: str) -> tuple[int, str, int]:
    """Run `laserarena ARGS` from a fresh parent: (exit code, stderr, the peak RSS in KiB of
    that run alone, from getrusage of the parent's only child)."""
    probe = (
        "import resource, subprocess, sys\n"
        "p = subprocess.run([sys.executable, '-m', 'referee', *sys.argv[1:]], capture_output=True, "
        "text=True, timeout=300)\n"
        "sys.stderr.write(p.stderr)\n"
        "print(p.returncode, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)\n"
    )
    proc = subprocess.run([sys.executable, "-c", probe, *args], capture_output=True, text=True, timeout=320)
    code, rss = map(int, proc.stdout.split())
    return code, proc.stderr, rss


def one_line(stderr: str, *words: str) -> None:
    assert stderr.count("\n") == 1 and "Traceback" not in stderr, stderr
    assert all(w in stderr for w in words), stderr


def test_an_alias_bomb_level_fails_fast_in_one_line_with_bounded_memory(write_level):
    good = write_level(MINI_LEVEL, "good.yaml")
    bomb = write_level(BOMB, "bomb.yaml")
    code, _, normal = measured("check", str(good))
    assert code == 0
    code, err, rss = measured("check", str(bomb))
    assert code == 2
    one_line(err, "bomb.yaml:3", "aliases")
    assert rss < normal + 50 * 1024  # what checking a normal level takes, give or take 50 MiB


def test_deep_and_huge_levels_are_refused_in_one_line(write_level):
    deep = write_level("a: " + "[" * 50_000 + "]" * 50_000 + "\n", "deep.yaml")
    proc = run_cli("check", str(deep))
    assert proc.returncode == 2
    one_line(proc.stderr, "deep.yaml:1", "nested deeper")
    huge = write_level(MINI_LEVEL + "#" * (2 << 20) + "\n", "huge.yaml")
    proc = run_cli("check", str(huge))
    assert proc.returncode == 2
    one_line(proc.stderr, "huge.yaml", "at most")


@pytest.fixture(scope="module")
def replay_lines(tmp_path_factory) -> list[bytes]:
    """The lines of a real replay (a short match)."""
    path = tmp_path_factory.mktemp("replay") / "real.replay"
    proc = run_cli("run", "bac-line", "--team", "ref:bac", "--seed", "1", "--replay", str(path), "--quiet")
    assert proc.returncode == 0, proc.stderr
    return gzip.open(path).read().splitlines(keepends=True)


def forged(tmp_path, lines: list[bytes], name: str = "forged.replay"):
    path = tmp_path / name
    with gzip.open(path, "wb") as f:
        f.writelines(lines)
    return str(path)


def with_header(lines: list[bytes], **changes) -> list[bytes]:
    header = json.loads(lines[0])
    header.update(changes)
    return [json.dumps(header).encode() + b"\n", *lines[1:]]


def test_an_alias_bomb_in_a_replay_header_is_refused_by_verify_and_render(tmp_path, replay_lines):
    header = json.loads(replay_lines[0])
    path = forged(tmp_path, with_header(replay_lines, level={**header["level"], "text": BOMB}))
    code, err, rss = measured("verify", path)
    assert code == 2
    one_line(err, "aliases")
    code, err, _ = measured("render", path, "--out", str(tmp_path / "o.mp4"))
    assert code == 2
    one_line(err, "aliases")
    real = forged(tmp_path, replay_lines, "real.replay")
    code, _, normal = measured("verify", real)  # the same modules, and a whole match
    assert code == 0 and rss < normal + 50 * 1024


@pytest.mark.parametrize(
    "damage, words",
    [
        (lambda lines: [b"[" * 100_000 + b"]" * 100_000 + b"\n", *lines[1:]], "nested too deeply"),
        (lambda lines: [b"[1, 2]\n", *lines[1:]], "not an object"),
        (lambda lines: with_header(lines, teams="ref:bac"), "teams"),
        (lambda lines: with_header(lines, seed=10**30), "seed"),
        (lambda lines: with_header(lines, noise_key="not hex"), "noise_key"),
        (
            lambda lines: [lines[0], b'{"k":"f","t":0.0,"p":' + b"[" * 10_000 + b"]" * 10_000 + b"}\n"],
            "nested too deeply",
        ),
        (lambda lines: [lines[0], b'{"k":"f","t":"x","p":[]}\n'], "frame"),
        (lambda lines: [*lines[:2], b'{"k":"trial","n":1}\n', *lines[2:]], "trial"),
        (lambda lines: [lines[0], b'"' + b"x" * (9 << 20) + b'"\n'], "over"),
    ],
)
def test_a_damaged_replay_is_one_line(tmp_path, replay_lines, damage, words):
    path = forged(tmp_path, damage(replay_lines))
    for args in (["verify", path], ["render", path, "--out", str(tmp_path / "frames")]):
        proc = run_cli(*args)
        assert proc.returncode == 2
        one_line(proc.stderr, words)


def test_an_untouched_replay_still_verifies(tmp_path, replay_lines):
    proc = run_cli("verify", forged(tmp_path, replay_lines))
    assert proc.returncode == 0 and "identical" in proc.stdout
