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

