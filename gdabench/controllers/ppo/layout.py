"""What each observation and action row of a body's policy stands for, and a child's policy made from its parent's.

``ppo[init=parent]`` starts a child's networks from its parent's trained ones.  Bodies differ, and so do
their observations and actions, so rows are matched by what they mean, not by their index:

* an **observation row** of a point mass (Evolution Gym's ``get_relative_pos_obs``: every x, then every y)
  is keyed by its axis and the lattice corner the point starts at (its voxel position; where two voxels
  touch only at a corner, each has its own point there, told apart by their order); the task's other
  rows (centre-of-mass velocity, orientation, terrain ahead...) by their place before or after the points;
* an **action row** is keyed by the voxel of its actuator.

:func:`inherit` copies the parent's weights wherever a key of the child's has a counterpart: the input
columns of both first layers (policy and value) and the observation statistics per observation row, the
action head's rows and the log standard deviation per action row, and every hidden layer whole.  Rows with
no counterpart keep the child's own fresh initialisation (as if trained from scratch).  A child equal to its
parent thus starts with the parent's exact policy.

Layouts are read from the voxel engine's environments (``voxel/<task>``, ``gdabench/Walker-v2``).  Any other
environment gets index keys (row ``i`` is row ``i``): a child inherits from a parent of the same sizes, the
others start from scratch.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np
import torch

from .networks import ActorCritic, _linears

#: a row's key: its kind, then what identifies it (e.g. ``("x", corner x, corner y)``, ``("voxel", row, column)``)
Key = tuple[Any, ...]
#: the voxel engine's lattice (metres per voxel): initial point positions / CELL are integer corners
CELL = 0.1


@dataclass(frozen=True)
class Layout:
    """Keys of a body's observation rows and action rows (JSON-able: saved with its policy)."""

    obs: tuple[Key, ...]
    act: tuple[Key, ...]

    def as_json(self) -> dict[str, list[list[Any]]]:
        return {"obs": [list(k) for k in self.obs], "act": [list(k) for k in self.act]}

    @classmethod
    def from_json(cls, data: dict[str, Sequence[Sequence[Any]]]) -> Layout:
        return cls(tuple(tuple(k) for k in data["obs"]), tuple(tuple(k) for k in data["act"]))


def indexed(n_obs: int, n_act: int) -> Layout:
    """Rows keyed by their index: what an environment that says nothing about its rows gets."""
    return Layout(tuple(("row", i) for i in range(n_obs)), tuple(("act", i) for i in range(n_act)))


def layout_of(env: Any) -> Layout:
    """The layout of a Gymnasium environment's body (see the module docstring)."""
    base = env.unwrapped
    n_obs, n_act = int(env.observation_space.shape[0]), int(env.action_space.shape[0])
    batch = getattr(base, "batch", None)
    if batch is None or not hasattr(batch, "tables") or not hasattr(batch, "task"):
        return indexed(n_obs, n_act)
    return _voxel_layout(batch, n_obs, n_act)


def point_block(batch: Any) -> tuple[int | None, int]:
    """Where a voxel-engine environment's observation holds the robot's relative point positions (the first
    row, None if its task has no such part) and the observation's length: found among its task's parts."""
    from ...envs.tasks import sense

    frame = batch.frame()
    mine = sense.robot_relative(frame)[0]
    start, width = None, 0
    for part in batch.task.observe(frame):
        array = np.asarray(part[0] if isinstance(part, tuple) else part).reshape(frame.n, -1)
        used = int(part[1][0]) if isinstance(part, tuple) else array.shape[1]
        if start is None and isinstance(part, tuple) and array.shape == mine.shape and np.array_equal(array, mine):
            start = width
        width += used
    return start, width


def _voxel_layout(batch: Any, n_obs: int, n_act: int) -> Layout:
    """A voxel-engine environment's layout: where its task puts the robot's relative positions among the
    observation's parts, and which voxel each actuator drives."""
    robot = batch.tables.robots[0]
    corners = np.rint(robot.pos / CELL).astype(np.int64)
    start, width = point_block(batch)
    points = len(corners)
    if start is None or width != n_obs:
        return indexed(n_obs, n_act)
    # two voxels that touch only at a corner have a point each there: the second is ("x", x, y, 1)
    seen: dict[tuple[int, int], int] = {}
    places = []
    for x, y in corners:
        place = (int(x), int(y))
        places.append((*place, seen.get(place, 0)))
        seen[place] = seen.get(place, 0) + 1
    obs: list[Key] = [("before", i) for i in range(start)]
    obs += [("x", *p) for p in places]
    obs += [("y", *p) for p in places]
    obs += [("after", i) for i in range(n_obs - start - 2 * points)]
    cells = robot.boxel_cell[robot.actuators]  # (x, y) in the body's grid, y = 0 the top row
    act = tuple(("voxel", int(y), int(x)) for x, y in cells)
    if len(act) != n_act:
        return indexed(n_obs, n_act)
    return Layout(tuple(obs), act)


def _matches(child: Sequence[Key], parent: Sequence[Key]) -> tuple[list[int], list[int]]:
    """(child rows, parent rows) with equal keys."""
    where = {k: i for i, k in enumerate(parent)}
    pairs = [(c, where[k]) for c, k in enumerate(child) if k in where]
    return [c for c, _ in pairs], [p for _, p in pairs]


@torch.no_grad()
def inherit(child: ActorCritic, child_layout: Layout, parent: ActorCritic, parent_layout: Layout) -> ActorCritic:
    """``child`` (freshly initialised) with every row that has a counterpart in ``parent`` copied from it (see the
    module docstring); changed in place and returned."""
    if child.hidden != parent.hidden:
        raise ValueError(f"the parent's hidden layers {parent.hidden} differ from the child's {child.hidden}")
    if (len(child_layout.obs), len(child_layout.act)) != (child.n_obs, child.n_act) or (
        len(parent_layout.obs), len(parent_layout.act)
    ) != (parent.n_obs, parent.n_act):
        raise ValueError("a layout does not match its networks' sizes")
    obs_c, obs_p = _matches(child_layout.obs, parent_layout.obs)
    act_c, act_p = _matches(child_layout.act, parent_layout.act)
    for net_c, net_p, head in ((child.mean, parent.mean, True), (child.value, parent.value, False)):
        first, *middle, last = zip(_linears(net_c), _linears(net_p))  # hidden layers are never empty
        first[0].weight[:, obs_c] = first[1].weight[:, obs_p]  # input columns by observation row
        first[0].bias.copy_(first[1].bias)
        for mine, theirs in middle:
            mine.weight.copy_(theirs.weight)
            mine.bias.copy_(theirs.bias)
        if head:  # the action head: output rows by actuator
            last[0].weight[act_c] = last[1].weight[act_p]
            last[0].bias[act_c] = last[1].bias[act_p]
        else:
            last[0].weight.copy_(last[1].weight)
            last[0].bias.copy_(last[1].bias)
    child.log_std[act_c] = parent.log_std[act_p]
    child.obs_mean[obs_c] = parent.obs_mean[obs_p]
    child.obs_var[obs_c] = parent.obs_var[obs_p]
    child.obs_count.copy_(parent.obs_count)
    return child
