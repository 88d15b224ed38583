"""Does lockstep training learn as per-body training did?  Learning curves, side by side.

The same bodies, seeds and settings trained (a) by the per-body ``ppo`` before lockstep training
(imported from the git worktree ``--before``, e.g. ``git worktree add /tmp/before e4cf1ac``) and
(b) by today's lockstep trainer.  The two draw their random numbers differently (per-body streams
now), so curves agree only within seed noise: the script prints, per body, each side's evaluation
curve (mean over seeds) and the final rewards per seed.  Side (b) trains every (body, seed) pair in
one lockstep batch, which is bit for bit what each would learn as a batch of one (a test checks it).

Usage::

    python benchmarks/compare/ppo_batch_of_one.py --before /tmp/before --timesteps 20000 --seeds 0,1,2
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import statistics
import subprocess
import sys

import gdabench  # noqa: F401 - before torch: it pins torch's CPU kernels to AVX2 (gdabench.cpu)

#: three 5x5 bodies of different kinds: a block, a walker with two legs, a sparse body
BODIES = ["33333/33333/33333/33333/33333", "00000/44444/44444/40004/40004", "03330/03330/33333/30003/30003"]


def run_before(body: str, timesteps: int, seed: int) -> list[float]:
    import torch

    from gdabench.body import as_body
    from gdabench.controllers.ppo import PPOConfig
    from gdabench.controllers.ppo.train import train  # the per-body signature
    from gdabench.envs.walker.env import make_walker

    torch.set_num_threads(1)
    config = PPOConfig(timesteps=timesteps)
    make_env = functools.partial(make_walker, as_body(body), "voxel")
    result = train(config, make_env, seed=seed, device=torch.device("cpu"), compiled=False)  # type: ignore[call-arg]
    return [e.mean for e in result.evaluations]


def run_lockstep(pairs: list[tuple[str, int]], timesteps: int) -> list[list[float]]:
    import torch

    from gdabench.batched import ArrayBodies
    from gdabench.controllers.ppo import PPOConfig
    from gdabench.controllers.ppo.train import train
    from gdabench.envs.voxel import MAX_EPISODE_STEPS, engine
    from gdabench.envs.voxel.batch import TaskBatch

    torch.set_num_threads(1)
    pad = engine.body_tables(["44444/44444/44444/44444/44444"])
    names = [body for body, _ in pairs]
    results = train(
        PPOConfig(timesteps=timesteps),
        lambda n: ArrayBodies(TaskBatch("Walker-v0", names, n, pad=pad), n, MAX_EPISODE_STEPS),
        [seed for _, seed in pairs],
        pad=(2 + 2 * 36, 25),
    )
    return [[e.mean for e in r.evaluations] for r in results]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", required=True, help="a git worktree of gdabench before lockstep training")
    parser.add_argument("--timesteps", type=int, default=20_000)
    parser.add_argument("--seeds", default="0,1,2")
    parser.add_argument("--one", help=argparse.SUPPRESS)
    args = parser.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    if args.one:
        body, seed = args.one.rsplit(":", 1)
        print(json.dumps(run_before(body, args.timesteps, int(seed))))
        return
    pairs = [(body, seed) for body in BODIES for seed in seeds]
    env = {**os.environ, "PYTHONPATH": args.before, "OMP_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1"}
    before = {}
    for body, seed in pairs:
        cmd = [
            sys.executable,
            __file__,
            "--before",
            args.before,
            "--timesteps",
            str(args.timesteps),
            "--one",
            f"{body}:{seed}",
        ]
        out = subprocess.run(cmd, capture_output=True, text=True, env=env, check=True).stdout.splitlines()[-1]
        before[body, seed] = json.loads(out)
    lockstep = dict(zip(pairs, run_lockstep(pairs, args.timesteps)))
    print(
        f"{args.timesteps} timesteps, seeds {seeds}; evaluation every {args.timesteps // 10} timesteps, mean over seeds"
    )
    for body in BODIES:
        print(f"\n{body}")
        for name, curves in (("per-body (before)", before), ("lockstep (now)", lockstep)):
            mean = [statistics.fmean(c) for c in zip(*(curves[body, s] for s in seeds))]
            finals = [max(curves[body, s]) for s in seeds]
            print(f"  {name:18s} curve {' '.join(f'{v:5.2f}' for v in mean)}")
            print(
                f"  {'':18s} reward per seed (best evaluation) {' '.join(f'{v:.2f}' for v in finals)}"
                f"  mean {statistics.fmean(finals):.2f}"
            )


if __name__ == "__main__":
    main()
