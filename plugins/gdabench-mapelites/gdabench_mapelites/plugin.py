"""The module the entry point names: it only describes the designer (no heavy imports)."""

import gdabench


@gdabench.hookimpl
def gdabench_designers():
    return [
        gdabench.DesignerSpec(
            name="map-elites",
            factory="gdabench_mapelites.designer:MapElites",
            description="MAP-Elites: best body per (voxel count, actuator share) cell, mutated from random elites",
        )
    ]
