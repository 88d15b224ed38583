"""Record Evolution Gym 2.0 trajectories for the voxel engine's parity tests (run in the plugin's venv).

    bash plugins/gdabench-evogym/install.sh /tmp/venv-evogym
    /tmp/venv-evogym/bin/python benchmarks/compare/evogym_record.py tests/fixtures/voxel_parity.npz
    /tmp/venv-evogym/bin/python benchmarks/compare/evogym_record.py tests/fixtures/tasks --tasks [TASK ...]

``--tasks``: one file per task, ``<folder>/<task>.npz`` (every task of Evolution Gym 2.0, or those named):
for each of :data:`TASK_BODIES`, one episode's first
:data:`TASK_STEPS` steps of the task's own Gymnasium environment under a fixed gait: the raw point positions
of every object at the start and of every object that can move after each step, the observations, rewards
and ``done`` flags, and the random set-up where the task draws one (Catcher-v0's offsets,
BidirectionalWalker-v0's goals), drawn from Python's ``random`` seeded with 0.

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


#: two 5x5 bodies every task can take: a walker with legs, and one of Evolution Gym's random samples
TASK_BODIES = ("11111/13331/40004/40004/40004", "32423/22443/04213/01412/31233")
TASK_STEPS = 20


def gait(t: int, n: int) -> np.ndarray:
    """The fixed gait of the task recordings: a wave along the actuators with a slow beat."""
    k = np.arange(n)
    return np.clip(1.1 + 0.45 * np.sin(2 * math.pi * t / 16 + 1.3 * k) * np.cos(2 * math.pi * t / 90), 0.6, 1.6)


class ZeroedEmpty:
    """numpy for ``evogym.sim``, with ``empty`` giving zeros.  ``EvoSim`` passes ``np.empty((2, 1))`` as the
    connections of an object without any (a single voxel: Traverser-v0's 1x1 block); the C++ side reads those
    uninitialised numbers as voxel indices, which crashes at random.  Zeros are a connection of voxel 0 to itself,
    which it ignores: the block has no connections, as intended."""

    def __getattr__(self, name: str):
        return np.zeros if name == "empty" else getattr(np, name)


def load_evogym() -> None:
    """Import Evolution Gym quietly (its tasks registered) with :class:`ZeroedEmpty` in place, so that every task's
    world builds without a crash."""
    with contextlib.redirect_stdout(io.StringIO()):
        import evogym.envs  # registers the tasks
        import evogym.sim
    evogym.sim.np = ZeroedEmpty()


def record_task(task: str, index: int, steps: int) -> dict[str, np.ndarray]:
    import random

    import gymnasium
    from evogym.simulator_cpp import Sim

    load_evogym()
    body_text = TASK_BODIES[index]
    body = np.array([[int(c) for c in r] for r in body_text.split("/")])
    random.seed(0)
    with contextlib.redirect_stdout(io.StringIO()):
        env = gymnasium.make(task, body=body)
        obs0, _ = env.reset(seed=0)
    raw = env.unwrapped
    sim = raw.sim
    names = sorted(raw.world.objects)
    grids = {name: raw.world.objects[name].grid for name in names}
    moving = [name for name in names if np.any((grids[name] != 0) & (grids[name] != 5))]
    key = f"{task}/{index}"
    out = {
        f"{key}/body": np.array(body_text),
        f"{key}/obs0": np.asarray(obs0, dtype=np.float64),
        f"{key}/moving": np.array(moving),
    }
    for name in names:
        out[f"{key}/pos0/{name}"] = Sim.object_pos_at_time(sim, sim.get_time(), name).T.copy()
    if hasattr(raw, "offsetx"):
        out[f"{key}/offset"] = np.array([raw.offsetx, raw.offsety])
    if hasattr(raw, "goals"):
        out[f"{key}/goals"] = np.array([g.x_goal for g in raw.goals])
    n = raw.get_actuator_indices("robot").size
    obs, rewards, done, actions = [], [], [], []
    pos: dict[str, list[np.ndarray]] = {name: [] for name in moving}
    for t in range(steps):
        actions.append(gait(t, n))
        with contextlib.redirect_stdout(io.StringIO()):
            o, r, terminated, truncated, _ = env.step(actions[-1])
        obs.append(np.asarray(o, dtype=np.float64))
        rewards.append(float(r))
        done.append(bool(terminated))
        for name in moving:
            pos[name].append(Sim.object_pos_at_time(sim, sim.get_time(), name).T.copy())
        if terminated or truncated:
            break
    out.update(
        {
            f"{key}/actions": np.array(actions),
            f"{key}/obs": np.array(obs),
            f"{key}/reward": np.array(rewards),
            f"{key}/done": np.array(done),
        }
    )
    for name in moving:
        out[f"{key}/pos/{name}"] = np.array(pos[name])
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "path",
        type=Path,
        help="the .npz file to write (tests/fixtures/voxel_parity.npz), or with "
        "--tasks the folder of the tasks' files (tests/fixtures/tasks)",
    )
    parser.add_argument(
        "--tasks",
        nargs="*",
        metavar="TASK",
        default=None,
        help="record Evolution Gym's tasks (all, or those named) instead of the walker cases",
    )
    parser.add_argument("--steps", type=int, default=TASK_STEPS, help="env steps per task recording")
    args = parser.parse_args()
    try:
        if args.tasks is None:
            data = {}
            for name in CASES:
                data.update(record(name))
            np.savez_compressed(args.path, **data)
            print(f"wrote {args.path}: {', '.join(CASES)}")
            return
        import evogym

        args.path.mkdir(parents=True, exist_ok=True)
        for task in args.tasks or list(evogym.BASELINE_ENV_NAMES):
            data = {}
            for index in range(len(TASK_BODIES)):
                data.update(record_task(task, index, args.steps))
            np.savez_compressed(args.path / f"{task}.npz", **data)
            print(f"wrote {args.path / task}.npz")
    except ImportError as exc:
        print(
            f"error: Evolution Gym is not installed ({exc}); run this in plugins/gdabench-evogym's venv",
            file=sys.stderr,
        )
        raise SystemExit(2) from None


if __name__ == "__main__":
    main()
