"""Co-design throughput: environment steps per second of PPO training (simulation plus learning).

Arms, each training in a fresh process on one core (one torch thread, one Numba thread), run in
turn and repeated so that they share the machine's load; evaluation is excluded everywhere:

* ``lockstep``: this gdabench's ``ppo`` training ``--bodies`` 5x5 bodies at once on the voxel engine
  (``gdabench/Walker-v2``'s physics, one array step for all bodies);
* ``pymunk``: this gdabench's ``ppo`` on one body of the pymunk walker (``gdabench/Walker-v1``), the
  batch of one;
* ``pymunk-before``: the per-body ``ppo`` before lockstep training (compiled update step), from the
  git worktree ``--before`` (e.g. ``git worktree add /tmp/before e4cf1ac``), on the pymunk walker;
* ``evogym-sb3``: Evolution Gym 2.0's own Walker-v0 with stable-baselines3's PPO at the same
  settings, in the Python given by ``--evogym-python`` (a venv with evogym and stable-baselines3:
  ``bash plugins/gdabench-evogym/install.sh VENV && VENV/bin/pip install stable-baselines3``);
* ``lockstep-machine``: the whole machine: ``--processes`` lockstep processes side by side, each
  with its share of the bodies; the figure is their summed throughput.

The lockstep arm also prints its process's peak memory (``peak_mb``, imports included): with
``--arms lockstep --bodies N`` it is the memory a batch of N bodies needs.

Bodies are drawn at random (valid 5x5 bodies, seeded); the single-body arms train the first.

Usage::

    python benchmarks/compare/codesign_speed.py --timesteps 2560 --bodies 25 --repeats 3 \\
        --before /tmp/before --evogym-python /work/venv-evogym/bin/python
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time
from typing import Any

import gdabench  # noqa: F401 - before torch: it pins torch's CPU kernels to AVX2 (gdabench.cpu)

SETTINGS = {
    "learning_rate": 2.5e-4, "n_steps": 128, "batch_size": 4, "n_epochs": 4, "gamma": 0.99, "gae_lambda": 0.95,
    "vf_coef": 0.5, "ent_coef": 0.01, "clip_range": 0.1, "max_grad_norm": 0.5,
}


def bodies(n: int, seed: int) -> list[str]:
    """``n`` random 5x5 bodies drawn as Evolution Gym draws them, in text form."""
    import numpy as np

    from gdabench.body import random_body

    rng = np.random.default_rng(seed)
    return [random_body(rng).text for _ in range(n)]


def _one_core() -> None:
    import torch

    torch.set_num_threads(1)


def run_lockstep(names: list[str], timesteps: int, seed: int) -> dict[str, Any]:
    from gdabench.batched import ArrayBodies
    from gdabench.controllers.ppo import PPOConfig
    from gdabench.controllers.ppo.train import train
    from gdabench.envs.voxel import engine
    from gdabench.envs.voxel.batch import TaskBatch

    pad = engine.body_tables(["44444/44444/44444/44444/44444"])

    def make(n: int) -> ArrayBodies:
        return ArrayBodies(TaskBatch("Walker-v0", names, n, pad=pad), n, 500)

    train(PPOConfig(timesteps=128, eval_interval=10**9), make, [0] * len(names))  # compile the kernels first
    config = PPOConfig(timesteps=timesteps, eval_interval=10**9, **SETTINGS)
    results = train(config, make, [seed + i for i in range(len(names))])
    s, c = results[0].seconds, results[0].cpu_seconds
    steps = len(names) * results[0].timesteps
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # the process's peak, imports included
    return {"steps": steps, "wall": s["collect"] + s["update"], "cpu": c["collect"] + c["update"], "peak_mb": peak_mb}


def run_pymunk(name: str, timesteps: int, seed: int) -> dict[str, Any]:
    import functools

    from gdabench.batched import GymBodies
    from gdabench.body import as_body
    from gdabench.controllers.ppo import PPOConfig
    from gdabench.controllers.ppo.train import train
    from gdabench.envs.walker.env import make_walker

    make_env = functools.partial(make_walker, as_body(name), "pymunk")
    config = PPOConfig(timesteps=timesteps, eval_interval=10**9, **SETTINGS)
    [result] = train(config, lambda n: GymBodies([make_env], n), [seed])
    s, c = result.seconds, result.cpu_seconds
    return {"steps": result.timesteps, "wall": s["collect"] + s["update"], "cpu": c["collect"] + c["update"]}


def run_pymunk_before(name: str, timesteps: int, seed: int) -> dict[str, Any]:
    """The per-body trainer before lockstep training (imported from ``--before``'s tree)."""
    import functools

    import torch

    from gdabench.body import as_body
    from gdabench.controllers.ppo import PPOConfig
    from gdabench.controllers.ppo.train import train  # the old signature
    from gdabench.envs.walker.env import make_walker

    make_env = functools.partial(make_walker, as_body(name), "pymunk")
    config = PPOConfig(timesteps=timesteps, eval_interval=10**9, **SETTINGS)
    result = train(config, make_env, seed=seed, device=torch.device("cpu"), compiled=True)  # type: ignore[call-arg]
    s, c = result.seconds, result.cpu_seconds
    # the first minibatch step compiles (once per process): left out, as a long training amortises it
    return {
        "steps": result.timesteps,
        "wall": s["collect"] + s["update"] - s["warmup"],
        "cpu": c["collect"] + c["update"],
    }


def run_evogym_sb3(name: str, timesteps: int, seed: int) -> dict[str, Any]:
    import evogym.envs  # noqa: F401  (registers Walker-v0)
    import gymnasium
    import numpy as np
    from stable_baselines3 import PPO

    body = np.array([[int(c) for c in row] for row in name.split("/")])
    env = gymnasium.make("Walker-v0", body=body)
    model = PPO("MlpPolicy", env, seed=seed, device="cpu", verbose=0, **SETTINGS)
    wall, cpu = time.perf_counter(), time.process_time()
    model.learn(timesteps)
    return {"steps": model.num_timesteps, "wall": time.perf_counter() - wall, "cpu": time.process_time() - cpu}


def spawn(arm: str, args: argparse.Namespace, names: list[str], seed: int) -> subprocess.Popen:
    python, env = sys.executable, {**os.environ, "NUMBA_NUM_THREADS": str(args.numba_threads), "OMP_NUM_THREADS": "1"}
    if arm == "pymunk-before":
        env["PYTHONPATH"] = args.before
    if arm == "evogym-sb3":
        python = args.evogym_python
    cmd = [
        python,
        __file__,
        "--one",
        arm,
        "--names",
        ",".join(names),
        "--timesteps",
        str(args.timesteps),
        "--seed",
        str(seed),
    ]
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)


def finish(arm: str, process: subprocess.Popen) -> dict[str, Any]:
    out, err = process.communicate()
    lines = [line for line in out.splitlines() if line.startswith("{")]
    if process.returncode != 0 or not lines:
        raise SystemExit(f"{arm} failed:\n{err[-3000:]}")
    return json.loads(lines[-1])


def measure(arm: str, args: argparse.Namespace, names: list[str], seed: int) -> dict[str, Any]:
    if arm != "lockstep-machine":
        row = finish(
            arm, spawn("lockstep" if arm == "lockstep" else arm, args, names if arm == "lockstep" else names[:1], seed)
        )
        extra = {"peak_mb": row["peak_mb"]} if "peak_mb" in row else {}
        return {"arm": arm, "per_s": row["steps"] / row["wall"], "per_cpu_s": row["steps"] / row["cpu"], **extra}
    shares = [names[i :: args.processes] for i in range(args.processes)]
    start = time.perf_counter()
    rows = [finish(arm, p) for p in [spawn("lockstep", args, share, seed) for share in shares]]
    # the sum of each process's own rate (each excludes its kernel compilation and its evaluation)
    return {
        "arm": arm,
        "per_s": sum(r["steps"] / r["wall"] for r in rows),
        "per_cpu_s": sum(r["steps"] / r["cpu"] for r in rows),
        "span_s": time.perf_counter() - start,
    }


ARMS = ("lockstep", "pymunk", "pymunk-before", "evogym-sb3", "lockstep-machine")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--timesteps", type=int, default=2560, help="timesteps per body")
    parser.add_argument("--bodies", type=int, default=25)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--processes", type=int, default=2, help="lockstep processes for the whole-machine arm")
    parser.add_argument("--arms", default=",".join(ARMS))
    parser.add_argument("--numba-threads", type=int, default=1, help="Numba threads per process (the engine's kernels)")
    parser.add_argument("--before", help="a git worktree of gdabench before lockstep training (for pymunk-before)")
    parser.add_argument("--evogym-python", help="a Python with evogym and stable-baselines3 (for evogym-sb3)")
    parser.add_argument("--one", help=argparse.SUPPRESS)
    parser.add_argument("--names", help=argparse.SUPPRESS)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    if args.one:
        _one_core()
        names = args.names.split(",")
        run = {
            "lockstep": run_lockstep,
            "pymunk": lambda n, t, s: run_pymunk(n[0], t, s),
            "pymunk-before": lambda n, t, s: run_pymunk_before(n[0], t, s),
            "evogym-sb3": lambda n, t, s: run_evogym_sb3(n[0], t, s),
        }[args.one]
        print(json.dumps(run(names, args.timesteps, args.seed)))
        return
    arms = args.arms.split(",")
    unknown = set(arms) - set(ARMS)
    if unknown or ("pymunk-before" in arms and not args.before) or ("evogym-sb3" in arms and not args.evogym_python):
        parser.error(
            f"unknown arms {sorted(unknown)}" if unknown else "pymunk-before needs --before, evogym-sb3 --evogym-python"
        )
    names = bodies(args.bodies, args.seed)
    print(
        f"{args.bodies} bodies, {args.timesteps} timesteps each, {args.repeats} repeats; arms in turn: "
        f"{', '.join(arms)}"
    )
    rows = []
    for repeat in range(args.repeats):
        for arm in arms if repeat % 2 == 0 else arms[::-1]:
            row = {**measure(arm, args, names, args.seed + repeat), "repeat": repeat}
            rows.append(row)
            print(json.dumps({k: round(v, 1) if isinstance(v, float) else v for k, v in row.items()}), flush=True)
    print("\nmedians (env steps/s; per CPU-second in brackets):")
    medians = {arm: statistics.median(r["per_s"] for r in rows if r["arm"] == arm) for arm in arms}
    for arm in arms:
        cpu = statistics.median(r["per_cpu_s"] for r in rows if r["arm"] == arm)
        print(f"  {arm:17s} {medians[arm]:9.0f}  ({cpu:.0f})")
    if "lockstep" in medians:
        for arm in ("pymunk", "pymunk-before", "evogym-sb3"):
            if arm in medians:
                print(f"  lockstep / {arm}: x{medians['lockstep'] / medians[arm]:.1f} per core")


if __name__ == "__main__":
    main()
