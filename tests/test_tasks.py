"""Evolution Gym's tasks on the voxel engine (``voxel/<task>``): parity with Evolution Gym 2.0, per task.

Parity numbers come from ``tests/fixtures/tasks/<task>.npz``, recorded from Evolution Gym 2.0's own
Gymnasium environments with ``benchmarks/evogym_record.py tests/fixtures/tasks --tasks`` (CI never needs
Evolution Gym): for every task and two bodies, the first steps of an episode under a fixed gait.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gdabench.envs.tasks import CATALOG, task
from gdabench.envs.tasks.sense import Frame
from gdabench.envs.tasks.shape import hull_area
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
    defined = set()
    for name in CATALOG:
        try:
            task(name)
        except KeyError:
            continue
        defined.add(name)
    assert recorded == defined
    assert all(f"{name}/1" in RECORDINGS for name in recorded)


def one_robot(points: np.ndarray, init: np.ndarray | None = None) -> Frame:
    """A frame of one environment whose robot is ``points`` (``(P, 2)``, metres), started at ``init``."""
    pos = np.asarray(points, dtype=np.float64)[None]
    return Frame(pos=pos, vel=np.zeros_like(pos), init=pos if init is None else np.asarray(init)[None],
                 robot_start=0, robot_count=np.array([len(points)]), objects={}, static={})


def test_the_shape_tasks_hull_keeps_evolution_gyms_choice_among_points_in_line():
    # a 1 x 2 body's six points in two orders: Evolution Gym's march (ShapeBase.jarvis_march, then
    # convex_poly_area) keeps different points of the edges in line, and its areas differ in the last bit
    points = np.array([[0.7, 0.2], [0.7999999999999999, 0.30000000000000004], [0.7999999999999999, 0.2],
                       [0.7, 0.1], [0.7999999999999999, 0.1], [0.7, 0.30000000000000004]])
    assert hull_area(one_robot(points), "robot")[0] == 0.019999999999999997
    assert hull_area(one_robot(points[[3, 4, 2, 1, 5, 0]]), "robot")[0] == 0.020000000000000004


def test_the_shape_tasks_hull_where_evolution_gyms_march_never_closes():
    # Evolution Gym's march walks back and forth along the bottom row of these 1 x 3 grid points and raises
    # IndexError; the true hull's area stands in
    points = np.array([[1.0, 0.2], [0.7999999999999999, 0.2], [0.7, 0.2], [0.7999999999999999, 0.1], [0.9, 0.2],
                       [0.9, 0.1], [0.7, 0.1], [1.0, 0.1]])
    assert hull_area(one_robot(points), "robot")[0] == pytest.approx(0.03, abs=1e-15)


@pytest.mark.parametrize("turn", [0.4, -0.4])
def test_flipper_counts_its_turns_on_over_whole_turns(turn):
    start = np.array([[x, y] for y in (0.1, 0.2) for x in (3.0, 3.1, 3.2)])  # none at the centre
    centre = start.mean(axis=0)

    def turned(angle: float) -> Frame:
        c, s = np.cos(angle), np.sin(angle)
        return one_robot(centre + (start - centre) @ np.array([[c, s], [-s, c]]), init=start)

    flipper = task("Flipper-v0")(np.array([len(start)]))
    flipper.reset(turned(0.0), np.array([True]), [])
    total = 0.0
    for k in range(40):  # 16 radians: two whole turns and a half
        reward, done = flipper.reward(turned(k * turn), turned((k + 1) * turn), np.array([False]))
        total += reward[0]
        assert not done[0]
    # to within the orientation's noise near a whole turn (Evolution Gym clamps a cosine above 1 to 0.99999)
    assert total == pytest.approx(40 * turn, abs=0.01)
    assert flipper.flips[0] == (2 if turn > 0 else -3)
    flipper.reset(turned(0.0), np.array([True]), [])
    assert flipper.flips[0] == 0
