"""Evolution Gym's climbing tasks (``evogym/envs/climb.py``): Climber-v0, Climber-v1, Climber-v2.

The robot starts at the bottom of a vertical channel (``pipe``) and is rewarded for the gain of its centre
of mass in y; an unstable step costs 3.  Climber-v0/v1 observe the robot's velocity and its points
relative to its centre, and end with +1 once the centre passes the top; Climber-v2 (a narrow stepwise
channel) also observes the orientation and the channel above the robot (3 columns either side), adds a
fifth of the gain in x to the reward, and has no end but the step limit.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from . import sense
from .base import UNSTABLE_PENALTY, Part, Task
from .sense import Frame

#: what reaching the top adds
GOAL_BONUS = 1.0


class Climb(Task):
    """``ClimbBase``: climb ``pipe`` from voxel (1, 1); +1 and done once the centre's y passes ``goal_y``."""

    robot_at = (1, 1)
    #: metres; None: no top to reach
    goal_y: ClassVar[float | None] = None
    #: the weight of the gain in x in the reward
    x_weight: ClassVar[float | None] = None

    @classmethod
    def obs_size(cls, robot_points: int) -> int:
        return 2 + 2 * robot_points

    def observe(self, frame: Frame) -> list[Part]:
        return [sense.vel_com(frame, "robot"), sense.robot_relative(frame)]

    def reward(self, before: Frame, after: Frame, unstable: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        com1, com2 = sense.com(before, "robot"), sense.com(after, "robot")
        reward = com2[:, 1] - com1[:, 1]
        if self.x_weight is not None:
            reward = reward + (com2[:, 0] - com1[:, 0]) * self.x_weight
        reward = np.where(unstable, reward + UNSTABLE_PENALTY, reward)
        if self.goal_y is None:
            return reward, unstable.copy()
        goal = com2[:, 1] > self.goal_y
        return np.where(goal, reward + GOAL_BONUS, reward), unstable | goal


class ClimberV0(Climb):
    id, world = "Climber-v0", "Climber-v0"
    goal_y = 86 * 0.1


class ClimberV1(Climb):
    id, world = "Climber-v1", "Climber-v1"
    goal_y = 65 * 0.1


class ClimberV2(Climb):
    id, world = "Climber-v2", "Climber-v2"
    x_weight = 0.2
    sight_dist = 3

    @classmethod
    def obs_size(cls, robot_points: int) -> int:
        return 3 + 2 * robot_points + 2 * cls.sight_dist + 1

    def observe(self, frame: Frame) -> list[Part]:
        return [sense.vel_com(frame, "robot"), sense.orientation(frame, "robot")[:, None],
                sense.robot_relative(frame), sense.ceiling(frame, "robot", ("pipe",), self.sight_dist)]


DEFINED = (ClimberV0, ClimberV1, ClimberV2)
