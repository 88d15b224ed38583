"""The voxel engine (gdabench/Walker-v2): Evolution Gym's physics, batched.

Parity numbers come from ``tests/fixtures/voxel_parity.npz``, recorded once from Evolution Gym 2.0
with ``benchmarks/compare/evogym_record.py`` (CI never needs Evolution Gym).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import gymnasium
import numba
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import gdabench
from gdabench import ConfigError, make_env
from gdabench.envs.voxel import engine
from gdabench.envs.voxel.batch import TaskBatch
from gdabench.running.runner import compare as run_experiment

FIXTURE = Path(__file__).parent / "fixtures" / "voxel_parity.npz"
CASES = ("falling-block", "lone-actuator", "standing", "walking", "folding", "unstable")
WALKER = "33333/40004/40004"
MIXED = ["11111/13331/40004/40004/40004", "33333/33333/33333/33333/33333", "44444/40000/44444/00004/44444",
         "22222/33333/30003/40004/40004", "00000/00000/00000/00000/34343", "10001/13331/13331/14441/10001"]


def replay(name: str, steps: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    data = np.load(FIXTURE)
    grid = np.array([[int(c) for c in row] for row in str(data[f"{name}.body"]).split("/")])
    at = tuple(int(v) for v in data[f"{name}.at"])
    tables = engine.body_tables([grid], dataclasses.replace(engine.WALKER_WORLD, robot_at=at))
    state = engine.reset(tables, np.array([0]))
    n = int(tables.n_points[0])
    assert np.array_equal(state.pos[0, :n], data[f"{name}.pos0"])  # same points, same order, same places
    pos, vel, unstable = [], [], []
    for action in data[f"{name}.actions"][:steps]:
        state, out = engine.step(tables, state, action[None])
        pos.append(state.pos[0, :n].copy())
        vel.append(state.vel[0, :n].copy())
        unstable.append(bool(out.unstable[0]))
    theirs = {k: data[f"{name}.{k}"][:steps] for k in ("pos", "vel", "unstable")}
    return np.array(pos), np.array(vel), np.array(unstable), theirs


@pytest.mark.parametrize("name", CASES)
def test_the_first_ten_steps_match_evolution_gym_to_1e6(name):
    pos, vel, unstable, theirs = replay(name, 10)
    assert np.abs(pos - theirs["pos"]).max() <= 1e-6
    assert np.abs(vel - theirs["vel"]).max() <= 1e-6 * max(1.0, np.abs(theirs["vel"]).max())
    assert np.array_equal(unstable, theirs["unstable"])


def test_longer_trajectories_stay_within_a_micrometre_of_evolution_gym():
    for name in CASES:
        pos, _, unstable, theirs = replay(name, 1000)
        assert len(pos) == len(theirs["pos"]) and np.array_equal(unstable, theirs["unstable"]), name
        assert np.abs(pos - theirs["pos"]).max() < 1e-6, name


def test_a_body_is_declared_unstable_at_the_step_evolution_gym_declares_it():
    pos, _, unstable, theirs = replay("unstable", 1000)
    assert np.flatnonzero(unstable).tolist() == [62] == np.flatnonzero(theirs["unstable"]).tolist()
    assert np.array_equal(pos[62], pos[61])  # the step is undone, as Evolution Gym keeps its last snapshot


def trajectories(tables: engine.BodyTables, body: np.ndarray, steps: int = 30) -> np.ndarray:
    state = engine.reset(tables, body)
    ours, others = np.random.default_rng(0), np.random.default_rng(1)
    out = []
    for _ in range(steps):
        actions = others.uniform(0.6, 1.6, size=(len(body), tables.max_actuators))
        actions[0, : tables.n_act[0]] = ours.uniform(0.6, 1.6, size=tables.n_act[0])  # the same in every batch
        state, _ = engine.step(tables, state, actions)
        out.append(state.pos.copy())
    return np.array(out)


def test_a_body_moves_bit_for_bit_the_same_alone_in_a_mixed_batch_and_padded_to_12x12():
    alone = trajectories(engine.body_tables([MIXED[0]]), np.array([0]))[:, 0]
    mixed = engine.body_tables(MIXED)
    body = np.array([0] + [1 + i % (len(MIXED) - 1) for i in range(63)])
    in_batch = trajectories(mixed, body)[:, 0]
    big = engine.body_tables(["/".join(["444444444444"] * 12)])
    padded = trajectories(engine.body_tables([MIXED[0]], pad=big), np.array([0]))[:, 0]
    n = alone.shape[1]
    assert np.array_equal(in_batch[:, :n], alone)
    assert padded.shape[1] >= 13 * 13 and np.array_equal(padded[:, :n], alone)
    assert not np.array_equal(alone[-1], alone[0])  # it did move


def test_the_thread_count_changes_nothing():
    tables = engine.body_tables(MIXED)
    body = np.arange(16) % len(MIXED)
    threads = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = trajectories(tables, body, steps=10)
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        many = trajectories(tables, body, steps=10)
    finally:
        numba.set_num_threads(threads)
    assert np.array_equal(one, many)


def test_step_is_pure():
    tables = engine.body_tables([WALKER])
    state = engine.reset(tables, np.array([0, 0]))
    before = state.pos.copy()
    new, _ = engine.step(tables, state, np.full((2, tables.max_actuators), 1.6))
    assert np.array_equal(state.pos, before) and not np.array_equal(new.pos, before)


def test_walker_v2_passes_gymnasiums_checker_and_plays_an_episode():
    env = gymnasium.make("gdabench/Walker-v2", body=WALKER)
    check_env(env.unwrapped, skip_render_check=True)
    obs, _ = env.reset()
    n_points = len(env.unwrapped.batch.tables.robots[0].pos)
    assert obs.shape == (2 + 2 * n_points,) and env.action_space.shape == (9,)
    steps, done = 0, False
    while not done:
        obs, reward, terminated, truncated, _ = env.step(env.action_space.sample())
        assert env.observation_space.contains(obs)
        steps, done = steps + 1, terminated or truncated
    assert steps == 500 and truncated
    frame = gymnasium.make("gdabench/Walker-v2", body=WALKER, render_mode="rgb_array")
    frame.reset()
    assert frame.render().shape == (240, 480, 3)


def test_the_vector_entry_point_steps_many_environments_of_one_body_in_one_call():
    envs = gymnasium.make_vec("gdabench/Walker-v2", num_envs=3, vectorization_mode="vector_entry_point", body=WALKER)
    single = gymnasium.make("gdabench/Walker-v2", body=WALKER)
    obs, _ = envs.reset()
    first, _ = single.reset()
    assert obs.shape == (3, first.shape[0]) and np.array_equal(obs[1], first)
    actions = np.linspace(0.7, 1.5, 3 * 9).reshape(3, 9)
    for _ in range(5):
        obs, reward, terminated, truncated, _ = envs.step(actions)
        expected, r, *_ = single.step(actions[2])
    assert np.array_equal(obs[2], expected) and reward[2] == r
    assert not (terminated.any() or truncated.any())


def test_a_batch_of_bodies_reports_each_bodys_own_observation_and_reward():
    batch = TaskBatch("Walker-v0", MIXED[:2], envs_per_body=2)
    obs = batch.reset()
    sizes = batch.obs_sizes
    assert obs.shape == (4, 2 + 2 * batch.tables.max_points)
    assert np.all(obs[0, sizes[0]:] == 0) and obs.shape[1] == sizes[1]
    obs, reward, terminated, unstable = batch.step(np.ones((4, batch.tables.max_actuators)))
    assert reward[0] == reward[1] and reward[2] == reward[3] and not terminated.any()


def test_walker_chooses_its_engine_and_records_it():
    assert make_env("walker").version == "gdabench/Walker-v2"
    assert make_env("walker", engine="pymunk").version == "gdabench/Walker-v1"
    with pytest.raises(ConfigError, match="engine must be one of voxel, pymunk"):
        make_env("walker", engine="bullet")


def test_a_run_on_the_voxel_walker_records_its_engine(tmp_path):
    experiment = gdabench.Experiment(
        designers=(gdabench.PluginChoice("random"),),
        envs=gdabench.PluginChoice("walker"),
        controller=gdabench.PluginChoice("open-loop", {"trials": 1}),
        shape=(3, 3), population=2, budget=2,
    )
    run = run_experiment(experiment, tmp_path / "run")
    rows = run.load_evaluations()
    assert set(rows["env_version"]) == {"gdabench/Walker-v2"} and rows["reward"].notna().all()


def test_import_registers_v2_without_loading_numba():
    import subprocess
    import sys

    code = ("import sys, gymnasium, gdabench; assert 'gdabench/Walker-v2' in gymnasium.registry; "
            "assert 'numba' not in sys.modules")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_resuming_a_run_scored_by_another_engine_refuses_to_mix_them(tmp_path):
    import json

    experiment = gdabench.Experiment(
        designers=(gdabench.PluginChoice("random"),), envs=gdabench.PluginChoice("walker"),
        controller=gdabench.PluginChoice("open-loop", {"trials": 1}), shape=(3, 3), population=2, budget=2,
    )
    run = run_experiment(experiment, tmp_path / "run")
    meta_path = run.path / "run.json"
    meta = json.loads(meta_path.read_text())
    meta["envs"]["walker"]["version"] = meta["env_version"] = "gdabench/Walker-v1"  # as a run made before v2
    meta_path.write_text(json.dumps(meta))
    before = (run.path / "evaluations.parquet").read_bytes()
    with pytest.raises(ConfigError, match="scored by gdabench/Walker-v1, but 'walker' now builds gdabench/Walker-v2"):
        run_experiment(dataclasses.replace(experiment, seeds=(0, 1)), run.path, resume=True)
    assert (run.path / "evaluations.parquet").read_bytes() == before
