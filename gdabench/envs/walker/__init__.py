"""The Walker-v0 task on a pymunk soft-voxel simulator.

Importing this package (``import gdabench`` does) registers the Gymnasium id
``gdabench/Walker-v0``; pymunk is imported only when an environment is made::

    import gdabench, gymnasium
    env = gymnasium.make("gdabench/Walker-v0", body="33333/31113/31013/31013/31013")

Modules: ``mesh`` (body -> point masses and springs), ``sim`` (pymunk world and
:class:`~gdabench.envs.walker.sim.WalkerPhysics`, every physical constant), ``gym_env`` (the
Gymnasium environment), ``render`` (frames and GIFs), ``env`` (the gdabench environment
``walker`` that scores bodies with a controller).
"""

from __future__ import annotations

import gymnasium

ENV_ID = "gdabench/Walker-v0"
#: Evolution Gym's episode length
MAX_EPISODE_STEPS = 500


def register_gym_envs() -> None:
    """Register ``gdabench/Walker-v0`` with Gymnasium (idempotent)."""
    if ENV_ID not in gymnasium.registry:
        gymnasium.register(id=ENV_ID, entry_point="gdabench.envs.walker.gym_env:WalkerEnv", max_episode_steps=MAX_EPISODE_STEPS)


register_gym_envs()
