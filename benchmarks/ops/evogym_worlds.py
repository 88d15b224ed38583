"""Write the task worlds of Evolution Gym 2.0 (``envs/sim_files/*.json``) in gdabench's form (plugin's venv).

    bash plugins/gdabench-evogym/install.sh /tmp/venv-evogym
    /tmp/venv-evogym/bin/python benchmarks/ops/evogym_worlds.py gdabench/envs/tasks/worlds.json

Each world is read with Evolution Gym's own ``EvoWorld.from_json`` and written as its objects: a name,
the voxel position of the object's bottom-left cell, and its cells as rows of codes (top row first).
Every object of these files connects all its adjacent cells, which this script checks, so connections are
not stored.  The layouts are Evolution Gym's (MIT License, Copyright (c) 2022 jagdeepsb); CI reads the
written file and never needs Evolution Gym.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import sys
from pathlib import Path


def read_worlds() -> dict:
    with contextlib.redirect_stdout(io.StringIO()):  # it announces its version on import
        import evogym.envs
    from evogym import EvoWorld
    from evogym.utils import get_full_connectivity

    folder = evogym.envs.BenchmarkBase.DATA_PATH
    worlds = {}
    for file in sorted(os.listdir(folder)):
        if not file.endswith(".json"):
            continue
        world = EvoWorld.from_json(os.path.join(folder, file))
        objects = {}
        for name, obj in world.objects.items():
            grid = obj.get_structure()  # rows top to bottom
            full = {tuple(sorted(p)) for p in get_full_connectivity(grid).T.tolist()}
            conns = obj.get_connections()
            given = {tuple(sorted(p)) for p in conns.T.tolist()} if conns.size else set()
            if full != given:
                raise SystemExit(f"error: {file}: object {name} does not connect all its adjacent cells")
            objects[name] = {
                "at": [int(obj.pos.x), int(obj.pos.y)],
                "rows": ["".join(str(int(c)) for c in row) for row in grid],
            }
        worlds[file.removesuffix(".json")] = {
            "size": [int(world.grid_size.x), int(world.grid_size.y)],
            "objects": objects,
        }
    return worlds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("path", type=Path, help="the file to write (gdabench/envs/tasks/worlds.json)")
    args = parser.parse_args()
    try:
        worlds = read_worlds()
    except ImportError as exc:
        print(
            f"error: Evolution Gym is not installed ({exc}); run this in plugins/gdabench-evogym's venv",
            file=sys.stderr,
        )
        raise SystemExit(2) from None
    source = "Evolution Gym 2.0.0, evogym/envs/sim_files (MIT License, Copyright (c) 2022 jagdeepsb)"
    args.path.write_text(json.dumps({"source": source, "worlds": worlds}, indent=1) + "\n")
    print(f"wrote {args.path}: {len(worlds)} worlds")


if __name__ == "__main__":
    main()
