"""Evolution Gym's tasks on the voxel engine (``voxel/<task>``): parity with Evolution Gym 2.0, per task.

Parity numbers come from ``tests/fixtures/tasks/<task>.npz``, recorded from Evolution Gym 2.0's own
Gymnasium environments with ``benchmarks/evogym_record.py tests/fixtures/tasks --tasks`` (CI never needs
Evolution Gym): for every task and two bodies, the first steps of an episode under a fixed gait.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gdabench.envs.tasks import CATALOG
from gdabench.envs.voxel.batch import TaskBatch

FIXTURES = Path(__file__).parent / "fixtures" / "tasks"
RECORDINGS = sorted({"/".join(k.split("/")[:2]) for f in FIXTURES.glob("*.npz") for k in np.load(f)})
#: the bar: agreement with Evolution Gym over the first ten env steps, in double precision
TOLERANCE, STEPS = 1e-6, 10


def object_points(batch: TaskBatch, name: str) -> np.ndarray:
    """Object ``name``'s points in environment 0, as Evolution Gym's ``object_pos_at_time`` gives them."""
    if name == "robot":
        start = batch.tables.robot_start
        return batch.state.pos[0, start:start + batch.robot_points[0]]
    return batch.frame().positions(name)[0]


def replay(key: str) -> dict[str, list[float]]:
    """Play recording ``key`` on the voxel engine; the largest gaps to Evolution Gym's numbers, per step."""
    task = key.split("/")[0]
    data = {k.removeprefix(key + "/"): v for k, v in np.load(FIXTURES / f"{task}.npz").items()
            if k.startswith(key + "/")}
    batch = TaskBatch(task, [str(data["body"])])
    batch.seed([0])
    size = batch.obs_sizes[0]
    setup = {k: data[k].tolist() for k in ("offset", "goals") if k in data}  # Evolution Gym's random draw
    obs = batch.reset(options=setup)[0, :size]
    gaps = {"start": [float(np.abs(obs - data["obs0"]).max())] + [
        float(np.abs(object_points(batch, k.removeprefix("pos0/")) - v).max())
        for k, v in data.items() if k.startswith("pos0/")]}
    gaps |= {"pos": [], "obs": [], "reward": [], "done": []}
    for t, action in enumerate(data["actions"]):
        obs, reward, terminated, _ = batch.step(action[None])
        gaps["pos"].append(max(float(np.abs(object_points(batch, str(m)) - data[f"pos/{m}"][t]).max())
                               for m in data["moving"]))
        gaps["obs"].append(float(np.abs(obs[0, :size] - data["obs"][t]).max()))
        gaps["reward"].append(abs(float(reward[0]) - float(data["reward"][t])))
        gaps["done"].append(float(bool(terminated[0]) != bool(data["done"][t])))
    return gaps


@pytest.mark.parametrize("key", RECORDINGS)
def test_the_first_ten_steps_match_evolution_gym_to_1e6(key):
    gaps = replay(key)
    assert max(gaps["start"]) <= TOLERANCE, "the first observation, or where objects start"
    for what in ("pos", "obs", "reward", "done"):
        assert max(gaps[what][:STEPS]) <= TOLERANCE, what


def test_the_fixture_records_two_bodies_of_every_task_defined_here():
    recorded = {key.split("/")[0] for key in RECORDINGS}
    from gdabench.envs.tasks import task

    defined = set()
    for name in CATALOG:
        try:
            task(name)
        except KeyError:
            continue
        defined.add(name)
    assert recorded == defined
    assert all(f"{name}/1" in RECORDINGS for name in recorded)


WALKER = "11111/13331/40004/40004/40004"


def setup_of(env) -> tuple:
    """The random set-up an environment drew: Catcher-v0's offset and package, BidirectionalWalker-v0's goals."""
    task = env.unwrapped.batch.task
    if hasattr(task, "offset"):
        return tuple(task.offset[0]), tuple(object_points(env.unwrapped.batch, "package").ravel())
    return tuple(task.goals[0, : task.n_goals[0]])


@pytest.mark.parametrize("name", ["Catcher-v0", "BidirectionalWalker-v0"])
def test_reset_seed_draws_the_random_setup_the_same_seed_the_same(name):
    import gymnasium

    env = gymnasium.make(f"voxel/{name}", body=WALKER)
    drawn = []
    for seed in (0, 0, 1, 2, 3):
        env.reset(seed=seed)
        drawn.append(setup_of(env))
    assert drawn[0] == drawn[1]
    assert len(set(drawn[1:])) == 4
    vec = gymnasium.make_vec(f"voxel/{name}", num_envs=3, vectorization_mode="vector_entry_point", body=WALKER)
    first, _ = vec.reset(seed=7)
    again, _ = vec.reset(seed=7)
    np.testing.assert_array_equal(first, again)
    assert len({tuple(row) for row in first}) == 3  # each environment its own draw


def test_reset_options_impose_a_setup_and_reject_what_a_task_cannot_take():
    import gymnasium

    catcher = gymnasium.make("voxel/Catcher-v0", body=WALKER)
    catcher.reset(seed=0, options={"offset": (-6, 5)})
    # Evolution Gym puts the package at voxel (21 + dx, 41 + dy): its bottom-left point there
    assert object_points(catcher.unwrapped.batch, "package").min(axis=0) == pytest.approx([1.5, 4.6])
    walker = gymnasium.make("voxel/BidirectionalWalker-v0", body=WALKER)
    obs, _ = walker.reset(options={"goals": [20, 49]})
    assert obs[-2] == pytest.approx(2.0)
    with pytest.raises(ValueError, match=r"offset must be two whole numbers \(dx, dy\) in -6..4 and 0..5"):
        catcher.reset(options={"offset": (5, 0)})
    with pytest.raises(ValueError, match="goals must be a non-empty list"):
        walker.reset(options={"goals": []})
    with pytest.raises(ValueError, match=r"Walker-v0 has no reset option 'goals' \(its options: none\)"):
        gymnasium.make("voxel/Walker-v0", body=WALKER).reset(options={"goals": [30]})


def test_bidirectional_walker_meets_goals_as_evolution_gym_does():
    batch = TaskBatch("BidirectionalWalker-v0", [WALKER])
    batch.reset(options={"goals": [36, 34, 45, 35]})  # the robot's centre starts at x 3.55 m
    x1 = float(batch.frame().pos[0, batch.tables.robot_start:].mean(axis=0)[0])
    obs, reward, done, _ = batch.step(np.ones((1, 9)))
    x2 = float(batch.frame().pos[0, batch.tables.robot_start:].mean(axis=0)[0])
    # the first two goals are met at once: the step is rewarded for the third, the observation still shows
    # the first (it is made before the goals move on), the next one the third
    assert batch.task.current[0] == 2
    assert reward[0] == pytest.approx(abs(4.5 - x1) - abs(4.5 - x2), abs=1e-12)
    assert obs[0, 62:65].tolist() == pytest.approx([0, 3.6, 3.6 - x2])
    obs, _, _, _ = batch.step(np.ones((1, 9)))
    assert obs[0, 62:64].tolist() == pytest.approx([2, 4.5])
    assert not done[0]


def test_an_autoreset_episode_starts_at_its_first_goal():
    import gymnasium

    vec = gymnasium.make_vec("voxel/BidirectionalWalker-v0", num_envs=1, vectorization_mode="vector_entry_point",
                             body=WALKER, max_episode_steps=1)
    task = vec.unwrapped.batch.task
    for seed in range(40):  # a seed whose second episode's first goal is met where the robot starts
        vec.reset(seed=seed)
        vec.step(np.ones((1, 9)))
        obs, reward, _, _, _ = vec.step(np.ones((1, 9)))  # the autoreset
        if abs(task.goals[0, 0] * 0.1 - 3.55) < 0.2:
            break
    else:
        pytest.fail("no seed drew a first goal by the robot")
    assert task.current[0] == 0 and obs[0, 62] == 0 and reward[0] == 0
