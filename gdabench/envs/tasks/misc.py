"""Evolution Gym's tasks of one file each: Flipper-v0 (``evogym/envs/flip.py``), Jumper-v0 (``jump.py``),
Balancer-v0 and Balancer-v1 (``balance.py``).

Every one takes 3 and ends the episode when the simulation becomes unstable; only Flipper-v0 has another
end (its centre of mass left of x = 0.1 m).
"""

from __future__ import annotations

import math
from typing import Any, ClassVar, Mapping, Sequence

import numpy as np

from . import sense
from .base import Part, Task, penalised
from .sense import VOXEL, Frame


class FlipperV0(Task):
    """Turn counter-clockwise: reward = the step's gain of the robot's orientation, counted on from one turn
    to the next (``num_flips`` whole turns, per environment, zeroed at reset)."""

    id, world, robot_at = "Flipper-v0", "Flipper-v0", (60, 1)

    def __init__(self, robot_points: np.ndarray):
        super().__init__(robot_points)
        self.flips = np.zeros(self.n, dtype=np.int64)

    @classmethod
    def obs_size(cls, robot_points: int) -> int:
        return 1 + 2 * robot_points

    def reset(self, frame: Frame, mask: np.ndarray, rng: Sequence[np.random.Generator],
              options: Mapping[str, Any] | None = None) -> None:
        self.flips[mask] = 0

    def observe(self, frame: Frame) -> list[Part]:
        return [sense.orientation(frame, "robot"), sense.robot_relative(frame)]

    def reward(self, before: Frame, after: Frame, unstable: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        ort1, ort2 = sense.orientation(before, "robot"), sense.orientation(after, "robot")
        flat1 = self.flips * 2 * math.pi + ort1
        # a wrap of the orientation from under a sixth of a turn to over five sixths is a turn back, the other
        # way a turn on; Evolution Gym counts turns as 2 * math.pi while the orientation wraps at 2 * 3.1415926,
        # so each wrap adds about 1e-7 to the reward (kept)
        self.flips -= (ort1 < math.pi / 3) & (ort2 > 5 * math.pi / 3)
        self.flips += (ort1 > 5 * math.pi / 3) & (ort2 < math.pi / 3)
        flat2 = self.flips * 2 * math.pi + ort2
        reward = penalised(flat2 - flat1, unstable)
        return reward, unstable | (sense.com(after, "robot")[:, 0] < 1 * VOXEL)


class JumperV0(Task):
    """Jump in place: reward = 10 x the centre's rise - 5 x its drift sideways."""

    id, world, robot_at = "Jumper-v0", "Jumper-v0", (32, 1)
    sight_dist = 2

    @classmethod
    def obs_size(cls, robot_points: int) -> int:
        return 2 + 2 * robot_points + (2 * cls.sight_dist + 1)

    def observe(self, frame: Frame) -> list[Part]:
        return [sense.vel_com(frame, "robot"), sense.robot_relative(frame),
                sense.floor(frame, "robot", ("ground",), self.sight_dist)]

    def reward(self, before: Frame, after: Frame, unstable: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        c1, c2 = sense.com(before, "robot"), sense.com(after, "robot")
        reward = (c2[:, 1] - c1[:, 1]) * 10 - np.abs(c2[:, 0] - c1[:, 0]) * 5
        return penalised(reward, unstable), unstable.copy()


class Balance(Task):
    """Stay on the pole: reward = the step's approach of the centre to ``target`` in x plus that in y (each the
    fall of a distance ``|target - centre|``)."""

    target: ClassVar[tuple[float, float]]

    @classmethod
    def obs_size(cls, robot_points: int) -> int:
        return 1 + 2 * robot_points

    def observe(self, frame: Frame) -> list[Part]:
        return [sense.orientation(frame, "robot"), sense.robot_relative(frame)]

    def reward(self, before: Frame, after: Frame, unstable: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        c1, c2 = sense.com(before, "robot"), sense.com(after, "robot")
        tx, ty = self.target
        reward = np.abs(tx - c1[:, 0]) - np.abs(tx - c2[:, 0])
        reward = reward + (np.abs(ty - c1[:, 1]) - np.abs(ty - c2[:, 1]))
        return penalised(reward, unstable), unstable.copy()


class BalancerV0(Balance):
    id, world, robot_at = "Balancer-v0", "Balancer-v0", (15, 3)
    # the pole's top; balance.py's get_obs (unused) aims y at 5.5 voxels, its reward at 5.0
    target = (17 * VOXEL, 5.0 * VOXEL)


class BalancerV1(Balance):
    id, world, robot_at = "Balancer-v1", "Balancer-v1", (10, 1)
    target = (17.5 * VOXEL, 6 * VOXEL)


DEFINED = (FlipperV0, JumperV0, BalancerV0, BalancerV1)
