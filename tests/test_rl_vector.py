"""Vector envs over LaserArena-v0: `gymnasium.make_vec` in every mode (its own in-process
vector env, sync, async) steps, resets the episodes that end, gives the single env's numbers,
and closes without leaving a process; the in-process one plays what Gymnasium's sync one does.
Every wait on a worker is bounded. Needs the `rl` extra (installed by `make test`)."""

import multiprocessing
import threading

import numpy as np
import pytest
import yaml

gymnasium = pytest.importorskip("gymnasium", reason="the rl extra is not installed: pip install '.[rl]'")

import levels  # noqa: E402
import referee.gym  # noqa: E402  (registers LaserArena-v0)
from levels.loader import load_level  # noqa: E402

WAIT = 120  # s: the most any one reset or step of a worker may take


@pytest.fixture(params=["path", "level"])
def short_level(request, tmp_path):
    """bac-line cut to 1 s (5 control periods), named by its file's path or loaded (a Level
    pickles whole to an async vector env's workers)."""
    d = yaml.safe_load(levels.path("bac-line").read_text())
    d["time_limit"] = 1.0
    path = tmp_path / "bac-line-1s.yaml"
    path.write_text(yaml.safe_dump(d))
    return str(path) if request.param == "path" else load_level(path)


def play(envs, steps: int) -> list[tuple]:
    """Reset with seeds 3 and 4, then `steps` steps of fixed actions; every outcome, waits bounded."""
    actions = np.array([[0.5, 0.6], [0.7, 0.4]], dtype=np.float32)
    if isinstance(envs, gymnasium.vector.AsyncVectorEnv):
        envs.reset_async(seed=[3, 4])
        outcomes = [envs.reset_wait(timeout=WAIT)]
        for _ in range(steps):
            envs.step_async(actions)
            outcomes.append(envs.step_wait(timeout=WAIT))
        return outcomes
    return [envs.reset(seed=[3, 4])] + [envs.step(actions) for _ in range(steps)]


def close_within(envs, seconds: float) -> None:
    """Close the vector env, failing (its workers killed) if that takes over `seconds`: Gymnasium's
    own close waits for every worker without a bound."""
    closing = threading.Thread(target=envs.close, daemon=True)
    closing.start()
    closing.join(seconds)
    if closing.is_alive():
        for process in getattr(envs, "processes", []):
            process.kill()
        pytest.fail(f"closing the vector env took over {seconds} s")


@pytest.mark.parametrize("mode", ["vector_entry_point", "sync", "async"])
def test_make_vec_steps_resets_and_closes(mode, short_level):
    before = set(multiprocessing.active_children())
    envs = gymnasium.make_vec(referee.gym.ENV_ID, num_envs=2, vectorization_mode=mode, level=short_level)
    assert envs.num_envs == 2 and envs.observation_space.shape == (2, *envs.single_observation_space.shape)
    try:
        outcomes = play(envs, 7)  # 5 periods, the step that resets both, and one of the next episodes
    finally:
        close_within(envs, WAIT)
    _, _, terminated, truncated, info = outcomes[5]
    assert not terminated.any() and truncated.all()  # the time limit, for both at once
    assert [r["seed"] for r in info["result"]] == [3, 4]  # each env's own match
    for _, _, terminated, truncated, _ in outcomes[6:]:  # the next episodes run on
        assert not (terminated.any() or truncated.any())
    # each env of the vector plays the single env's episode, number for number
    single = gymnasium.make(referee.gym.ENV_ID, level=short_level)
    for k, seed in enumerate([3, 4]):
        obs, _ = single.reset(seed=seed)
        assert np.array_equal(obs, outcomes[0][0][k])
        for step in range(1, 6):
            obs, reward, *_ = single.step(np.array([[0.5, 0.6], [0.7, 0.4]][k], dtype=np.float32))
            assert np.array_equal(obs, outcomes[step][0][k]) and reward == outcomes[step][1][k]
    single.close()
    if mode == "async":
        assert all(p.exitcode == 0 for p in envs.processes)
    assert set(multiprocessing.active_children()) <= before  # nothing left running


def test_the_default_vector_env_is_the_in_process_one():
    envs = gymnasium.make_vec(referee.gym.ENV_ID, num_envs=2, level="bac-line")
    try:
        assert type(envs.unwrapped).__name__ == "LaserArenaVectorEnv"
        assert envs.metadata["autoreset_mode"] == gymnasium.vector.AutoresetMode.NEXT_STEP
    finally:
        envs.close()


@pytest.mark.parametrize("seed", [None, 11])
def test_the_in_process_vector_env_plays_as_gymnasiums_sync_one(seed, tmp_path):
    """Over several episodes each (ended ones reset from each env's own generator, seeded
    `seed + i`), the in-process vector env and Gymnasium's SyncVectorEnv over the one-robot
    env give the same observations, rewards, flags and match seeds, step for step."""
    d = yaml.safe_load(levels.path("bac-line").read_text())
    d["time_limit"] = 0.6  # 3 control periods: 12 steps cross three resets
    path = tmp_path / "short.yaml"
    path.write_text(yaml.safe_dump(d))
    level = load_level(path)
    rng = np.random.default_rng(5)
    actions = rng.uniform(-1, 1, (12, 3, 2)).astype(np.float32)
    runs = []
    for mode in ("vector_entry_point", "sync"):
        envs = gymnasium.make_vec(referee.gym.ENV_ID, num_envs=3, vectorization_mode=mode, level=level)
        first = envs.reset(seed=seed if seed is not None else [7, 8, 9])
        outcomes = [first] + [envs.step(a) for a in actions]
        envs.close()
        runs.append(outcomes)
    (obs_a, info_a), (obs_b, info_b) = runs[0][0], runs[1][0]
    assert np.array_equal(obs_a, obs_b) and list(info_a["seed"]) == list(info_b["seed"])
    resets = 0
    for a, b in zip(runs[0][1:], runs[1][1:]):
        for x, y in zip(a[:4], b[:4]):
            assert np.array_equal(x, y)
        if "seed" in b[4]:  # an env reset at this step: the same next match
            resets += int(b[4]["_seed"].sum())
            assert np.array_equal(a[4]["_seed"], b[4]["_seed"])
            assert list(a[4]["seed"][a[4]["_seed"]]) == list(b[4]["seed"][b[4]["_seed"]])
    assert resets >= 6  # every env went through at least two resets
