"""Hooks: one gdabench environment ``evogym/<task id>`` per Evolution Gym task."""

import gdabench
from gdabench.envs.tasks.catalog import CATALOG

from .tasks import TASKS


@gdabench.hookimpl
def gdabench_environments():
    return [
        gdabench.EnvironmentSpec(
            name=f"evogym/{task}",
            factory="gdabench_evogym.env:EvogymTask",
            description=f"[{CATALOG[task].difficulty}] {CATALOG[task].summary}: Evolution Gym 2.0's {task} on its "
                        "own C++ simulator; needs a controller",
            defaults={"task": task},
            requires_controller=True,
        )
        for task in TASKS
    ]
