"""Evolution Gym's multi-goal task (``evogym/envs/multi_goal.py``): BidirectionalWalker-v0.

The robot walks to a list of goals, one at a time: each step is rewarded with how much closer in x it came
to the current goal, and a goal is met once the robot's centre is less than 2 voxels from it.  Meeting the
last one adds 1 and ends the episode.
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np

from . import sense
from .base import Part, Task, finish
from .sense import VOXEL, Frame


class BidirectionalWalkerV0(Task):
    """Walk to goals drawn at random on either side.

    Evolution Gym draws the goals (x in voxels, 20..49) from Python's global ``random``, which
    ``reset(seed=...)`` does not seed, until they lie 100 voxels apart in all, starting from x 35.  Here each
    environment draws its goals the same way from its own generator (seeded by Gymnasium's
    ``reset(seed=...)`` or ``TaskBatch.seed``); ``reset(options={"goals": [x, ...]})`` imposes a list.
    Environments hold different numbers of goals (``goals`` is padded with NaN beyond ``n_goals``).
    """

    id, world, robot_at = "BidirectionalWalker-v0", "BidirectionalWalker-v0", (33, 1)
    reset_options = ("goals",)
    #: Evolution Gym's ``set_random_goals(20, 50, 100)`` from x 35 (voxels)
    start, low, high, distance = 35, 20, 50, 100
    #: a goal is met within this distance (metres)
    near = 2 * VOXEL

    def __init__(self, robot_points: np.ndarray):
        super().__init__(robot_points)
        self.goals = np.full((self.n, 1), np.nan)
        self.n_goals = np.zeros(self.n, dtype=np.int64)
        self.current = np.zeros(self.n, dtype=np.int64)
        #: the goal the last observation shows: the step's observation is made before the goals move on
        self.shown = np.zeros(self.n, dtype=np.int64)

    @classmethod
    def obs_size(cls, robot_points: int) -> int:
        return 5 + 2 * robot_points

    def draw(self, rng: np.random.Generator) -> list[int]:
        """``set_random_goals``: goals until the path through them is ``distance`` voxels long."""
        at, walked, goals = self.start, 0, []
        while walked < self.distance:
            goal = int(rng.integers(self.low, self.high))
            walked += abs(at - goal)
            at = goal
            goals.append(goal)
        return goals

    def reset(self, frame: Frame, mask: np.ndarray, rng: Sequence[np.random.Generator],
              options: Mapping[str, Any] | None = None) -> None:
        imposed = (options or {}).get("goals")
        rows = np.flatnonzero(mask).tolist()
        lists = [self.checked_goals(imposed) if imposed is not None else self.draw(rng[i]) for i in rows]
        width = max([self.goals.shape[1], *map(len, lists)])
        if width > self.goals.shape[1]:
            self.goals = np.pad(self.goals, ((0, 0), (0, width - self.goals.shape[1])), constant_values=np.nan)
        for i, goals in zip(rows, lists):
            self.goals[i] = np.nan
            self.goals[i, :len(goals)] = goals
            self.n_goals[i] = len(goals)
        self.current[mask] = 0
        self.shown[mask] = 0

    def checked_goals(self, goals: Any) -> list[float]:
        """``goals`` as a non-empty list of finite x positions (voxels), or a one-line ValueError."""
        try:
            values = np.asarray(goals, dtype=float)
        except (TypeError, ValueError):
            values = np.zeros((0, 0))
        if values.ndim != 1 or len(values) == 0 or not np.isfinite(values).all():
            raise ValueError(f"{self.id}'s goals must be a non-empty list of x positions in voxels, got {goals!r}")
        return values.tolist()

    def target(self, goal: np.ndarray) -> np.ndarray:
        """Goal ``goal[i]`` of each environment, in metres (the last one past the end: Evolution Gym's
        ``get_obs`` fails there, which only a step after the episode ended reaches, and those are not taken)."""
        index = np.minimum(goal, self.n_goals - 1)
        return self.goals[np.arange(self.n), index] * 0.1

    def observe(self, frame: Frame) -> list[Part]:
        target = self.target(self.shown)
        x = sense.com(frame, "robot")[:, 0]
        return [sense.vel_com(frame, "robot"),
                sense.robot_relative(frame),
                self.shown.astype(float), target, target - x]

    def reward(self, before: Frame, after: Frame, unstable: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x1, x2 = sense.com(before, "robot")[:, 0], sense.com(after, "robot")[:, 0]
        self.shown = self.current.copy()
        reward = np.zeros(self.n)
        # GoalBase.get_reward: evaluate the current goal; once met, the next one is evaluated on the same
        # step and its reward replaces the met goal's (Evolution Gym's quirk: the step's reward is that of
        # the first goal not met, or of the last goal)
        pending = self.current < self.n_goals
        while pending.any():
            target = self.target(self.current)
            reward = np.where(pending, np.abs(target - x1) - np.abs(target - x2), reward)
            met = pending & (np.abs(target - x2) < self.near)
            self.current += met
            pending = met & (self.current < self.n_goals)
        return finish(reward, unstable, self.current == self.n_goals)


DEFINED = (BidirectionalWalkerV0,)
