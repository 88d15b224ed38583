"""Speed of Evolution Gym's tasks on the voxel engine against Evolution Gym itself, side by side, per task.

For each task: ``--batch`` environments of as many different bodies (Evolution Gym's random sampler,
seeded, 5x5, those the task can place) stepped as one :class:`~gdabench.envs.voxel.batch.TaskBatch` on one
thread (observations and rewards included: the env steps/s a user gets), and Evolution Gym 2.0's own
Gymnasium environment on the same bodies, one at a time.  Both play the same open-loop sinusoid; an episode
that ends is reset.  The two are timed in turn, ``--repeats`` times each, and the medians are compared.
Both are timed in the process's CPU time (one thread each: Numba's set to one, Evolution Gym's simulator
single-threaded), so that other work on a shared machine slows neither's figure; ``--clock wall`` times
wall-clock seconds instead, for a quiet machine.
Memory per environment: the batch's state and observation arrays, plus its tables' share.

Run it in the Evolution Gym plugin's venv (numba and Evolution Gym together)::

    /tmp/venv-evogym/bin/python benchmarks/compare/task_speed.py --out docs/benchmarks/output/task-speed.json
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import os
import platform
import time
from pathlib import Path
from typing import Any

import numba
import numpy as np

import gdabench
from gdabench.envs.tasks import CATALOG, task as definition
from gdabench.envs.tasks.base import checked_body


def gait(t: int, n: int, width: int) -> np.ndarray:
    wave = 1.1 + 0.5 * np.sin(2 * math.pi * t / 20 + np.arange(width))
    return np.ascontiguousarray(np.broadcast_to(wave, (n, width)))


def task_bodies(task: str, count: int, seed: int) -> list[gdabench.Body]:
    """``count`` sampler bodies that ``task`` can place (checked as the engine checks them)."""
    rng, out = np.random.default_rng(seed), []
    while len(out) < count:
        body = gdabench.random_body(rng, (5, 5))
        try:
            checked_body(body, definition(task))
        except ValueError:
            continue
        out.append(body)
    return out


CLOCK = time.process_time  # --clock: what both simulators are timed by


def engine_rate(task: str, bodies: list[gdabench.Body], seconds: float) -> tuple[float, float]:
    """(env steps/s, bytes per environment) of one batch of ``bodies``, one environment each."""
    from gdabench.envs.voxel.batch import TaskBatch

    batch = TaskBatch(task, bodies)
    batch.seed(list(range(len(bodies))))
    batch.reset()
    width = batch.tables.max_actuators
    n = batch.num_envs
    batch.step(gait(0, n, width))  # compile / warm
    steps, start = 0, CLOCK()
    while CLOCK() - start < seconds or steps < 3:
        _, _, terminated, _ = batch.step(gait(steps, n, width))
        if terminated.any():
            batch.reset(terminated)
        steps += 1
    rate = n * steps / (CLOCK() - start)
    arrays = (batch.state.pos, batch.state.vel, batch.state.vtrue, batch.init, batch._obs)
    per_env = sum(a.nbytes for a in arrays) / n
    per_env += sum(v.nbytes for v in vars(batch.tables).values() if isinstance(v, np.ndarray)) / n
    return rate, per_env


def evogym_rate(task: str, bodies: list[gdabench.Body], seconds: float) -> float:
    """Evolution Gym's env steps/s on ``bodies``, one environment at a time (its own Gymnasium env)."""
    import gymnasium
    from evogym_record import load_evogym

    load_evogym()
    steps, spent = 0, 0.0
    for i, body in enumerate(bodies):
        with contextlib.redirect_stdout(io.StringIO()):
            env = gymnasium.make(task, body=body.voxels.astype(float))
            env.reset(seed=i)
            n = env.action_space.shape[0]
            start = CLOCK()
            for t in range(100):
                _, _, done, _, _ = env.step(gait(t, 1, n)[0].copy())
                steps += 1
                if done:
                    env.reset()
            spent += CLOCK() - start
            env.close()
        if spent > seconds:
            break
    return steps / spent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", default="", help="comma-separated task ids (default: every task defined)")
    parser.add_argument("--batch", type=int, default=64, help="environments (one body each) per batch")
    parser.add_argument("--seconds", type=float, default=2.0, help="per timed run")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--clock", choices=["cpu", "wall"], default="cpu", help="what both are timed by")
    parser.add_argument("--out", type=Path, default=None, help="also write the rows as JSON here")
    args = parser.parse_args()
    global CLOCK
    CLOCK = time.process_time if args.clock == "cpu" else time.perf_counter
    tasks = [t for t in args.tasks.split(",") if t] or list(CATALOG)
    numba.set_num_threads(1)
    print(f"task speed, one core, {args.clock} time; numba {numba.__version__}, load {os.getloadavg()[0]:.1f}, "
          f"{platform.processor() or platform.machine()}")
    print("| task | grade | voxel env steps/s (B = %d) | Evolution Gym env steps/s | ratio | KB per env |" % args.batch)
    print("|---|---|--:|--:|--:|--:|")
    rows: list[dict[str, Any]] = []
    for name in tasks:
        try:
            definition(name)
        except KeyError:
            continue
        bodies = task_bodies(name, args.batch, args.seed)
        ours, theirs, memory = [], [], 0.0
        for _ in range(args.repeats):  # in turn, so that load on the machine falls on both
            rate, memory = engine_rate(name, bodies, args.seconds)
            ours.append(rate)
            theirs.append(evogym_rate(name, bodies, args.seconds))
        row = {"task": name, "difficulty": CATALOG[name].difficulty, "batch": args.batch,
               "voxel": float(np.median(ours)), "evogym": float(np.median(theirs)),
               "voxel_runs": [round(r) for r in ours], "evogym_runs": [round(r) for r in theirs],
               "bytes_per_env": round(memory)}
        row["ratio"] = row["voxel"] / row["evogym"]
        rows.append(row)
        print(f"| {name} | {row['difficulty']} | {row['voxel']:,.0f} | {row['evogym']:,.0f} | {row['ratio']:.1f}x "
              f"| {memory / 1e3:.0f} |", flush=True)
        if args.out:
            args.out.write_text(json.dumps({"command": "benchmarks/compare/task_speed.py", "batch": args.batch,
                                            "seconds": args.seconds, "repeats": args.repeats, "clock": args.clock,
                                            "load_at_start": os.getloadavg()[0], "rows": rows}, indent=1) + "\n")


if __name__ == "__main__":
    main()
