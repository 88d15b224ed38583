"""A batched soft-voxel engine with Evolution Gym 2.0's physics (Numba, CPU), and Evolution Gym's tasks on it.

Importing this package (``import gdabench`` does) registers the Gymnasium ids ``voxel/<task>`` for every
task of Evolution Gym 2.0 (e.g. ``voxel/Carrier-v0``) and ``gdabench/Walker-v2`` (``voxel/Walker-v0``
under its first name), each with a vector entry point; Numba loads only when an environment is made.

Modules: ``model`` (an object as Evolution Gym builds it: points, edges, boxels), ``kernels`` (the
physics of one env step for many environments), ``engine`` (worlds, tables, state, the pure ``step``),
``batch`` (a task on the engine for a batch of bodies), ``gym_env`` (the Gymnasium environments),
``render`` (frames), ``gpu`` (the same kernels compiled for CUDA).
"""

from __future__ import annotations

import gymnasium

from ..tasks.catalog import ENTRIES

#: the first id of the voxel walker, kept: ``voxel/Walker-v0`` under another name
ENV_ID = "gdabench/Walker-v2"
MAX_EPISODE_STEPS = 500
#: the engine splits a batch over threads from this many environments on (smaller ones step on the calling
#: thread: waking threads costs more than they save)
PARALLEL_FROM = 8


def env_id(task: str) -> str:
    """The Gymnasium id of Evolution Gym's task ``task`` on the voxel engine."""
    return f"voxel/{task}"


def register_gym_envs() -> None:
    """Register ``voxel/<task>`` for every task, and ``gdabench/Walker-v2`` (idempotent)."""
    ids = {env_id(e.id): e for e in ENTRIES} | {ENV_ID: ENTRIES[0]}
    for name, entry in ids.items():
        if name not in gymnasium.registry:
            gymnasium.register(
                id=name,
                entry_point="gdabench.envs.voxel.gym_env:VoxelEnv",
                vector_entry_point="gdabench.envs.voxel.gym_env:VoxelVectorEnv",
                max_episode_steps=entry.max_episode_steps,
                kwargs={"task": entry.id},
            )


register_gym_envs()
