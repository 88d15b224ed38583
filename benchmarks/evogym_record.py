"""Record Evolution Gym 2.0 trajectories for the voxel engine's parity tests (run in the plugin's venv).

    bash plugins/gdabench-evogym/install.sh /tmp/venv-evogym
    /tmp/venv-evogym/bin/python benchmarks/evogym_record.py tests/fixtures/voxel_parity.npz

Each case is a body placed in Walker-v0's world (a row of 100 fixed voxels) at a voxel position,
driven by a deterministic action sequence; the file holds, per case, the raw simulator positions
and velocities of the robot's points after every env step (``pos``/``vel``: ``(T, P, 2)``,
metres, before Evolution Gym's Python side rescales them) the actions, and whether each step was unstable.
CI reads the file; it never needs Evolution Gym.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import math
import os
import sys
from pathlib import Path

import numpy as np

#: the columns of the "unstable" case's actuators, in action order
WAVE40_COLUMNS = np.array([0, 1, 2, 3, 4, 0, 2, 4, 0, 2, 4, 0, 2, 4])

#: name -> (body rows top to bottom, (x, y) in voxels, steps, action(t, n_actuators) -> array)
CASES = {
    "falling-block": ("222/232/222", (3, 6), 60, lambda t, n: np.ones(n)),
    "lone-actuator": ("3", (1, 1), 60, lambda t, n: np.full(n, 1.6)),
    "standing": ("33333/40004/40004", (1, 1), 60, lambda t, n: np.ones(n)),
    "walking": ("11111/13331/40004/40004/40004", (1, 1), 100,
                lambda t, n: 1.1 + 0.5 * np.sin(2 * math.pi * t / 20 + np.arange(n))),
    "folding": ("44444/40000/44444/00004/44444", (1, 1), 150,
                lambda t, n: 1.1 + 0.5 * np.sin(2 * math.pi * t / 12 + 2.0 * np.arange(n))),
    # walker_fidelity's wave40 gait (phase = column index, vertical actuators a quarter period later):
    # Evolution Gym declares this body unstable at step 63
    "unstable": ("11111/44444/40404/40404/40404", (1, 1), 80,
                 lambda t, n: 1.1 + 0.5 * np.sin(2 * math.pi * t / 40 - WAVE40_COLUMNS - math.pi / 2)),
}


def record(name: str) -> dict[str, np.ndarray]:
    import evogym.envs
    from evogym import EvoSim, EvoWorld
    from evogym.simulator_cpp import Sim

    rows, (x, y), steps, action = CASES[name]
    body = np.array([[int(c) for c in r] for r in rows.split("/")])
    world = EvoWorld.from_json(os.path.join(evogym.envs.BenchmarkBase.DATA_PATH, "Walker-v0.json"))
    world.add_from_array("robot", body, x, y)
    with contextlib.redirect_stdout(io.StringIO()):
        sim = EvoSim(world)
    sim.reset()
    n = sim.get_dim_action_space("robot")
    pos, vel, unstable, acts = [], [], [], []
    pos0 = Sim.object_pos_at_time(sim, 0, "robot").T.copy()
    for t in range(steps):
        acts.append(np.clip(action(t, n), 0.6, 1.6))
        sim.set_action("robot", acts[-1])
        with contextlib.redirect_stdout(io.StringIO()):
            bad = sim.step()
        unstable.append(bad)
        now = sim.get_time()
        pos.append(Sim.object_pos_at_time(sim, now, "robot").T.copy())
        vel.append(Sim.object_vel_at_time(sim, now, "robot").T.copy())
        if bad:
            break
    return {f"{name}.body": np.array(rows), f"{name}.at": np.array([x, y]), f"{name}.pos0": pos0,
            f"{name}.actions": np.array(acts), f"{name}.pos": np.array(pos), f"{name}.vel": np.array(vel),
            f"{name}.unstable": np.array(unstable)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("path", type=Path, help="the .npz file to write (tests/fixtures/voxel_parity.npz)")
    args = parser.parse_args()
    try:
        data = {}
        for name in CASES:
            data.update(record(name))
    except ImportError as exc:
        print(f"error: Evolution Gym is not installed ({exc}); run this in plugins/gdabench-evogym's venv", file=sys.stderr)
        raise SystemExit(2) from None
    np.savez_compressed(args.path, **data)
    print(f"wrote {args.path}: {', '.join(CASES)}")


if __name__ == "__main__":
    main()
