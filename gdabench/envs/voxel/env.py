"""The gdabench environments ``voxel/<task>``: a body's score on an Evolution Gym task is what a controller
makes it do there, on the voxel engine.

``--env voxel/Carrier-v0`` mirrors the Evolution Gym plugin's ``evogym/Carrier-v0`` (the C++ simulator), so
an experiment switches simulator by its prefix.  Scoring and report animations come from
:class:`~gdabench.envs.controlled.ControlledEnvironment`; a controller that learns many bodies at once gets
them as one array batch of the task (:class:`~gdabench.envs.voxel.batch.TaskBatch`).
"""

from __future__ import annotations

import functools
import warnings
from typing import Any, Sequence

import gymnasium
import numpy as np

from ...body import Body
from ...environment import Bodies
from ...errors import ConfigError
from ...sdk import ArrayBodies
from ..controlled import ControlledEnvironment
from ..tasks import CATALOG
from . import env_id


class VoxelTask(ControlledEnvironment):
    """One of Evolution Gym's 32 tasks on the voxel engine; needs a controller.

    Parameters:
        task: the Evolution Gym id (Walker-v0, Carrier-v0, ...)
        device: where a controller's batches step the physics: cpu, or cuda (an NVIDIA GPU, with the gpu extra;
            pays from thousands of environments at once: docs/environments/voxel-engine.md)
    """

    def __init__(self, *, shape: tuple[int, int] = (5, 5), task: str = "Walker-v0", device: str = "cpu"):
        super().__init__(shape=shape)
        if task not in CATALOG:
            raise ConfigError(f"unknown Evolution Gym task {task!r}; tasks: {', '.join(CATALOG)}")
        if device not in ("cpu", "cuda"):
            raise ConfigError(f"{env_id(task)}: device must be cpu or cuda, got {device!r}")
        self.task = task
        self.device = device
        #: the physics and task every row records (``env_version``)
        self.version: str = env_id(task)

    def invalid_reason(self, body: Body) -> str | None:
        reason = super().invalid_reason(body)
        if reason is None:
            from ..tasks import task as definition
            from ..tasks.base import checked_body

            try:
                checked_body(body, definition(self.task))
            except ValueError as exc:
                return str(exc)
        return reason

    def make_env(self, body: Body, **kwargs: Any) -> gymnasium.Env:
        with warnings.catch_warnings():  # "voxel/Carrier-v0 is out of date": Carrier-v1 is another task, not a new
            warnings.filterwarnings("ignore", message=".*is out of date", category=DeprecationWarning)  # version
            return gymnasium.make(env_id(self.task), body=body.text, **kwargs)

    def bodies(self, bodies: Sequence[Body]) -> Bodies:
        """The bodies' Gymnasium environments and all of them as one array batch; every batch is padded as
        for the largest body of the shape (``(h + 1)(w + 1)`` points, ``h w`` actuators), so a body learns the
        same in any batch and alone."""
        from ..tasks import task as definition
        from . import batch, engine  # Numba loads here, not when gdabench is imported

        h, w = self.shape
        defined = definition(self.task)
        pad = (defined.obs_size((h + 1) * (w + 1)), h * w)
        make_envs = [functools.partial(self.make_env, body) for body in bodies]
        tables = engine.body_tables([np.full(self.shape, 4, dtype=np.int8)], batch.task_world(self.task))

        def make_batch(indices: Sequence[int], n: int) -> ArrayBodies:
            simulator = batch.TaskBatch(defined, [bodies[i] for i in indices], n, pad=tables, device=self.device)
            return ArrayBodies(simulator, n, defined.max_episode_steps)

        return Bodies(make_envs, make_batch, pad)
