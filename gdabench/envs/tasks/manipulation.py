"""Evolution Gym's manipulation tasks (``evogym/envs/manipulate.py``): Carrier-v0, Carrier-v1, Pusher-v0,
Pusher-v1, Thrower-v0, Catcher-v0, BeamToppler-v0, BeamSlider-v0, Lifter-v0.

The robot moves a thing: a package (a 3 x 2 box; Lifter-v0's is 1 x 2) or a beam.  Every reward is read
from the centres of mass of the robot and the thing before and after the step; each task takes 3 when the
simulation becomes unstable and, where it has a goal, adds 1 and ends the episode once the goal is met.
Evolution Gym's thresholds are kept as its code writes them (``3.0 * VOXEL``, ``99 * VOXEL``: the same
doubles).
"""

from __future__ import annotations

from typing import Any, ClassVar, Mapping, Sequence

import numpy as np

from . import sense
from .base import Part, Task, finish, world_objects
from .sense import VOXEL, Frame


class Manipulation(Task):
    """A robot and the thing it moves: the centres of mass that rewards read, and the robot's points."""

    thing: ClassVar[str] = "package"
    #: the observation's length before the robot's points
    features: ClassVar[int] = 6

    @classmethod
    def obs_size(cls, robot_points: int) -> int:
        return cls.features + 2 * robot_points

    def coms(self, before: Frame, after: Frame) -> tuple[np.ndarray, ...]:
        """The centres of mass ``(N, 2)``: the robot's before and after the step, the thing's before and after."""
        return (sense.com(before, "robot"), sense.com(after, "robot"),
                sense.com(before, self.thing), sense.com(after, self.thing))

    def reward(self, before: Frame, after: Frame, unstable: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        reward, goal = self.score(*self.coms(before, after))
        return finish(reward, unstable, goal)

    def score(self, r1: np.ndarray, r2: np.ndarray, p1: np.ndarray, p2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The step's reward before the instability penalty, and where the goal is met (robot ``r``, thing
        ``p``; 1 before the step, 2 after)."""
        raise NotImplementedError


def below(height: np.ndarray | float, p1: np.ndarray, p2: np.ndarray) -> np.ndarray:
    """Evolution Gym's penalty for a package below ``height``: 10 times its fall this step, 0 above."""
    return np.where(p2[:, 1] < height, 10 * (p2[:, 1] - p1[:, 1]), 0.0)


def closer(r1: np.ndarray, r2: np.ndarray, p1: np.ndarray, p2: np.ndarray) -> np.ndarray:
    """How much closer in x the robot and the thing came this step."""
    return np.abs(r1[:, 0] - p1[:, 0]) - np.abs(r2[:, 0] - p2[:, 0])


class Package(Manipulation):
    """``PackageBase``'s observation: the robot's velocity, where the package is from the robot and its
    velocity, then the robot's points (the same at reset)."""

    #: Evolution Gym's ``thresh_height``: a package below it is penalised for falling
    thresh_height: ClassVar[float] = 0.0
    #: the robot's centre passing this x (metres) is the goal; None: no goal
    goal_x: ClassVar[float | None] = None

    def observe(self, frame: Frame) -> list[Part]:
        return [sense.vel_com(frame, "robot"), sense.com(frame, "package") - sense.com(frame, "robot"),
                sense.vel_com(frame, "package"), *self.extra(frame), sense.robot_relative(frame)]

    def extra(self, frame: Frame) -> list[Part]:
        """Parts after the package's velocity (Lifter-v0 adds its orientation)."""
        return []

    def reached(self, r2: np.ndarray) -> np.ndarray:
        return np.zeros(len(r2), dtype=bool) if self.goal_x is None else r2[:, 0] > self.goal_x


class Pushing(Package):
    """``PackageBase.get_reward``: the package's and the robot's advance, robot and package kept together."""

    def score(self, r1, r2, p1, p2):
        reward = (p2[:, 0] - p1[:, 0]) * 0.75
        reward = reward + (r2[:, 0] - r1[:, 0]) * 0.5
        reward = reward + closer(r1, r2, p1, p2)
        return reward + below(self.thresh_height, p1, p2), self.reached(r2)


class CarrierV0(Package):
    id, world, robot_at = "Carrier-v0", "Carrier-v0", (1, 1)
    thresh_height = 3.0 * VOXEL
    goal_x = 99 * VOXEL

    def score(self, r1, r2, p1, p2):
        reward = (p2[:, 0] - p1[:, 0]) * 0.5
        reward = reward + (r2[:, 0] - r1[:, 0]) * 0.5
        return reward + below(self.thresh_height, p1, p2), self.reached(r2)


class CarrierV1(Package):
    id, world, robot_at = "Carrier-v1", "Carrier-v1", (1, 4)

    def score(self, r1, r2, p1, p2):
        # Evolution Gym's quirk: it computes the package's approach to the table (x 48.5 voxels) and then
        # overwrites it, so only the robot's approach to x 40 voxels is rewarded
        reward = np.abs(40 * VOXEL - r1[:, 0]) - np.abs(40 * VOXEL - r2[:, 0])
        # the package may sink lower once it is past x 20 voxels (over the table)
        height = np.where(p2[:, 0] > 20 * VOXEL, 4.0 * VOXEL, 6.0 * VOXEL)
        return reward + below(height, p1, p2), self.reached(r2)


class PusherV0(Pushing):
    id, world, robot_at = "Pusher-v0", "Pusher-v0", (1, 1)
    goal_x = 99 * VOXEL


class PusherV1(Pushing):
    id, world, robot_at = "Pusher-v1", "Pusher-v1", (13, 1)
    goal_x = 69 * VOXEL


class ThrowerV0(Package):
    id, world, robot_at = "Thrower-v0", "Thrower-v0", (1, 1)

    def score(self, r1, r2, p1, p2):
        # the robot is penalised for moving right, rewarded for moving right once its centre is left of x 0
        motion = (r1[:, 0] - r2[:, 0]) * 0.25
        motion = np.where(r2[:, 0] < 0, -motion, motion)
        return p2[:, 0] - p1[:, 0] + motion, self.reached(r2)


class LifterV0(Package):
    id, world, robot_at = "Lifter-v0", "Lifter-v0", (2, 3)
    features = 7

    def extra(self, frame: Frame) -> list[Part]:
        return [sense.orientation(frame, "package")]

    def score(self, r1, r2, p1, p2):
        reward = (p2[:, 1] - p1[:, 1]) * 10
        goal = 5.5 * VOXEL  # the hole's centre: moving the package sideways is penalised
        reward = reward + (np.abs(goal - p1[:, 0]) - np.abs(goal - p2[:, 0])) * 10
        # the robot is penalised for sinking below y 3 voxels
        reward = reward + np.where(r2[:, 1] < 3 * VOXEL, 20 * (r2[:, 1] - r1[:, 1]), 0.0)
        return reward, self.reached(r2)


class Tracking(Manipulation):
    """Catcher-v0's and the beam tasks' observation: where the thing is from the robot, the robot's and
    the thing's velocities, the thing's orientation, then the robot's points (the same at reset)."""

    features = 7

    def observe(self, frame: Frame) -> list[Part]:
        return [sense.com(frame, self.thing) - sense.com(frame, "robot"), sense.vel_com(frame, "robot"),
                sense.vel_com(frame, self.thing), sense.orientation(frame, self.thing), sense.robot_relative(frame)]


class CatcherV0(Tracking):
    """Catch a box that falls on pegs.

    Evolution Gym rebuilds the world at every reset with the package and the two pegs shifted by one
    random offset (``dx`` in -6..4, ``dy`` in 0..5 voxels) drawn from Python's global ``random``, which
    ``reset(seed=...)`` does not seed.  Here each environment draws its offset from its own generator
    (seeded by Gymnasium's ``reset(seed=...)`` or ``TaskBatch.seed``), ``dx`` then ``dy`` as Evolution Gym
    does; ``reset(options={"offset": (dx, dy)})`` imposes one.  The pegs are fixed voxels placed per
    environment.
    """

    id, world, robot_at = "Catcher-v0", "Walker-v0", (22, 1)
    moving = ("peg1", "peg2")
    reset_options = ("offset",)
    #: where each object goes at offset (0, 0), and the file of its cells
    places: ClassVar[dict[str, tuple[str, tuple[int, int]]]] = {
        "package": ("package", (21, 41)), "peg1": ("peg", (17, 39)), "peg2": ("peg", (19, 25))}
    #: Evolution Gym's ranges of the offset, both ends included
    offsets = ((-6, 4), (0, 5))

    def __init__(self, robot_points: np.ndarray):
        super().__init__(robot_points)
        self.offset = np.zeros((self.n, 2), dtype=np.int64)

    @classmethod
    def objects(cls) -> dict[str, tuple[np.ndarray, tuple[int, int]]]:
        objects = world_objects(cls.world)
        for name, (source, at) in cls.places.items():
            (cells, _), = world_objects(source).values()
            objects[name] = (cells, at)
        return objects

    def placements(self, rng: Sequence[np.random.Generator], mask: np.ndarray,
                   options: Mapping[str, Any] | None = None) -> dict[str, np.ndarray]:
        imposed = (options or {}).get("offset")
        if imposed is not None:
            self.offset[mask] = self.checked_offset(imposed)
        else:
            (lo_x, hi_x), (lo_y, hi_y) = self.offsets
            for i in np.flatnonzero(mask).tolist():
                self.offset[i] = rng[i].integers(lo_x, hi_x + 1), rng[i].integers(lo_y, hi_y + 1)
        return {name: np.asarray(at) + self.offset for name, (_, at) in self.places.items()}

    def checked_offset(self, offset: Any) -> np.ndarray:
        """``offset`` as two whole numbers in Evolution Gym's ranges, or a one-line ValueError."""
        try:
            value = np.asarray(offset, dtype=float)
        except (TypeError, ValueError):
            value = np.zeros(0)
        ranges = " and ".join(f"{lo}..{hi}" for lo, hi in self.offsets)
        if value.shape != (2,) or not np.all(value == np.round(value)) or not all(
                lo <= v <= hi for v, (lo, hi) in zip(value, self.offsets)):
            raise ValueError(f"{self.id}'s offset must be two whole numbers (dx, dy) in {ranges}, got {offset!r}")
        return value.astype(np.int64)

    def score(self, r1, r2, p1, p2):
        return closer(r1, r2, p1, p2) + below(5.0 * VOXEL, p1, p2), np.zeros(len(r1), dtype=bool)


class Beam(Tracking):
    """Move a beam resting on pegs; the goal: the beam's centre left of x 2 voxels."""

    thing = "beam"

    def fallen(self, p2: np.ndarray) -> np.ndarray:
        return p2[:, 0] < 2 * VOXEL


class BeamTopplerV0(Beam):
    id, world, robot_at = "BeamToppler-v0", "BeamToppler-v0", (1, 1)

    def score(self, r1, r2, p1, p2):
        reward = closer(r1, r2, p1, p2)
        reward = reward + np.abs(p2[:, 0] - p1[:, 0]) * 1.0  # any motion of the beam, more for vertical motion
        reward = reward + np.abs(p2[:, 1] - p1[:, 1]) * 3.0
        reward = reward + (p1[:, 1] - p2[:, 1]) * 10  # and for its fall
        return reward, self.fallen(p2)


class BeamSliderV0(Beam):
    id, world, robot_at = "BeamSlider-v0", "BeamSlider-v0", (1, 1)

    def score(self, r1, r2, p1, p2):
        # Evolution Gym's quirk: the beam is rewarded for sliding right, yet the goal is its centre left of
        # x 2 voxels, as in BeamToppler-v0
        reward = closer(r1, r2, p1, p2) + (p2[:, 0] - p1[:, 0]) * 1.0
        return reward, self.fallen(p2)


DEFINED = (CarrierV0, CarrierV1, PusherV0, PusherV1, ThrowerV0, CatcherV0, BeamTopplerV0, BeamSliderV0, LifterV0)
