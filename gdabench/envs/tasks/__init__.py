"""Evolution Gym 2.0's tasks, stated over arrays and independent of any simulator.

Each task (:class:`~gdabench.envs.tasks.base.Task`) is its sim file's world, where the robot goes, the
observation (same parts, same order), the reward with its bonuses and penalties, termination, the step
limit and the reset of tasks with random set-ups, as ``evogym/envs/*.py`` define them.  The voxel engine
(:mod:`gdabench.envs.voxel`) runs them; nothing here imports it.

Modules: ``catalog`` (ids, grades, step limits: plain data), ``sense`` (what tasks read of a simulation:
centres of mass, orientation, floor and ceiling), ``base`` (the task interface, the worlds of
``worlds.json``), and one module per family of Evolution Gym's task files, imported when a task of it is
first asked for.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from .catalog import CATALOG, ENTRIES, Entry

if TYPE_CHECKING:
    from .base import Task

__all__ = ["CATALOG", "ENTRIES", "Entry", "task"]


def task(name: str) -> type[Task]:
    """The definition of task ``name`` (an Evolution Gym id such as ``Carrier-v0``), or a one-line KeyError."""
    entry = CATALOG.get(name)
    if entry is None:
        raise KeyError(f"unknown Evolution Gym task {name!r}; tasks: {', '.join(CATALOG)}")
    try:
        module = importlib.import_module(f"{__name__}.{entry.module}")
    except ModuleNotFoundError as exc:
        if exc.name != f"{__name__}.{entry.module}":
            raise
        module = None
    for defined in getattr(module, "DEFINED", ()):
        if defined.id == name:
            return defined
    raise KeyError(f"Evolution Gym task {name!r} is not yet available on the voxel engine")
