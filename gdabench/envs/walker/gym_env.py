"""``gdabench/Walker-v1``: Evolution Gym's Walker-v0 task as a Gymnasium environment on pymunk.

Conventions (Evolution Gym's): the body's grid starts at voxel (1, 1) on flat rigid terrain
100 voxels long; an episode lasts 500 steps (the registered time limit); the reward of a step
is the change in x of the mean point-mass position; passing x = 9.9 adds +1 and ends the
episode; an unstable simulation gives -3 and ends it.  The observation is the centre-of-mass
velocity (2) followed by every point's position relative to the centre of mass (all x, then all y),
each multiplied by the voxel size as Evolution Gym's benchmark tasks do; the action is one target
length ratio in [0.6, 1.6] per actuator voxel, in the order of :attr:`WalkerEnv.actuator_voxels`.
The episode return includes the final step's reward (Evolution Gym 1.0's scoring), so crossing the
course scores about 10.5.
"""

from __future__ import annotations

from typing import Any, cast

import gymnasium
import numpy as np
from gymnasium import spaces

from ...body import Body
from ...errors import MalformedBodyError
from ..tasks.base import NO_BODY
from .render import Renderer
from .sim import Terrain, VoxelSim, WalkerPhysics

#: Walker-v0's geometry in voxels (Evolution Gym's task)
TERRAIN_VOXELS = 100
START_VOXEL = (1, 1)
GOAL_VOXELS = 99
MIN_RATIO, MAX_RATIO = 0.6, 1.6
GOAL_BONUS, UNSTABLE_PENALTY = 1.0, -3.0


def checked_body(body: Any) -> Body:
    """The body as a :class:`Body`, or a one-line ``ValueError`` saying why it cannot walk (Evolution Gym's
    rules, and the pymunk walker's terrain is 100 voxels long)."""
    from ..tasks.base import checked_body as checked_for
    from ..tasks.walking import WalkerV0

    parsed = checked_for(body, WalkerV0)
    if START_VOXEL[0] + parsed.shape[1] > TERRAIN_VOXELS:
        raise MalformedBodyError(f"body {parsed.shape[0]}x{parsed.shape[1]} is wider than the walker's terrain")
    return parsed


class WalkerEnv(gymnasium.Env):
    """A voxel body walking to the right on flat ground (see the module docstring)."""

    metadata = {"render_modes": ["rgb_array"]}

    def __init__(self, body: Any = NO_BODY, render_mode: str | None = None, physics: WalkerPhysics | None = None):
        if body is NO_BODY:
            raise TypeError("gdabench/Walker-v1 needs a body: gymnasium.make('gdabench/Walker-v1', body='44444/...')")
        self.body = checked_body(body)
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode {render_mode!r} is not supported; use 'rgb_array' or None")
        self.render_mode = render_mode
        self.physics = physics or WalkerPhysics()
        self.metadata = {**self.metadata, "render_fps": 1.0 / self.physics.step_seconds}
        s = self.physics.voxel_size
        self.terrain = Terrain(x_start=0.0, x_end=TERRAIN_VOXELS * s, top=s, floor=0.0)
        self.goal_x = GOAL_VOXELS * s
        self._new_sim()
        mesh = self.sim.mesh
        #: the actuator voxels in action order: one row (row, col, code) each, row 0 being the
        #: top row of the body array and code 3 (horizontal) or 4 (vertical).  Controllers such
        #: as ``open-loop`` read this attribute from ``env.unwrapped``.
        self.actuator_voxels = mesh.actuator_cells.copy()
        self.actuator_voxels.flags.writeable = False
        self.action_space = spaces.Box(MIN_RATIO, MAX_RATIO, shape=(mesh.n_actuators,), dtype=np.float64)
        # Evolution Gym's bounds; never reached: the instability check stops any point faster than
        # max_speed, and relative positions stay within the body's extent
        self.observation_space = spaces.Box(-100.0, 100.0, shape=(2 + 2 * mesh.n_points,), dtype=np.float64)
        self.renderer = Renderer(mesh.voxel_corners, mesh.voxel_codes, self.terrain)

    def _new_sim(self) -> None:
        s = self.physics.voxel_size
        origin = (START_VOXEL[0] * s, START_VOXEL[1] * s)
        self.sim = VoxelSim(np.asarray(self.body.voxels), self.physics, origin=origin, terrain=self.terrain)
        self._com_x = float(self.sim.positions[:, 0].mean())
        self._obs = self._observe()
        self._shown = self.sim.positions  # what render() draws: the last trustworthy state
        self._untouched = True  # reset() can keep a simulation that has not been stepped

    def _observe(self) -> np.ndarray:
        pos, vel = self.sim.positions, self.sim.velocities
        rel = pos - pos.mean(axis=0)
        return self.physics.voxel_size * np.concatenate([vel.mean(axis=0), rel[:, 0], rel[:, 1]])

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)  # the simulation itself is deterministic: the seed changes nothing
        if not self._untouched:
            self._new_sim()
        return self._obs.copy(), {}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        ratios = np.asarray(action, dtype=np.float64).reshape(-1)
        if ratios.shape != self.action_space.shape:
            raise ValueError(
                f"the walker expects {cast('tuple[int]', self.action_space.shape)[0]} actions (one per actuator), "
                f"got {ratios.shape[0]}"
            )
        if not np.isfinite(ratios).all():
            raise ValueError("walker actions must be finite numbers")
        self._untouched = False
        self.sim.set_ratios(np.clip(ratios, MIN_RATIO, MAX_RATIO))
        self.sim.step()
        why = self.sim.instability()
        if why is not None:  # keep the last trustworthy observation; the episode is over
            return self._obs.copy(), UNSTABLE_PENALTY, True, False, {"unstable": why}
        com_x = float(self.sim.positions[:, 0].mean())
        reward, self._com_x = com_x - self._com_x, com_x
        self._obs = self._observe()
        self._shown = self.sim.positions
        terminated = com_x > self.goal_x
        if terminated:
            reward += GOAL_BONUS
        return self._obs.copy(), reward, terminated, False, {}

    def render(self) -> np.ndarray | None:
        if self.render_mode != "rgb_array":
            return None
        return self.renderer.draw(self._shown)
