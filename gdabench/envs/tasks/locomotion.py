"""Evolution Gym's terrain tasks (``evogym/envs/traverse.py``): UpStepper-v0, DownStepper-v0,
ObstacleTraverser-v0/v1, Hurdler-v0, PlatformJumper-v0, GapJumper-v0, Traverser-v0.

All follow its ``StairsBase``: the observation is the robot's velocity, its orientation, its points
relative to its centre and the terrain below it (5 columns either side), the reward is the gain of the
robot's centre of mass in x, and an unstable step costs 3.  They differ in the terrain seen, and in how an
episode ends: past a finishing line (+2), with the centre fallen below a height (-3), or turned over
(orientation in a band around pi, -3), each checked in that order, so that several can apply to one step.

Traverser-v0 adds 27 rigid blocks to its sim file, which fill a pit and count as terrain.  Evolution
Gym builds its 1x1 block from uninitialised memory (``EvoSim`` passes ``np.empty((2, 1))`` as the
connections of an object without any, and the C++ side reads them as voxel indices): at random it crashes,
writes outside the block's cells, or, when the numbers happen to be harmless, makes a block without
connections.  This makes that block, always (the parity fixture was recorded with those numbers zeroed).
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from . import sense
from .base import UNSTABLE_PENALTY, Part, Task, world_objects
from .sense import Frame

#: what an episode's end adds: crossing the finishing line, falling, turning over
GOAL_BONUS, FALL_PENALTY, TURN_PENALTY = 2.0, -3.0, -3.0
#: StairsBase's orientations (radians, open interval) that count as turned over
TURNED = (math.pi / 2, 3 * math.pi / 2)


class Stairs(Task):
    """``StairsBase``: walk right over ``terrain``; the episode ends as the class attributes say."""

    terrain: ClassVar[tuple[str, ...]] = ("ground",)
    sight_dist: ClassVar[int] = 5
    #: +2 and done once the centre's x passes it (metres); None: no finishing line
    goal_x: ClassVar[float | None] = None
    #: -3 and done once the centre's y is below it (metres); None: no fall
    fall_y: ClassVar[float | None] = None
    #: -3 and done while the orientation is inside this open interval; None: never
    turned: ClassVar[tuple[float, float] | None] = TURNED

    @classmethod
    def obs_size(cls, robot_points: int) -> int:
        return 3 + 2 * robot_points + 2 * cls.sight_dist + 1

    def observe(self, frame: Frame) -> list[Part]:
        # Evolution Gym's reset observation (np.array([robot_ort])) is laid out as its step's (get_ort_obs)
        return [sense.vel_com(frame, "robot"), sense.orientation(frame, "robot")[:, None],
                sense.robot_relative(frame), sense.floor(frame, "robot", self.terrain, self.sight_dist)]

    def reward(self, before: Frame, after: Frame, unstable: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        com = sense.com(after, "robot")
        reward = com[:, 0] - sense.com(before, "robot")[:, 0]
        reward = np.where(unstable, reward + UNSTABLE_PENALTY, reward)
        done = unstable.copy()
        # the checks in Evolution Gym's order: each adds to the reward of the same step
        if self.goal_x is not None:
            goal = com[:, 0] > self.goal_x
            reward, done = np.where(goal, reward + GOAL_BONUS, reward), done | goal
        if self.fall_y is not None:
            fell = com[:, 1] < self.fall_y
            reward, done = np.where(fell, reward + FALL_PENALTY, reward), done | fell
        if self.turned is not None:
            ort = sense.orientation(after, "robot")
            over = (ort > self.turned[0]) & (ort < self.turned[1])
            reward, done = np.where(over, reward + TURN_PENALTY, reward), done | over
        return reward, done


class UpStepperV0(Stairs):
    id, world, robot_at = "UpStepper-v0", "UpStepper-v0", (1, 1)
    goal_x = 69 * 0.1
    # a wider band than the others': pi / 12 more on either side
    turned = (math.pi / 2 - math.pi / 12, 3 * math.pi / 2 + math.pi / 12)


class DownStepperV0(Stairs):
    id, world, robot_at = "DownStepper-v0", "DownStepper-v0", (1, 11)
    goal_x = 74 * 0.1


class ObstacleTraverserV0(Stairs):
    id, world, robot_at = "ObstacleTraverser-v0", "ObstacleTraverser-v0", (2, 1)
    goal_x = 79 * 0.1


class ObstacleTraverserV1(Stairs):
    id, world, robot_at = "ObstacleTraverser-v1", "ObstacleTraverser-v1", (2, 4)
    goal_x = 59 * 0.1
    turned = None


class HurdlerV0(Stairs):
    """No finishing line: the episode ends at the step limit or turned over."""

    id, world, robot_at = "Hurdler-v0", "Hurdler-v0", (2, 4)


class PlatformJumperV0(Stairs):
    id, world, robot_at = "PlatformJumper-v0", "PlatformJumper-v0", (1, 6)
    terrain = tuple(f"platform_{k}" for k in range(1, 8))
    fall_y = 0.4


class GapJumperV0(Stairs):
    id, world, robot_at = "GapJumper-v0", "GapJumper-v0", (1, 6)
    terrain = tuple(f"platform_{k}" for k in range(1, 6))
    fall_y = 4 * 0.1
    turned = None


#: Traverser-v0's blocks as ``BlockSoup`` adds them: (x, y) of the bottom-left voxel, side, named block_<k>
BLOCKS = (
    (20, 1, 3), (24, 1, 3), (27, 1, 2), (31, 1, 3), (34, 1, 3), (38, 1, 2), (41, 1, 3), (45, 1, 3),
    (21, 4, 3), (24, 4, 2), (26, 4, 1), (29, 4, 2), (31, 4, 3), (34, 4, 2), (36, 4, 2), (40, 4, 3),
    (43, 4, 2), (46, 4, 3),
    *((x, 7, 2) for x in range(20, 45, 3)),
)


class TraverserV0(Stairs):
    id, world, robot_at = "Traverser-v0", "Traverser-v0", (1, 9)
    terrain = ("ground", *(f"block_{k}" for k in range(len(BLOCKS))))
    goal_x = 59 * 0.1
    turned = None

    @classmethod
    def objects(cls) -> dict[str, tuple[np.ndarray, tuple[int, int]]]:
        objects = world_objects(cls.world)
        for k, (x, y, side) in enumerate(BLOCKS):
            (grid, _), = world_objects(f"rigid_{side}x{side}").values()
            objects[f"block_{k}"] = (grid, (x, y))
        return objects


DEFINED = (UpStepperV0, DownStepperV0, ObstacleTraverserV0, ObstacleTraverserV1, HurdlerV0, PlatformJumperV0,
           GapJumperV0, TraverserV0)
