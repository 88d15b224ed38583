"""One generation of co-design on a machine with a GPU: ``--bodies`` bodies trained in lockstep towards
``--timesteps`` each, for at most ``--minutes`` per arm; prints the timesteps reached and env steps/s.

Each arm is ``DEVICE:SCHEDULE``: the learner (the stacked policies and critics, the PPO update) on
``cuda`` or ``cpu`` (one torch thread), the simulation on the voxel engine on every CPU core (Numba
threads); ``evogym2`` is Evolution Gym 2.0's settings (gdabench's default: one environment per body,
128-step rollouts, minibatches of 4, 4 epochs), ``evogym1`` its 1.0 schedule (4 environments per body,
4 minibatches, linear learning-rate decay, observation normalisation).  Bodies are random 5x5 bodies
(Evolution Gym's sampler, seeded).  Evaluation is left out (one at the end, not reached when an arm is
stopped by its time limit).

    python benchmarks/figures/codesign_gpu.py --arms cuda:evogym2,cuda:evogym1,cpu:evogym2 --minutes 1.5 \
        --out gpu-ppo.json
"""

from __future__ import annotations

import argparse
import json
import os
import time
import traceback
from typing import Any

import gdabench  # noqa: F401 - before torch: it pins torch's CPU kernels to AVX2 (gdabench.cpu)

SCHEDULES: dict[str, dict[str, Any]] = {
    "evogym2": {},
    "evogym1": {"n_envs": 4, "batch_size": 128, "lr_schedule": "linear", "normalize_obs": True},
}


class Deadline(Exception):
    """The arm's time is up."""


def run_arm(arm: str, names: list[str], timesteps: int, minutes: float) -> dict[str, Any]:
    from gdabench.batched import ArrayBodies
    from gdabench.controllers.ppo import PPOConfig
    from gdabench.controllers.ppo.train import train
    from gdabench.envs.voxel import MAX_EPISODE_STEPS, engine
    from gdabench.envs.voxel.batch import TaskBatch

    device, schedule = arm.split(":")
    pad = engine.body_tables(["44444/44444/44444/44444/44444"])

    def make(n: int) -> ArrayBodies:
        return ArrayBodies(TaskBatch("Walker-v0", names, n, pad=pad), n, MAX_EPISODE_STEPS)

    marks: list[tuple[float, int]] = []
    start = time.perf_counter()

    def on_rollout(steps: int) -> None:
        marks.append((time.perf_counter() - start, steps))
        if marks[-1][0] > minutes * 60:
            raise Deadline

    config = PPOConfig(timesteps=timesteps, eval_interval=10**9, device=device, **SCHEDULES[schedule])
    finished = True
    try:
        train(config, make, list(range(len(names))), pad=(2 + 2 * 36, 25), device=device, on_rollout=on_rollout)
    except Deadline:
        finished = False
    wall, steps = marks[-1]
    first_wall, first_steps = marks[0]
    steady = (steps - first_steps) * len(names) / (wall - first_wall) if len(marks) > 1 else None
    return {
        "arm": arm, "bodies": len(names), "goal_timesteps": timesteps, "finished": finished,
        "timesteps_per_body": steps, "wall_s": round(wall, 1), "first_rollout_s": round(first_wall, 2),
        "env_steps_per_s": round(steps * len(names) / wall), "steady_env_steps_per_s": steady and round(steady),
        "seconds_for_goal_at_steady_rate": steady and round(timesteps * len(names) / steady),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--arms", default="cuda:evogym2,cuda:evogym1,cpu:evogym2")
    parser.add_argument("--bodies", type=int, default=25)
    parser.add_argument("--timesteps", type=int, default=1_000_000)
    parser.add_argument("--minutes", type=float, default=1.5, help="time limit of each arm")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default="codesign-gpu.json")
    args = parser.parse_args()

    import numba
    import numpy as np
    import torch

    from gdabench.body import random_body

    rng = np.random.default_rng(args.seed)
    names = [random_body(rng).text for _ in range(args.bodies)]
    result: dict[str, Any] = {"torch": torch.__version__, "cuda": torch.cuda.is_available() and
                              torch.cuda.get_device_name(0), "numba_threads": numba.get_num_threads(),
                              "cores": os.cpu_count(), "arms": []}
    for arm in args.arms.split(","):
        try:
            row = run_arm(arm, names, args.timesteps, args.minutes)
        except Exception:  # noqa: BLE001 - one arm's failure must not lose the others' figures
            row = {"arm": arm, "error": traceback.format_exc()}
        result["arms"].append(row)
        print(json.dumps(row), flush=True)
        with open(args.out, "w") as f:
            json.dump(result, f, indent=1)


if __name__ == "__main__":
    main()
