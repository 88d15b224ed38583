"""An Evolution Gym task on the voxel engine, for a batch of bodies x environments: one array step for all.

:class:`TaskBatch` joins the engine (physics, task-neutral) and a task (:mod:`gdabench.envs.tasks`: world,
observation, reward, termination, reset).  It is the interface a co-design loop uses, and the Gymnasium
environments of :mod:`gdabench.envs.voxel.gym_env` are thin faces of it.
"""

from __future__ import annotations

from functools import cache
from typing import Any, Mapping, Sequence

import numpy as np

from ...body import Body
from ..tasks import task as task_named
from ..tasks.base import ACTION_HIGH, ACTION_LOW, Task, checked_body, observation
from ..tasks.sense import Frame
from . import engine
from .model import build_object


@cache
def task_world(task: str) -> engine.World:
    """The engine's world of Evolution Gym's task ``task`` (built once per process)."""
    defined = task_named(task)
    return engine.world(defined.objects(), defined.robot_at, moving=defined.moving)


@cache
def _placed(task: str, name: str, at: tuple[int, int]) -> np.ndarray:
    """The points of ``task``'s object ``name`` placed at voxel ``at`` (as the world builds its objects)."""
    return build_object(task_world(task).grids[name], at, point_offset=1, edge_offset=1).pos


class TaskBatch:
    """Environments ``i`` of bodies ``body[i]`` on ``task``: one array step for all (no automatic reset).

    ``bodies`` are padded to the largest (or to ``pad``'s tables); ``envs_per_body`` environments of each,
    body-major.  ``step`` returns observations ``(N, W)`` (each body's own size first, then zeros),
    rewards, and whether each environment's episode ended; environments whose episode ended are not
    stepped until ``reset(mask)``.  Tasks with random set-ups draw them from each environment's generator
    (``seed``), unless ``reset(options=...)`` imposes one (the task's ``reset_options``).
    """

    #: every action is clipped into this range (Evolution Gym's actuator ratios)
    action_bounds = (ACTION_LOW, ACTION_HIGH)

    def __init__(self, task: type[Task] | str, bodies: Sequence[Body | str], envs_per_body: int = 1,
                 pad: engine.BodyTables | None = None, threads: int | None = None, device: str = "cpu"):
        self.task_type = task_named(task) if isinstance(task, str) else task
        self.threads = threads  # Numba threads per step (None: Numba's count; see engine.step)
        if device not in ("cpu", "cuda"):
            raise ValueError(f"device must be 'cpu' or 'cuda', got {device!r}")
        self.device = device
        self.bodies = [checked_body(b, self.task_type) for b in bodies]
        self.world = task_world(self.task_type.id)
        self.tables = engine.body_tables(self.bodies, self.world, pad=pad)
        self.body_index = np.repeat(np.arange(len(self.bodies)), envs_per_body)
        self.robot_points = self.tables.n_robot_points[self.body_index]
        self.task = self.task_type(self.robot_points)
        self.width = self.task_type.obs_size(int(self.tables.max_robot_points))
        self.rngs = [np.random.default_rng() for _ in self.body_index]
        self.done = np.zeros(self.num_envs, dtype=bool)
        w, starts = self.world, self.world.point_starts
        self._objects = {name: (starts[name], len(kept)) for name, kept, rest in zip(w.names, w.kept, w.rest)
                         if len(kept) == len(rest)}
        self._partial = {name: (starts[name], kept, rest) for name, kept, rest in zip(w.names, w.kept, w.rest)
                         if len(kept) < len(rest)}
        self._static = {name: obj.pos for name, obj in zip(self.world.static_names, self.world.static)}
        self._spans: dict = {}  # the objects' point spans, the same in every frame of this batch
        self.state = engine.reset(self.tables, self.body_index)
        self.init = self.state.pos.copy()
        self._gpu: Any = None
        if device == "cuda":  # the physics on the GPU; the task reads the state back every step
            from . import gpu

            self._gpu = gpu.Stepper(self.tables)
        self._obs = np.zeros((self.num_envs, self.width))
        self.reset()

    @property
    def num_envs(self) -> int:
        return len(self.body_index)

    @property
    def obs_sizes(self) -> list[int]:
        return [self.task_type.obs_size(int(n)) for n in self.tables.n_robot_points[: len(self.bodies)]]

    @property
    def act_sizes(self) -> list[int]:
        return [int(n) for n in self.tables.n_act[: len(self.bodies)]]

    def seed(self, seeds: Sequence[int | None]) -> None:
        """Environment ``i`` draws its set-ups from ``seeds[i]`` (None: fresh entropy)."""
        self.rngs = [np.random.default_rng(s) for s in seeds]

    def frame(self, state: engine.State | None = None) -> Frame:
        state = self.state if state is None else state
        return Frame(pos=state.pos, vel=state.vel, init=self.init, robot_start=self.tables.robot_start,
                     robot_count=self.robot_points, objects=self._objects, static=self._static,
                     partial=self._partial, spans=self._spans)

    def _fresh_positions(self, mask: np.ndarray, options: Mapping[str, Any]) -> np.ndarray:
        pos = self.tables.init_pos[self.body_index].copy()
        placed = self.task.placements(self.rngs, mask, options=options)
        for name, at in (placed or {}).items():
            start, count = self._objects[name]
            for i in np.flatnonzero(mask):
                pos[i, start:start + count] = _placed(self.task_type.id, name, (int(at[i, 0]), int(at[i, 1])))
        return pos

    def reset(self, mask: np.ndarray | None = None, options: Mapping[str, Any] | None = None) -> np.ndarray:
        """Put environments (all, or where ``mask``) at the start of an episode; returns every observation.

        ``options`` impose one random set-up on all of them instead of drawing theirs (Catcher-v0's
        ``{"offset": (dx, dy)}``, BidirectionalWalker-v0's ``{"goals": [...]}``: the task's ``reset_options``).
        """
        mask = np.ones(self.num_envs, dtype=bool) if mask is None else np.asarray(mask, dtype=bool)
        options = dict(options or {})
        unknown = sorted(set(options) - set(self.task_type.reset_options))
        if unknown:
            takes = ", ".join(map(repr, self.task_type.reset_options)) or "none"
            raise ValueError(f"{self.task_type.id} has no reset option {unknown[0]!r} (its options: {takes})")
        fresh = engine.reset(self.tables, self.body_index, self._fresh_positions(mask, options))
        keep = ~mask[:, None, None]
        self.state = engine.State(
            pos=np.where(keep, self.state.pos, fresh.pos), vel=np.where(keep, self.state.vel, fresh.vel),
            vtrue=np.where(keep, self.state.vtrue, fresh.vtrue), body=self.body_index,
        )
        self.init = np.where(keep, self.init, fresh.pos)
        self.done[mask] = False
        frame = self.frame()
        self.task.reset(frame, mask, self.rngs, options=options)
        self._obs = np.where(mask[:, None], observation(self.task.observe(frame), self.width), self._obs)
        return self._obs.copy()

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Step every environment not done; returns ``(obs, reward, terminated, unstable)``."""
        active = ~self.done
        before = self.frame()
        if self._gpu is None:
            self.state, out = engine.step(self.tables, self.state, actions, active=active, threads=self.threads)
        else:
            self.state, out = self._gpu.step(self.state, actions, active)
        after = self.frame()
        unstable = out.unstable & active
        reward, ended = self.task.reward(before, after, unstable)
        reward = np.where(active, reward, 0.0)
        terminated = active & ended
        self.done |= terminated
        self._obs = np.where(active[:, None], observation(self.task.observe(after), self.width), self._obs)
        return self._obs.copy(), reward, terminated, unstable
