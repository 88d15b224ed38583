"""The module the entry point names: it only describes what the plugin offers (no heavy imports)."""

import gdabench


@gdabench.hookimpl
def gdabench_designers():
    return [
        gdabench.DesignerSpec(
            name="hill-climber",
            factory="gdabench_checkerboard.designer:HillClimber",
            description="Every child is a mutation of the best body found so far",
        )
    ]


@gdabench.hookimpl
def gdabench_environments():
    return [
        gdabench.EnvironmentSpec(
            name="checkerboard",
            factory="gdabench_checkerboard.environment:Checkerboard",
            description="Share of neighbouring voxels that differ (optimum 100: a checkerboard)",
        )
    ]
