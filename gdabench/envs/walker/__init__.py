"""The Walker-v0 task of Evolution Gym on a pymunk soft-voxel simulator.

Importing this package (``import gdabench`` does) registers the Gymnasium id
``gdabench/Walker-v1``; pymunk is imported only when an environment is made::

    import gdabench, gymnasium
    env = gymnasium.make("gdabench/Walker-v1", body="33333/31113/31013/31013/31013")

``gdabench/Walker-v0``, the first, uncalibrated physics, is retired: making it raises a
one-line error that names v1 (Gymnasium's rule: changed dynamics get a new version).

Modules: ``mesh`` (body -> point masses and springs), ``sim`` (pymunk world and
:class:`~gdabench.envs.walker.sim.WalkerPhysics`, every physical constant), ``gym_env`` (the
Gymnasium environment), ``render`` (frames), ``env`` (the gdabench environment
``walker`` that scores bodies with a controller).
"""

from __future__ import annotations

from typing import Any, NoReturn

import gymnasium

from ...errors import ConfigError

ENV_ID = "gdabench/Walker-v1"
RETIRED_IDS = ("gdabench/Walker-v0",)
#: Evolution Gym's episode length
MAX_EPISODE_STEPS = 500


def retired(**kwargs: Any) -> NoReturn:
    """Entry point of retired ids: one line saying what to use instead."""
    raise ConfigError(
        f"{RETIRED_IDS[0]} is retired (its physics was never calibrated against Evolution Gym); use "
        f"gdabench/Walker-v2 (Evolution Gym's own physics, also voxel/Walker-v0) or {ENV_ID} (pymunk)"
    )


def register_gym_envs() -> None:
    """Register ``gdabench/Walker-v1`` and the retired ids with Gymnasium (idempotent)."""
    if ENV_ID not in gymnasium.registry:
        gymnasium.register(
            id=ENV_ID, entry_point="gdabench.envs.walker.gym_env:WalkerEnv", max_episode_steps=MAX_EPISODE_STEPS
        )
    for old in RETIRED_IDS:
        if old not in gymnasium.registry:
            gymnasium.register(id=old, entry_point="gdabench.envs.walker:retired")


register_gym_envs()
