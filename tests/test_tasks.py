"""Evolution Gym's tasks on the voxel engine (``voxel/<task>``): parity with Evolution Gym 2.0, per task.

Parity numbers come from ``tests/fixtures/tasks/<task>.npz``, recorded from Evolution Gym 2.0's own
Gymnasium environments with ``benchmarks/evogym_record.py tests/fixtures/tasks --tasks`` (CI never needs
Evolution Gym): for every task and two bodies, the first steps of an episode under a fixed gait.
"""

from __future__ import annotations

from dataclasses import replace
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
    if name in batch.world.names:
        start, count = batch.frame().objects[name]
        return batch.state.pos[0, start:start + count]
    return batch.world.static[batch.world.static_names.index(name)].pos


def replay(key: str) -> dict[str, list[float]]:
    """Play recording ``key`` on the voxel engine; the largest gaps to Evolution Gym's numbers, per step."""
    task = key.split("/")[0]
    data = {k.removeprefix(key + "/"): v for k, v in np.load(FIXTURES / f"{task}.npz").items()
            if k.startswith(key + "/")}
    batch = TaskBatch(task, [str(data["body"])])
    batch.seed([0])
    size = batch.obs_sizes[0]
    obs = batch.reset()[0, :size]
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


# -- how episodes end: the fixtures' first steps never reach an end, so each is checked on a step set up to --
WALKER = "11111/13331/40004/40004/40004"


def moved(task: str, centre: tuple[float | None, float | None] = (None, None), turn: float = 0.0):
    """Task ``task``'s reward and end for a step that turns its robot by ``turn`` (radians, counter-clockwise)
    about its centre and puts that centre at ``centre`` (metres; None keeps a coordinate)."""
    batch = TaskBatch(task, [WALKER])
    before = batch.frame()
    start, count = batch.tables.robot_start, batch.robot_points[0]
    pos = before.pos.copy()
    points = pos[0, start:start + count]
    c = points.mean(axis=0)
    to = np.array([c[k] if centre[k] is None else centre[k] for k in (0, 1)])
    rotation = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
    pos[0, start:start + count] = (points - c) @ rotation.T + to
    reward, done = batch.task.reward(before, replace(before, pos=pos), np.zeros(1, dtype=bool))
    return float(reward[0]), bool(done[0]), to - c


#: (task, finishing line or None, its axis, its bonus)
LINES = [("UpStepper-v0", 6.9, 0, 2.0), ("DownStepper-v0", 7.4, 0, 2.0), ("ObstacleTraverser-v0", 7.9, 0, 2.0),
         ("ObstacleTraverser-v1", 5.9, 0, 2.0), ("Traverser-v0", 5.9, 0, 2.0), ("Hurdler-v0", None, 0, 0.0),
         ("PlatformJumper-v0", None, 0, 0.0), ("GapJumper-v0", None, 0, 0.0), ("Climber-v0", 8.6, 1, 1.0),
         ("Climber-v1", 6.5, 1, 1.0), ("Climber-v2", None, 1, 0.0)]


@pytest.mark.parametrize("task,line,axis,bonus", LINES)
def test_crossing_the_finishing_line_ends_the_episode_with_its_bonus(task, line, axis, bonus):
    for at, past in ((line or 9.0) - 0.01, False), ((line or 9.0) + 0.01, line is not None):
        centre = (at, None) if axis == 0 else (None, at)
        reward, done, shift = moved(task, centre)
        gain = shift[axis] + (0.2 * shift[0] if task == "Climber-v2" else 0.0)
        assert done == past
        assert reward == pytest.approx(gain + (bonus if past else 0.0), abs=1e-9)


@pytest.mark.parametrize("task", ["PlatformJumper-v0", "GapJumper-v0"])
def test_falling_below_the_lowest_platform_ends_the_episode_with_a_penalty(task):
    assert moved(task, (None, 0.41))[:2] == (pytest.approx(0.0, abs=1e-9), False)
    assert moved(task, (None, 0.39))[:2] == (pytest.approx(-3.0, abs=1e-9), True)


TURNERS = {"UpStepper-v0", "DownStepper-v0", "ObstacleTraverser-v0", "Hurdler-v0", "PlatformJumper-v0"}


@pytest.mark.parametrize("task", [line[0] for line in LINES])
def test_turning_over_ends_the_terrain_tasks_that_check_it_with_a_penalty(task):
    upside_down = moved(task, turn=np.pi)[:2]
    assert upside_down == ((pytest.approx(-3.0, abs=1e-9), True) if task in TURNERS else
                           (pytest.approx(0.0, abs=1e-9), False))
    # UpStepper-v0's band is pi / 12 wider on either side: 80 degrees ends it, no other
    assert moved(task, turn=np.radians(80))[1] == (task == "UpStepper-v0")
    assert moved(task, turn=np.radians(280))[1] == (task == "UpStepper-v0")
    assert not moved(task, turn=np.radians(70))[1]
