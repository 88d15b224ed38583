"""Speed of the voxel engine: env steps per second against batch size and body shape, memory, and
Evolution Gym's own simulator side by side in the same run.

Bodies are Evolution Gym's random sampler's (``gdabench.random_body``, seeded), driven by an
open-loop sinusoid; a batch of B environments holds B different bodies (cycled when B exceeds
``--bodies``).  Each cell is the median of ``--repeats`` timed runs of ``--seconds`` each, on one
thread (env steps/s per core); the last table uses every core.  Memory is the bytes of the batch's
state, tables and per-step outputs.  With Evolution Gym installed (run it in the plugin's venv), it
is timed on the same 5x5 bodies, one environment at a time, interleaved with ours.

    python benchmarks/compare/voxel_speed.py                                  # the docs' table
    python benchmarks/compare/voxel_speed.py --shapes 5x5 --batches 64 --repeats 5
"""

from __future__ import annotations

import argparse
import contextlib
import io
import math
import os
import time

import numba
import numpy as np

import gdabench
from gdabench.envs.voxel import engine


def actions(t: int, n: int, width: int) -> np.ndarray:
    return np.broadcast_to(1.1 + 0.5 * np.sin(2 * math.pi * t / 20 + np.arange(width)), (n, width))


def bodies_of(shape: tuple[int, int], count: int, seed: int) -> list[gdabench.Body]:
    rng = np.random.default_rng(seed)
    return [gdabench.random_body(rng, shape) for _ in range(count)]


def time_batch(bodies: list[gdabench.Body], batch: int, seconds: float) -> tuple[float, int, int]:
    """Env steps/s of ``batch`` environments over ``bodies``; also bytes in use and unstable envs."""
    tables = engine.body_tables(bodies)
    index = np.arange(batch) % len(bodies)
    state = engine.reset(tables, index)
    width = tables.max_actuators
    state, out = engine.step(tables, state, actions(0, batch, width))  # compile / warm
    steps, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds or steps < 3:
        state, out = engine.step(tables, state, actions(steps, batch, width))
        steps += 1
    rate = batch * steps / (time.perf_counter() - start)
    used = sum(a.nbytes for a in (state.pos, state.vel, state.vtrue))
    used += sum(v.nbytes for k, v in vars(tables).items() if isinstance(v, np.ndarray)) * batch // len(bodies)
    return rate, used, int(out.unstable.sum())


def evogym_rate(bodies: list[gdabench.Body], seconds: float) -> float | None:
    """Evolution Gym's env steps/s on these bodies (Walker-v0, one env at a time), or None without it."""
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            import evogym.envs  # noqa: F401
    except ImportError:
        return None
    from task_speed import evogym_rate as task_rate  # (a script beside this one)

    return task_rate("Walker-v0", bodies, seconds)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--shapes", default="5x5,8x8,12x12")
    parser.add_argument("--batches", default="1,16,64,256,1024")
    parser.add_argument("--bodies", type=int, default=64, help="distinct bodies per shape")
    parser.add_argument("--seconds", type=float, default=2.0, help="per timed run")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    shapes = [tuple(int(v) for v in s.split("x")) for s in args.shapes.split(",")]
    batches = [int(b) for b in args.batches.split(",")]
    cores = numba.config.NUMBA_NUM_THREADS
    print(f"voxel engine speed; numba {numba.__version__}, {cores} threads available, load {os.getloadavg()[0]:.1f}")
    print("| shape | B | env steps/s per core (median) | runs | memory MB | unstable |")
    print("|---|--:|--:|---|--:|--:|")
    evo, ours = None, None
    for shape in shapes:
        bodies = bodies_of(shape, args.bodies, args.seed)
        numba.set_num_threads(1)
        for batch in batches:
            runs = []
            for _ in range(args.repeats):
                rate, used, unstable = time_batch(bodies, batch, args.seconds)
                runs.append(rate)
                if shape == (5, 5) and batch == 64 and evo is None:
                    evo = evogym_rate(bodies, args.seconds)
            if shape == (5, 5) and batch == 64:
                ours = float(np.median(runs))
            print(f"| {shape[0]}x{shape[1]} | {batch} | {np.median(runs):,.0f} | {', '.join(f'{r:,.0f}' for r in runs)}"
                  f" | {used / 1e6:.1f} | {unstable} |", flush=True)
    numba.set_num_threads(cores)
    whole = [time_batch(bodies_of((5, 5), args.bodies, args.seed), 256, args.seconds)[0] for _ in range(args.repeats)]
    print(f"whole machine ({cores} threads), 5x5, B = 256: {np.median(whole):,.0f} env steps/s")
    if evo is not None:
        ratio = f", ours at B = 64 {ours / evo:.1f}x that" if ours else ""
        print(f"Evolution Gym 2.0, the same 5x5 bodies one at a time: {evo:,.0f} env steps/s per core{ratio}")
    else:
        print("Evolution Gym is not installed here: no side-by-side figure (run in plugins/gdabench-evogym's venv)")


if __name__ == "__main__":
    main()
