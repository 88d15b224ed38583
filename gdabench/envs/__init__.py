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
            description="Evolution Gym's Walker-v0 on a pymunk soft-voxel simulator calibrated against it (gdabench/Walker-v1); needs a controller",
            requires_controller=True,
        ),
        EnvironmentSpec(
            name="two-peaks",
            factory="gdabench.envs.two_peaks:TwoPeaks",
            description="Thesis author's second reward on 5x5 bodies: a narrow peak (100) and a wide decoy (50)",
        ),
        EnvironmentSpec(
            name="target",
            factory="gdabench.envs.target:TargetBody",
            description="Share of voxels matching a target body (default: a two-legged walker), 0-100",
        ),
        EnvironmentSpec(
            name="nk",
            factory="gdabench.envs.nk:NKLandscape",
            description="NK landscape: each voxel's score depends on itself and the K voxels before it; K sets ruggedness",
        ),
    ]
