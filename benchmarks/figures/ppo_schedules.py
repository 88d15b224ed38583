"""Evolution Gym 2.0's PPO schedule against Evolution Gym 1.0's: sample efficiency on the same bodies.

Both schedules train the same random 5x5 bodies (Evolution Gym's sampler) with the same seeds and
timesteps on the voxel walker, each schedule as one lockstep batch (every (body, seed) pair learns
bit for bit what it would learn alone).  Evolution Gym 1.0's schedule: 4 environments per body, 4
minibatches per rollout (of 128 samples), the learning rate decaying linearly to 0, observations
normalised by running statistics; 2.0's: 1 environment, minibatches of 4, constant learning rate.

Printed: per schedule the mean evaluation curve over all pairs, the mean best reward (a body's
reward), and per pair which schedule scored higher.

Usage::

    python benchmarks/figures/ppo_schedules.py --bodies 5 --seeds 0,1,2 --timesteps 50000
"""

from __future__ import annotations

import argparse
import statistics

import gdabench  # noqa: F401 - before torch: it pins torch's CPU kernels to AVX2 (gdabench.cpu)

SCHEDULES = {
    "evogym2": {},
    "evogym1": {"n_envs": 4, "batch_size": 128, "lr_schedule": "linear", "normalize_obs": True},
}


def train_schedule(names: list[str], seeds: list[int], timesteps: int, schedule: dict) -> list[list[float]]:
    import torch

    from gdabench.batched import ArrayBodies
    from gdabench.controllers.ppo import PPOConfig
    from gdabench.controllers.ppo.train import train
    from gdabench.envs.voxel import MAX_EPISODE_STEPS, engine
    from gdabench.envs.voxel.batch import TaskBatch

    torch.set_num_threads(1)
    pad = engine.body_tables(["44444/44444/44444/44444/44444"])
    results = train(
        PPOConfig(timesteps=timesteps, **schedule),
        lambda n: ArrayBodies(TaskBatch("Walker-v0", names, n, pad=pad), n, MAX_EPISODE_STEPS),
        seeds,
        pad=(2 + 2 * 36, 25),
    )
    return [[e.mean for e in r.evaluations] for r in results]


def main() -> None:
    import numpy as np

    from gdabench.body import random_body

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bodies", type=int, default=5)
    parser.add_argument("--seeds", default="0,1,2")
    parser.add_argument("--timesteps", type=int, default=50_000)
    parser.add_argument("--body-seed", type=int, default=1)
    args = parser.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    rng = np.random.default_rng(args.body_seed)
    bodies = [random_body(rng).text for _ in range(args.bodies)]
    pairs = [(body, seed) for body in bodies for seed in seeds]
    print(f"{len(bodies)} bodies x seeds {seeds}, {args.timesteps} timesteps, evaluation every tenth")
    curves = {}
    for name, schedule in SCHEDULES.items():
        curves[name] = train_schedule([b for b, _ in pairs], [s for _, s in pairs], args.timesteps, schedule)
        mean = [statistics.fmean(c) for c in zip(*curves[name])]
        best = [max(c) for c in curves[name]]
        print(f"{name}: curve {' '.join(f'{v:5.2f}' for v in mean)}")
        print(
            f"{'':9s}mean best reward {statistics.fmean(best):.3f} (median {statistics.median(best):.3f})", flush=True
        )
    wins = sum(max(a) > max(b) for a, b in zip(curves["evogym1"], curves["evogym2"]))
    print(f"evogym1 scored higher on {wins} of {len(pairs)} (body, seed) pairs")
    for (body, seed), a, b in zip(pairs, curves["evogym2"], curves["evogym1"]):
        print(f"  {body} seed {seed}: evogym2 {max(a):6.3f}  evogym1 {max(b):6.3f}")


if __name__ == "__main__":
    main()
