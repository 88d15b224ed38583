"""The voxel engine on an NVIDIA GPU: CPU/GPU agreement and env steps/s against batch size.

Prepared to run once on a machine with a GPU (at most about 4 minutes, compiling included):

* **agreement**: ``--agree`` random 5x5 bodies (Evolution Gym's sampler, seeded), 500 env steps of an
  open-loop sinusoid on the CPU engine and on the GPU; the largest point-position gap after 1, 10,
  100 and 500 steps, the per-body episode reward (sum of centre-of-mass gains) on each, the largest
  reward gap, instability flags, and whether a body steps bit-identically alone and in the batch on
  the GPU.  Bit-identity with the CPU is not expected: NVVM fuses multiply-adds and CUDA's ``tanh``
  is not glibc's, so trajectories agree to rounding at first and drift apart where the dynamics
  amplify rounding (contacts);
* **speed**: env steps/s on the GPU at each batch of ``--batches`` (B environments of
  ``--distinct`` different bodies, cycled), median of ``--repeats`` timed runs of ``--seconds``, with
  the device memory in use; beside it the CPU engine on every core of the same machine.

    python benchmarks/figures/voxel_gpu.py --out gpu-engine.json
    python benchmarks/figures/voxel_gpu.py --dry-run    # the flow on the CPU engine (no GPU): for checking the script
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import statistics
import sys
import time
import traceback
from types import SimpleNamespace
from typing import Any

import numba
import numpy as np

import gdabench
from gdabench.envs.voxel import engine


def actions(t: int, n: int, width: int) -> np.ndarray:
    wave = 1.1 + 0.5 * np.sin(2 * math.pi * t / 20 + np.arange(width))
    return np.ascontiguousarray(np.broadcast_to(wave, (n, width)))


def random_bodies(count: int, seed: int, shape: tuple[int, int] = (5, 5)) -> list[gdabench.Body]:
    rng = np.random.default_rng(seed)
    return [gdabench.random_body(rng, shape) for _ in range(count)]


def cpu_backend() -> Any:
    """The GPU module's interface on the CPU engine (``--dry-run``)."""

    def step(dev: Any, state: engine.State, acts: Any, active: Any = None) -> tuple:
        new, out = engine.step(dev.tables, state, acts, active)
        return new, out

    return SimpleNamespace(
        to_device=lambda tables: SimpleNamespace(tables=tables),
        reset=lambda dev, body: engine.reset(dev.tables, body), step=step, host=np.asarray, put=lambda x: x,
        synchronize=lambda: None, memory=lambda: 0, name="cpu (dry run)",
    )


def gpu_backend() -> Any:
    from numba import cuda

    from gdabench.envs.voxel import gpu

    def memory() -> int:
        free, total = cuda.current_context().get_memory_info()
        return int(total - free)

    name = cuda.get_current_device().name
    return SimpleNamespace(to_device=gpu.to_device, reset=gpu.reset, step=gpu.step, host=lambda x: x.copy_to_host(),
                           put=cuda.to_device, synchronize=cuda.synchronize, memory=memory,
                           name=name.decode() if isinstance(name, bytes) else str(name))


def agreement(backend: Any, bodies: list[gdabench.Body], tables: engine.BodyTables, count: int,
              steps: int = 500) -> dict[str, Any]:
    """Bodies ``0..count-1`` of ``tables`` (padded as the speed batches are: one kernel serves both)."""
    index = np.arange(count)
    cpu_state = engine.reset(tables, index)
    dev = backend.to_device(tables)
    gpu_state = backend.reset(dev, index)
    alone_dev = backend.to_device(engine.body_tables(bodies[:1], pad=tables))
    alone = backend.reset(alone_dev, np.array([0]))
    gaps, reward_cpu, reward_gpu = {}, np.zeros(count), np.zeros(count)
    unstable_cpu, unstable_gpu, alone_same = np.zeros(count, int), np.zeros(count, int), True
    start = time.perf_counter()
    def com_x(pos: np.ndarray) -> np.ndarray:  # Walker-v0's reward is this x's gain (robot points: from 0)
        return np.array([pos[i, : tables.n_robot_points[i], 0].mean() for i in range(count)])

    for t in range(1, steps + 1):
        a = actions(t, count, tables.max_actuators)
        before_cpu, before_gpu = com_x(cpu_state.pos), com_x(backend.host(gpu_state.pos))
        cpu_state, out_c = engine.step(tables, cpu_state, a)
        gpu_state, out_g = backend.step(dev, gpu_state, a)
        alone, out_a = backend.step(alone_dev, alone, a[:1])
        reward_cpu += com_x(cpu_state.pos) - before_cpu
        reward_gpu += com_x(backend.host(gpu_state.pos)) - before_gpu
        unstable_cpu += out_c.unstable
        unstable_gpu += backend.host(out_g.unstable)
        if t in (1, 10, 100, steps):
            gaps[t] = float(np.abs(cpu_state.pos - backend.host(gpu_state.pos)).max())
        alone_same &= bool(np.array_equal(backend.host(alone.pos)[0], backend.host(gpu_state.pos)[0]))
    return {
        "bodies": count, "steps": steps, "seconds": round(time.perf_counter() - start, 1),
        "max_position_gap": gaps,
        "reward_cpu": reward_cpu.round(6).tolist(), "reward_gpu": reward_gpu.round(6).tolist(),
        "max_reward_gap": float(np.abs(reward_cpu - reward_gpu).max()),
        "median_reward_gap": float(np.median(np.abs(reward_cpu - reward_gpu))),
        "reward_spearman": float(_spearman(reward_cpu, reward_gpu)),
        "unstable_steps_cpu": int(unstable_cpu.sum()), "unstable_steps_gpu": int(unstable_gpu.sum()),
        "alone_bit_identical_to_batch_on_gpu": alone_same,
    }


def _spearman(a: np.ndarray, b: np.ndarray) -> float:
    ra, rb = np.argsort(np.argsort(a)), np.argsort(np.argsort(b))
    return float(np.corrcoef(ra, rb)[0, 1])


def rate(backend: Any, tables: engine.BodyTables, batch: int, seconds: float, repeats: int,
         group: int = 1) -> dict[str, Any]:
    """Env steps/s of ``batch`` environments: ``group`` neighbouring environments share a body (1: every
    neighbour differs, the worst case for a GPU warp), the bodies cycled."""
    index = np.arange(batch) // group % len(tables.objects)
    dev = backend.to_device(tables)
    state = backend.reset(dev, index)
    acts = [backend.put(actions(t, batch, tables.max_actuators)) for t in range(20)]  # on the device beforehand
    first = time.perf_counter()
    state, out = backend.step(dev, state, acts[0])  # compile (first batch only) and warm up
    backend.synchronize()
    first = time.perf_counter() - first
    rates = []
    for _ in range(repeats):
        steps, start = 0, time.perf_counter()
        while time.perf_counter() - start < seconds or steps < 3:
            state, out = backend.step(dev, state, acts[steps % 20])
            steps += 1
        backend.synchronize()
        rates.append(batch * steps / (time.perf_counter() - start))
    unstable = int(backend.host(out.unstable).sum())
    return {"batch": batch, "group": group, "env_steps_per_s": round(statistics.median(rates)),
            "all": [round(r) for r in rates], "first_step_s": round(first, 2), "device_bytes": backend.memory(),
            "unstable_last_step": unstable}


def cpu_rates(tables: engine.BodyTables, batches: list[int], seconds: float) -> list[dict[str, Any]]:
    rows = []
    for batch in batches:
        row = rate(cpu_backend(), tables, batch, seconds, 1)
        rows.append({"batch": batch, "env_steps_per_s": row["env_steps_per_s"], "threads": numba.get_num_threads()})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--agree", type=int, default=20)
    parser.add_argument("--batches", default="1024,16384,65536", help="the last is the largest")
    parser.add_argument("--cpu-batches", default="1024")
    parser.add_argument("--distinct", type=int, default=1000, help="different bodies in the speed batches")
    parser.add_argument("--seconds", type=float, default=2.0)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--group", type=int, default=32, help="neighbours sharing a body in the grouped layout")
    parser.add_argument("--block-sweep", default="32,128,256", help="threads per block tried at the largest batch")
    parser.add_argument("--shapes", default="8x8,12x12", help="larger bodies, timed at --shape-batch")
    parser.add_argument("--shape-batch", type=int, default=16384)
    parser.add_argument("--dry-run", action="store_true", help="the CPU engine in place of the GPU")
    parser.add_argument("--out", default="voxel-gpu.json")
    args = parser.parse_args()

    result: dict[str, Any] = {"python": platform.python_version(), "numba": numba.__version__, "numpy": np.__version__,
                              "cores": os.cpu_count(), "numba_threads": numba.get_num_threads()}

    def save() -> None:
        with open(args.out, "w") as f:
            json.dump(result, f, indent=1)

    def part(name: str, fn: Any) -> None:
        start = time.perf_counter()
        try:
            result[name] = fn()
        except Exception:  # noqa: BLE001 - one part's failure must not lose the others' figures
            result[name] = {"error": traceback.format_exc()}
        print(f"== {name} ({time.perf_counter() - start:.0f} s)", json.dumps(result[name])[:2000], flush=True)
        save()

    try:
        backend = cpu_backend() if args.dry_run else gpu_backend()
    except Exception:  # noqa: BLE001 - said in the output file, which is what comes back from the GPU machine
        result["backend_error"] = traceback.format_exc()
        save()
        print(result["backend_error"])
        sys.exit(1)
    result["device"] = backend.name
    try:
        import numba_cuda  # type: ignore[import-not-found]

        result["numba_cuda"] = getattr(numba_cuda, "__version__", "?")
    except ImportError:
        result["numba_cuda"] = None
    print(json.dumps(result), flush=True)
    bodies = random_bodies(args.distinct, args.seed)
    tables = engine.body_tables(bodies)
    part("agreement", lambda: agreement(backend, bodies, tables, args.agree))
    for b in (int(x) for x in args.batches.split(",")):
        part(f"gpu_{b}", lambda b=b: rate(backend, tables, b, args.seconds, args.repeats))
    big = int(args.batches.split(",")[-1])
    part(f"gpu_{big}_grouped_{args.group}", lambda: rate(backend, tables, big, args.seconds, args.repeats,
                                                         group=args.group))
    part("cpu_all_cores", lambda: cpu_rates(tables, [int(x) for x in args.cpu_batches.split(",")], args.seconds))
    if args.dry_run:
        return
    from gdabench.envs.voxel import gpu

    for threads in (int(x) for x in args.block_sweep.split(",") if x):
        gpu.THREADS = threads
        part(f"gpu_{big}_threads_{threads}", lambda: rate(backend, tables, big, args.seconds, 1))
    gpu.THREADS = 64
    for shape in (s for s in args.shapes.split(",") if s):
        rows, cols = (int(x) for x in shape.split("x"))
        wide = engine.body_tables(random_bodies(200, args.seed + 2, (rows, cols)))
        part(f"gpu_{args.shape_batch}_{shape}",
             lambda wide=wide: rate(backend, wide, args.shape_batch, args.seconds, 1))

if __name__ == "__main__":
    main()
