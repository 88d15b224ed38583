"""Walker-v0 on the voxel engine: a batch of bodies x environments, and the Gymnasium faces of it.

* :class:`WalkerBatch` steps every environment of several bodies in one call (the interface a
  co-design loop uses): ``reset()``, then ``step(actions)`` with ``(N, A)`` padded actions.
* ``gdabench/Walker-v2`` (:class:`WalkerEnv`) is one body in one environment, and its vector entry
  point (:class:`WalkerVectorEnv`) E environments of one body in one call::

      gymnasium.make_vec("gdabench/Walker-v2", num_envs=16, vectorization_mode="vector_entry_point", body=...)

Conventions are Evolution Gym's Walker-v0 (the robot at voxel (1, 1) on 100 fixed voxels; reward =
gain of the mean point x; +1 and done past x = 9.9; -3 and done when unstable; 500 steps), with the
observation and action layout of ``gdabench/Walker-v1``.  The episode return includes the final
step's reward (Evolution Gym 1.0's scoring).
"""

from __future__ import annotations

from typing import Any, Sequence

import gymnasium
import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv

from ...body import Body
from ..walker.gym_env import GOAL_BONUS, GOAL_VOXELS, MAX_RATIO, MIN_RATIO, UNSTABLE_PENALTY, checked_body
from . import ENV_ID, MAX_EPISODE_STEPS, engine

__all__ = ["ENV_ID", "WalkerBatch", "WalkerEnv", "WalkerVectorEnv"]

GOAL_X = GOAL_VOXELS * 0.1


class WalkerBatch:
    """Environments ``i`` of bodies ``body[i]``: one array step for all (no automatic reset).

    ``bodies`` are padded to the largest (or to ``pad``'s tables); ``envs_per_body`` environments
    of each, body-major.  ``step`` returns observations ``(N, 2 + 2P)`` (each body's own size
    first, then zeros), rewards, and whether each environment terminated (goal or instability);
    environments already terminated are not stepped until ``reset(mask)``.
    """

    def __init__(self, bodies: Sequence[Body | str], envs_per_body: int = 1, pad: engine.BodyTables | None = None):
        self.bodies = [checked_body(b) for b in bodies]
        self.tables = engine.body_tables(self.bodies, pad=pad)
        self.terrain = engine.WALKER_TERRAIN
        self.body_index = np.repeat(np.arange(len(self.bodies)), envs_per_body)
        self.state = engine.reset(self.tables, self.body_index)
        self.done = np.zeros(len(self.body_index), dtype=bool)

    #: every action is clipped into this range (Evolution Gym's actuator ratios)
    action_bounds = (MIN_RATIO, MAX_RATIO)

    @property
    def num_envs(self) -> int:
        return len(self.body_index)

    @property
    def obs_sizes(self) -> list[int]:
        return [self.tables.obs_size(b) for b in range(len(self.bodies))]

    @property
    def act_sizes(self) -> list[int]:
        return [int(n) for n in self.tables.n_act[: len(self.bodies)]]

    def reset(self, mask: np.ndarray | None = None) -> np.ndarray:
        """Put environments (all, or where ``mask``) back at rest; returns every observation."""
        fresh = engine.reset(self.tables, self.body_index)
        if mask is None:
            self.state = fresh
            self.done[:] = False
        else:
            mask = np.asarray(mask, dtype=bool)
            keep = ~mask[:, None, None]
            self.state = engine.State(
                pos=np.where(keep, self.state.pos, fresh.pos), vel=np.where(keep, self.state.vel, fresh.vel),
                vtrue=np.where(keep, self.state.vtrue, fresh.vtrue), body=self.body_index,
            )
            self.done[mask] = False
        return engine.observe(self.tables, self.state)

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Step every environment not done; returns ``(obs, reward, terminated, unstable)``."""
        active = ~self.done
        self.state, out = engine.step(self.tables, self.terrain, self.state, actions, active=active)
        reward = out.dx + np.where(out.unstable, UNSTABLE_PENALTY, 0.0)
        goal = active & ~out.unstable & (out.com > GOAL_X)
        reward = np.where(goal, reward + GOAL_BONUS, reward)
        reward[~active] = 0.0
        terminated = active & (goal | out.unstable)
        self.done |= terminated
        obs = np.where(active[:, None], out.obs, engine.observe(self.tables, self.state))
        return obs, reward, terminated, out.unstable & active


def _spaces(tables: engine.BodyTables) -> tuple[spaces.Box, spaces.Box]:
    n_act = int(tables.n_act[0])
    action = spaces.Box(MIN_RATIO, MAX_RATIO, shape=(n_act,), dtype=np.float64)
    observation = spaces.Box(-100.0, 100.0, shape=(tables.obs_size(0),), dtype=np.float64)
    return action, observation


def actuator_voxels(obj: Any) -> np.ndarray:
    """(row, col, code) of each actuator in action order, as ``gdabench/Walker-v1`` exposes them."""
    cells = obj.boxel_cell[obj.actuators]
    out = np.stack([cells[:, 1], cells[:, 0], obj.boxel_type[obj.actuators]], axis=1)
    out.flags.writeable = False
    return out


class WalkerEnv(gymnasium.Env):
    """One body walking to the right on Evolution Gym's physics (see the module docstring)."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 1.0 / (30 * 0.0001)}

    def __init__(self, body: Any, render_mode: str | None = None):
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode {render_mode!r} is not supported; use 'rgb_array' or None")
        self.render_mode = render_mode
        self.batch = WalkerBatch([body])
        self.body = self.batch.bodies[0]
        self.action_space, self.observation_space = _spaces(self.batch.tables)
        obj = self.batch.tables.objects[0]
        self.actuator_voxels = actuator_voxels(obj)
        self._n = len(obj.pos)
        self._size = self.batch.tables.obs_size(0)
        self._n_act = int(self.batch.tables.n_act[0])
        self._obs = self.batch.reset()[0, : self._size]
        self._renderer: Any = None

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)  # the simulation is deterministic: the seed changes nothing
        self._obs = self.batch.reset()[0, : self._size]
        return self._obs.copy(), {}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        ratios = np.asarray(action, dtype=np.float64).reshape(-1)
        if ratios.shape != (self._n_act,):
            raise ValueError(f"the walker expects {self._n_act} actions (one per actuator), got {ratios.shape[0]}")
        if not np.isfinite(ratios).all():
            raise ValueError("walker actions must be finite numbers")
        if self.batch.done[0]:
            raise RuntimeError("step() after the episode ended: call reset()")
        obs, reward, terminated, unstable = self.batch.step(ratios[None])
        self._obs = obs[0, : self._size]
        info = {"unstable": "self-intersection"} if unstable[0] else {}
        return self._obs.copy(), float(reward[0]), bool(terminated[0]), False, info

    def render(self) -> np.ndarray | None:
        if self.render_mode != "rgb_array":
            return None
        if self._renderer is None:
            from ..walker.render import Renderer
            from ..walker.sim import Terrain

            obj = self.batch.tables.objects[0]
            self._renderer = Renderer(obj.boxel_points, obj.boxel_type, Terrain(0.0, 100 * 0.1, 0.1, 0.0))
        return self._renderer.draw(self.batch.state.pos[0, : self._n])


class WalkerVectorEnv(VectorEnv):
    """E environments of one body stepped in one call; episodes reset on the step after they end
    (Gymnasium's next-step autoreset) and are truncated after 500 steps."""

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(self, num_envs: int, body: Any, max_episode_steps: int = MAX_EPISODE_STEPS, **kwargs: Any):
        if kwargs.get("render_mode") not in (None,):
            raise ValueError(
                "the vector walker does not render; use gymnasium.make('gdabench/Walker-v2', render_mode='rgb_array')"
            )
        self.num_envs = int(num_envs)
        self.batch = WalkerBatch([body], envs_per_body=self.num_envs)
        self.single_action_space, self.single_observation_space = _spaces(self.batch.tables)
        self.action_space = gymnasium.vector.utils.batch_space(self.single_action_space, self.num_envs)
        self.observation_space = gymnasium.vector.utils.batch_space(self.single_observation_space, self.num_envs)
        self.max_episode_steps = max_episode_steps
        self._t = np.zeros(self.num_envs, dtype=np.int64)
        self._ended = np.zeros(self.num_envs, dtype=bool)
        self._size = self.batch.tables.obs_size(0)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        self._t[:] = 0
        self._ended[:] = False
        return self.batch.reset()[:, : self._size].copy(), {}

    def step(self, actions: np.ndarray):
        actions = np.asarray(actions, dtype=np.float64).reshape(self.num_envs, -1)
        restart = self._ended.copy()
        if restart.any():  # reset now, not stepped: they report their first observation
            self.batch.reset(restart)
            self._t[restart] = 0
            self.batch.done[restart] = True
        obs, reward, terminated, _ = self.batch.step(actions)
        self.batch.done[restart] = False
        self._t[~restart] += 1
        truncated = ~terminated & (self._t >= self.max_episode_steps)
        self._ended = terminated | truncated
        return obs[:, : self._size].copy(), reward, terminated, truncated, {}
