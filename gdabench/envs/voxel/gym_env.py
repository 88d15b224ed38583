"""Evolution Gym's tasks on the voxel engine as Gymnasium environments: ``voxel/<task id>``.

* ``voxel/Carrier-v0`` (:class:`VoxelEnv`) is one body in one environment, and its vector entry point
  (:class:`VoxelVectorEnv`) E environments of one body stepped in one call::

      gymnasium.make_vec("voxel/Carrier-v0", num_envs=16, vectorization_mode="vector_entry_point", body=...)

* ``gdabench/Walker-v2`` is ``voxel/Walker-v0`` under the name it had first.

Conventions are Evolution Gym 2.0's for each task (observation and action order, reward, bonuses,
termination, step limit); the action space is [0.6, 1.6] per actuator, in Evolution Gym's order
(row-major over the body, top row first), and :attr:`VoxelEnv.actuator_voxels` says which voxel each
drives.  The episode return includes the final step's reward (Evolution Gym 1.0's scoring).
"""

from __future__ import annotations

from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv

from ..tasks.base import ACTION_HIGH, ACTION_LOW, NO_BODY
from . import engine, env_id
from .batch import TaskBatch

#: observations are bounded as Evolution Gym bounds them
OBS_BOUND = 100.0


def _spaces(batch: TaskBatch) -> tuple[spaces.Box, spaces.Box]:
    n_act = int(batch.tables.n_act[0])
    action = spaces.Box(ACTION_LOW, ACTION_HIGH, shape=(n_act,), dtype=np.float64)
    observation = spaces.Box(-OBS_BOUND, OBS_BOUND, shape=(batch.obs_sizes[0],), dtype=np.float64)
    return action, observation


def actuator_voxels(obj: Any) -> np.ndarray:
    """(row, col, code) of each actuator in action order, as ``gdabench/Walker-v1`` exposes them."""
    cells = obj.boxel_cell[obj.actuators]
    out = np.stack([cells[:, 1], cells[:, 0], obj.boxel_type[obj.actuators]], axis=1)
    out.flags.writeable = False
    return out


def checked_actions(actions: Any, shape: tuple[int, ...], what: str) -> np.ndarray:
    """Actions as a float array of ``shape``, or a one-line ValueError: the wrong shape, or not finite."""
    try:
        array = np.asarray(actions, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{what} must be numbers: {exc}") from None
    if array.shape != shape and array.size == int(np.prod(shape)) and len(shape) == 1:
        array = array.reshape(shape)
    if array.shape != shape:
        raise ValueError(f"{what} must have shape {shape} (one per actuator), got {array.shape}")
    if not np.isfinite(array).all():
        raise ValueError(f"{what} must be finite numbers")
    return array


def _body_arg(task: str, body: Any) -> Any:
    if body is NO_BODY:
        raise TypeError(f"{env_id(task)} needs a body: gymnasium.make({env_id(task)!r}, body='44444/44444/...')")
    return body


class VoxelEnv(gymnasium.Env):
    """One body on one of Evolution Gym's tasks (see the module docstring)."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 1.0 / (30 * 0.0001)}

    def __init__(self, body: Any = NO_BODY, task: str = "Walker-v0", render_mode: str | None = None):
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode {render_mode!r} is not supported; use 'rgb_array' or None")
        self.render_mode = render_mode
        self.batch = TaskBatch(task, [_body_arg(task, body)])
        self.task = self.batch.task_type
        self.body = self.batch.bodies[0]
        self.action_space, self.observation_space = _spaces(self.batch)
        self.actuator_voxels = actuator_voxels(self.batch.tables.robots[0])
        self._size = self.batch.obs_sizes[0]
        self._obs = self.batch.reset()[0, : self._size]
        self._renderer: Any = None

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        self.batch.rngs = [self.np_random]  # a task's random set-up comes from the environment's generator
        self._obs = self.batch.reset(options=options)[0, : self._size]
        return self._obs.copy(), {}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        ratios = checked_actions(action, self.action_space.shape or (), f"{self.task.id} actions")
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
            from .render import WorldRenderer

            self._renderer = WorldRenderer(self.batch.tables, 0)
        return self._renderer.draw(self.batch.state.pos[0])


class VoxelVectorEnv(VectorEnv):
    """E environments of one body stepped in one call; episodes reset on the step after they end
    (Gymnasium's next-step autoreset) and are truncated at the task's step limit."""

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(self, num_envs: int = 1, body: Any = NO_BODY, task: str = "Walker-v0",
                 max_episode_steps: int | None = None, threads: int | None = None, **kwargs: Any):
        if kwargs.get("render_mode") is not None:
            raise ValueError(f"the vector environments do not render; use gymnasium.make({env_id(task)!r}, "
                             "render_mode='rgb_array')")
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"num_envs must be a whole number of at least 1, got {num_envs!r}")
        if threads is not None and (isinstance(threads, bool) or not isinstance(threads, (int, np.integer))
                                    or threads < 1):
            raise ValueError(f"threads must be a whole number of at least 1, got {threads!r}")
        self.num_envs = int(num_envs)
        #: Numba threads that step the environments: by default one below 32 environments (see
        #: gdabench.envs.voxel.engine.default_threads), else one per 16 up to the cores this process may use
        self.threads = engine.default_threads(self.num_envs) if threads is None else int(threads)
        self.batch = TaskBatch(task, [_body_arg(task, body)], envs_per_body=self.num_envs, threads=self.threads)
        self.task = self.batch.task_type
        self.single_action_space, self.single_observation_space = _spaces(self.batch)
        self.action_space = gymnasium.vector.utils.batch_space(self.single_action_space, self.num_envs)
        self.observation_space = gymnasium.vector.utils.batch_space(self.single_observation_space, self.num_envs)
        self.max_episode_steps = self.task.max_episode_steps if max_episode_steps is None else int(max_episode_steps)
        self._t = np.zeros(self.num_envs, dtype=np.int64)
        self._ended = np.zeros(self.num_envs, dtype=bool)
        self._size = self.batch.obs_sizes[0]

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        if seed is not None:  # environment i draws its set-ups from seed + i, as Gymnasium seeds a vector
            self.batch.seed([seed + i for i in range(self.num_envs)])
        self._t[:] = 0
        self._ended[:] = False
        return self.batch.reset(options=options)[:, : self._size].copy(), {}

    def step(self, actions: np.ndarray):
        shape = (self.num_envs, *(self.single_action_space.shape or ()))
        actions = checked_actions(actions, shape, f"{self.task.id} vector actions")
        restart = self._ended.copy()
        self.batch.done[restart] = True  # not stepped: reset after the step, they report their first observation
        obs, reward, terminated, unstable = self.batch.step(actions)
        if restart.any():  # (after: a task that keeps state between steps sees no step of a fresh episode)
            obs = self.batch.reset(restart)
            self._t[restart] = 0
        self._t[~restart] += 1
        truncated = ~terminated & (self._t >= self.max_episode_steps)
        self._ended = terminated | truncated
        info: dict[str, Any] = {}
        if unstable.any():  # which environments' simulations became unstable (Gymnasium's vector info form)
            info = {"unstable": unstable.copy(), "_unstable": unstable.copy()}
        return obs[:, : self._size].copy(), reward, terminated, truncated, info
