"""Built-in environments (registered through the ``gdabench_environments`` hook)."""

from __future__ import annotations

from ..hookspecs import hookimpl
from ..specs import EnvironmentSpec


@hookimpl
def gdabench_environments() -> list[EnvironmentSpec]:
    return [
        EnvironmentSpec(
            name="simple",
            factory="gdabench.envs.simple:SumOfVoxels",
            description="Thesis's simplified reward: sum of the voxel codes (optimum: all vertical actuators)",
        ),
        EnvironmentSpec(
            name="walker",
            factory="gdabench.envs.walker.env:Walker",
            description="Evolution Gym's Walker-v0 on a pymunk soft-voxel simulator (gdabench/Walker-v0); needs a controller",
            requires_controller=True,
        ),
    ]
