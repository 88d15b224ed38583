"""A batched soft-voxel engine with Evolution Gym 2.0's physics (Numba, CPU).

Importing this package (``import gdabench`` does) registers the Gymnasium id
``gdabench/Walker-v2`` and its vector entry point; Numba loads only when an environment is made.

Modules: ``model`` (a body as Evolution Gym builds it: points, edges, boxels), ``kernels`` (the
physics of one env step for many environments), ``engine`` (tables, state, the pure ``step``),
``walker`` (Walker-v0's task on it: a batch of bodies, the Gymnasium environments).
"""

from __future__ import annotations

import gymnasium

ENV_ID = "gdabench/Walker-v2"
MAX_EPISODE_STEPS = 500


def register_gym_envs() -> None:
    """Register ``gdabench/Walker-v2`` (and its vector entry point) with Gymnasium (idempotent)."""
    if ENV_ID not in gymnasium.registry:
        gymnasium.register(
            id=ENV_ID,
            entry_point="gdabench.envs.voxel.walker:WalkerEnv",
            vector_entry_point="gdabench.envs.voxel.walker:WalkerVectorEnv",
            max_episode_steps=MAX_EPISODE_STEPS,
        )


register_gym_envs()
