"""Evolution Gym's walking tasks (``evogym/envs/walk.py``): Walker-v0, BridgeWalker-v0, CaveCrawler-v0.

Each rewards the gain of the robot's centre of mass in x, adds 1 and ends the episode once that centre
passes the course's end, and takes 3 when the simulation becomes unstable.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from . import sense
from .base import Part, Task, penalised
from .sense import Frame


class Forward(Task):
    """Walk right: reward = gain of the centre of mass's x; +1 and done past ``goal_x`` (metres)."""

    goal_x: ClassVar[float]

    def reward(self, before: Frame, after: Frame, unstable: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x1, x2 = sense.com(before, "robot")[:, 0], sense.com(after, "robot")[:, 0]
        reward = x2 - x1
        reward = penalised(reward, unstable)
        goal = x2 > self.goal_x
        return np.where(goal, reward + 1.0, reward), unstable | goal


class WalkerV0(Forward):
    id, world, robot_at = "Walker-v0", "Walker-v0", (1, 1)
    goal_x = 99 * 0.1

    @classmethod
    def obs_size(cls, robot_points: int) -> int:
        return 2 + 2 * robot_points

    def observe(self, frame: Frame) -> list[Part]:
        return [sense.vel_com(frame, "robot"), sense.robot_relative(frame)]


class BridgeWalkerV0(Forward):
    id, world, robot_at = "BridgeWalker-v0", "BridgeWalker-v0", (2, 5)
    goal_x = 60 * 0.1

    @classmethod
    def obs_size(cls, robot_points: int) -> int:
        return 3 + 2 * robot_points

    def observe(self, frame: Frame) -> list[Part]:
        return [sense.vel_com(frame, "robot"), sense.orientation(frame, "robot"), sense.robot_relative(frame)]


class CaveCrawlerV0(Forward):
    id, world, robot_at = "CaveCrawler-v0", "CaveCrawler-v0", (1, 2)
    goal_x = 69 * 0.1
    sight_dist = 5

    @classmethod
    def obs_size(cls, robot_points: int) -> int:
        return 2 + 2 * robot_points + 2 * (2 * cls.sight_dist + 1)

    def observe(self, frame: Frame) -> list[Part]:
        return [sense.vel_com(frame, "robot"), sense.robot_relative(frame),
                sense.floor(frame, "robot", ("terrain",), self.sight_dist),
                sense.ceiling(frame, "robot", ("terrain",), self.sight_dist)]


DEFINED = (WalkerV0, BridgeWalkerV0, CaveCrawlerV0)
