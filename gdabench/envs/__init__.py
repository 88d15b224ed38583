"""Built-in environments (registered through the ``gdabench_environments`` hook)."""

from __future__ import annotations

from ..specs import EnvironmentSpec, SuiteSpec, hookimpl
from .tasks.catalog import ENTRIES

#: Evolution Gym's grades, in the order suites list them
GRADES = ("easy", "medium", "hard")


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
            description="[easy] Evolution Gym's Walker-v0 on its own physics, batched (voxel/Walker-v0; "
                        "engine=pymunk: gdabench/Walker-v1); needs a controller",
            requires_controller=True,
        ),
        *(
            EnvironmentSpec(
                name=f"voxel/{entry.id}",
                factory="gdabench.envs.voxel.env:VoxelTask",
                description=f"[{entry.difficulty}] {entry.summary}: Evolution Gym's {entry.id} on the voxel engine; "
                            "needs a controller",
                defaults={"task": entry.id},
                requires_controller=True,
            )
            for entry in ENTRIES
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
            description="NK landscape: each voxel's score depends on itself and the K voxels before it; K sets "
                        "ruggedness",
        ),
    ]


@hookimpl
def gdabench_suites() -> list[SuiteSpec]:
    return [
        SuiteSpec(
            name="landscapes",
            envs=("simple", "two-peaks", "target", "nk[k=0]", "nk[k=4]"),
            description="The analytic rewards: sum of voxels, a deceptive two-peak, a target body, NK smooth and "
                        "rugged",
        ),
        SuiteSpec(
            name="walker",
            envs=("walker",),
            controller="ppo",
            description="Co-design on physics: Walker with PPO learning each body's controller (thesis section 5.1)",
        ),
        SuiteSpec(
            name="evogym",
            envs=tuple(f"voxel/{entry.id}" for entry in ENTRIES),
            controller="ppo",
            description="Evolution Gym's 32 tasks on the voxel engine, PPO learning each body's controller",
        ),
        *(
            SuiteSpec(
                name=f"evogym-{grade}",
                envs=tuple(f"voxel/{entry.id}" for entry in ENTRIES if entry.difficulty == grade),
                controller="ppo",
                description=f"Evolution Gym's {grade} tasks on the voxel engine, with PPO",
            )
            for grade in GRADES
        ),
    ]
