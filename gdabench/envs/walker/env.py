"""The gdabench environment ``walker``: a body's score is what a controller makes it walk.

The harness passes the controller chosen with ``--controller``; scoring and report animations
come from :class:`~gdabench.envs.controlled.ControlledEnvironment`, which hands the controller
fresh Gymnasium environments, so a controller written against Gymnasium (open-loop, PPO, ...)
never needs to know which simulator runs underneath.  ``engine`` chooses it:

* ``voxel`` (the default): ``gdabench/Walker-v2``, Evolution Gym 2.0's own physics on the batched
  voxel engine (:mod:`gdabench.envs.voxel`);
* ``pymunk``: ``gdabench/Walker-v1``, the earlier pymunk simulator calibrated against it.
"""

from __future__ import annotations

import functools
from typing import Any, Sequence

import gymnasium
import numpy as np

from ...body import Body
from ...environment import Bodies
from ...errors import ConfigError
from .. import voxel
from ..batched import ArrayBodies
from ..controlled import ControlledEnvironment
from . import ENV_ID

#: engine name -> the Gymnasium id it runs
ENGINES = {"voxel": voxel.ENV_ID, "pymunk": ENV_ID}


def make_walker(body: Body, engine: str = "voxel", **kwargs: Any) -> gymnasium.Env:
    """A fresh walker Gymnasium env for ``body`` on ``engine`` (picklable through functools.partial)."""
    return gymnasium.make(ENGINES[engine], body=body.text, **kwargs)


class Walker(ControlledEnvironment):
    """Evolution Gym's Walker-v0; needs a controller.

    Parameters:
        engine: the simulator: voxel (Evolution Gym's physics, gdabench/Walker-v2) or pymunk (gdabench/Walker-v1)
    """

    def __init__(self, *, shape: tuple[int, int] = (5, 5), engine: str = "voxel"):
        super().__init__(shape=shape)
        if engine not in ENGINES:
            raise ConfigError(f"walker: engine must be one of {', '.join(ENGINES)}, got {engine!r}")
        self.engine = engine
        #: the physics every row records (``env_version``): the Gymnasium id names the engine
        self.version = ENGINES[engine]

    def make_env(self, body: Body, **kwargs: Any) -> gymnasium.Env:
        return make_walker(body, self.engine, **kwargs)

    def bodies(self, bodies: Sequence[Body]) -> Bodies:
        """The bodies' Gymnasium environments and, on the voxel engine, all of them as one array batch;
        every batch is padded as for the largest body of the shape (``(h + 1)(w + 1)`` points,
        ``h w`` actuators), so a body learns the same in any batch and alone."""
        h, w = self.shape
        pad = (2 + 2 * (h + 1) * (w + 1), h * w)
        make_envs = [functools.partial(self.make_env, body) for body in bodies]
        if self.engine != "voxel":
            return Bodies(make_envs, pad=pad)
        from ..voxel import engine, walker  # Numba loads here, not when gdabench is imported

        tables = engine.body_tables([np.full(self.shape, 4, dtype=np.int8)])

        def make_batch(indices: Sequence[int], n: int) -> ArrayBodies:
            simulator = walker.WalkerBatch([bodies[i] for i in indices], n, pad=tables)
            return ArrayBodies(simulator, n, voxel.MAX_EPISODE_STEPS)

        return Bodies(make_envs, make_batch, pad)
