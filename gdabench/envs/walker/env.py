"""The gdabench environment ``walker``: a body's score is what a controller makes it walk.

``walker`` is ``voxel/Walker-v0`` (:class:`~gdabench.envs.voxel.env.VoxelTask`) with a choice of engine:

* ``voxel`` (the default): ``gdabench/Walker-v2``, Evolution Gym 2.0's own physics on the batched
  voxel engine (:mod:`gdabench.envs.voxel`);
* ``pymunk``: ``gdabench/Walker-v1``, the earlier pymunk simulator calibrated against it.
"""

from __future__ import annotations

from typing import Any, Sequence

import gymnasium

from ...body import Body
from ...environment import Bodies
from ...errors import ConfigError
from .. import voxel
from ..voxel.env import VoxelTask
from . import ENV_ID

#: engine name -> the Gymnasium id it runs
ENGINES = {"voxel": voxel.ENV_ID, "pymunk": ENV_ID}


def make_walker(body: Body, engine: str = "voxel", **kwargs: Any) -> gymnasium.Env:
    """A fresh walker Gymnasium env for ``body`` on ``engine`` (picklable through functools.partial)."""
    return gymnasium.make(ENGINES[engine], body=body.text, **kwargs)


class Walker(VoxelTask):
    """Evolution Gym's Walker-v0; needs a controller.

    Parameters:
        engine: the simulator: voxel (Evolution Gym's physics, gdabench/Walker-v2) or pymunk (gdabench/Walker-v1)
    """

    def __init__(self, *, shape: tuple[int, int] = (5, 5), engine: str = "voxel"):
        super().__init__(shape=shape, task="Walker-v0")
        if engine not in ENGINES:
            raise ConfigError(f"walker: engine must be one of {', '.join(ENGINES)}, got {engine!r}")
        self.engine = engine
        #: the physics every row records (``env_version``): the Gymnasium id names the engine
        self.version = ENGINES[engine]

    def invalid_reason(self, body: Body) -> str | None:
        return super(VoxelTask, self).invalid_reason(body)

    def make_env(self, body: Body, **kwargs: Any) -> gymnasium.Env:
        return make_walker(body, self.engine, **kwargs)

    def bodies(self, bodies: Sequence[Body]) -> Bodies:
        if self.engine != "voxel":
            h, w = self.shape
            return Bodies(super(VoxelTask, self).bodies(bodies).make_envs, pad=(2 + 2 * (h + 1) * (w + 1), h * w))
        return super().bodies(bodies)
