"""The ``ppo`` controller against stable-baselines3's PPO: same body, settings and timesteps.

Both sides train Evolution Gym 2.0's PPO (lr 2.5e-4, 128 steps per rollout, minibatches of 4,
4 epochs, gamma 0.99, GAE 0.95, value 0.5, entropy 0.01, clip 0.1, gradient norm 0.5, one env)
on ``gdabench/Walker-v0`` for the same body and number of timesteps, one torch thread each,
each training in its own fresh process, the two sides alternating so that they share the same
machine load.  Printed per run and as medians:

* throughput: environment steps per second of training (collection + updates, no
  evaluation); CPU-seconds of the process are printed too, because on a shared machine
  wall-clock time is not all the process's own, and the ratio of each gdabench training to the
  SB3 training of the same seed run next to it.  gdabench trains the body as a batch of one
  (the lockstep trainer: :mod:`gdabench.controllers.ppo.train`);
* final mean evaluation reward: the final policy of each side plays ``--episodes`` episodes
  scored the same way (actions sampled from a seeded generator, Evolution Gym 2.0's
  convention of dropping the last step's reward) and, separately, its mean action.

Usage (needs the ``bench`` extra: ``pip install -e .[bench]``)::

    python benchmarks/compare/ppo_vs_sb3.py --timesteps 30000 --seeds 0,1,2 --repeats 2
"""

from __future__ import annotations

import argparse
import functools
import json
import statistics
import subprocess
import sys
import time
from typing import Any

import gdabench  # noqa: F401 - before torch: it pins torch's CPU kernels to AVX2 (gdabench.cpu)

#: a body that walks (an open-loop gait moves it about 5.5 on Walker-v0): legs of vertical actuators
DEFAULT_BODY = "00000/44444/44444/40004/40004"
SB3_SETTINGS = {
    "learning_rate": 2.5e-4,
    "n_steps": 128,
    "batch_size": 4,
    "n_epochs": 4,
    "gamma": 0.99,
    "gae_lambda": 0.95,
    "vf_coef": 0.5,
    "ent_coef": 0.01,
    "clip_range": 0.1,
    "max_grad_norm": 0.5,
}


class _SB3Policy:
    """An SB3 policy behind the interface gdabench's evaluation uses (a stack of one body's networks)."""

    def __init__(self, model: Any, n_obs: int):
        import torch

        self.model, self.n_obs, self.n_bodies = model, n_obs, 1
        self.log_std = torch.zeros(1)  # where inputs go (the CPU)

    def act(self, obs: Any, generators: Any) -> tuple[Any, None]:
        import torch

        with torch.no_grad():
            dist = self.model.policy.get_distribution(obs[0]).distribution
            mean, std = dist.mean.float(), dist.stddev.float()
            if generators[0] is None:
                return mean.unsqueeze(0), None
            return (mean + std * torch.randn(mean.shape, generator=generators[0])).unsqueeze(0), None


def _evaluate(policy: Any, make_env: Any, episodes: int, seed: int) -> dict[str, float]:
    import torch

    from gdabench.batched import GymBodies
    from gdabench.controllers.ppo.evaluation import evaluate_policies

    def play(generator: Any) -> float:
        [[score]] = evaluate_policies(
            policy, lambda n: GymBodies([make_env], n), n_evals=1, episode_end="evogym2", generators=[generator]
        )
        return score

    sampled = [play(torch.Generator().manual_seed(seed * 1000 + i)) for i in range(episodes)]
    return {"reward": statistics.fmean(sampled), "reward_mean_action": play(None)}


def run_one(side: str, body: str, timesteps: int, seed: int, episodes: int) -> dict[str, Any]:
    """Train one side once in this process; returns its figures."""
    import torch

    torch.set_num_threads(1)
    from gdabench.body import as_body
    from gdabench.envs.walker.env import make_walker

    make_env = functools.partial(make_walker, as_body(body))
    if side == "sb3":
        from stable_baselines3 import PPO as SB3PPO

        model = SB3PPO("MlpPolicy", make_env(), seed=seed, device="cpu", verbose=0, **SB3_SETTINGS)
        wall, cpu = time.perf_counter(), time.process_time()
        model.learn(timesteps)
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        steps = model.num_timesteps
        out = {"steps_per_s": steps / wall, "steps_per_s_cpu": steps / cpu}
        policy: Any = _SB3Policy(model, make_env().observation_space.shape[0])
    else:
        from gdabench.batched import GymBodies
        from gdabench.controllers.ppo import PPOConfig
        from gdabench.controllers.ppo.networks import Stacked
        from gdabench.controllers.ppo.train import train

        config = PPOConfig(timesteps=timesteps, eval_interval=10 * timesteps)  # evaluation only at the end
        [result] = train(config, lambda n: GymBodies([make_env], n), [seed], device=torch.device("cpu"))
        steps, s, c = result.timesteps, result.seconds, result.cpu_seconds
        wall = s["collect"] + s["update"]
        out = {"steps_per_s": steps / wall, "steps_per_s_cpu": steps / (c["collect"] + c["update"])}
        policy = Stacked([result.nets], *result.padded)
    out.update(_evaluate(policy, make_env, episodes, seed))
    return {"side": side, "seed": seed, "timesteps": steps, **out}


def _spawn(side: str, args: argparse.Namespace, seed: int) -> dict[str, Any]:
    cmd = [
        sys.executable,
        __file__,
        "--one",
        side,
        "--body",
        args.body,
        "--timesteps",
        str(args.timesteps),
        "--seeds",
        str(seed),
        "--episodes",
        str(args.episodes),
    ]
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    lines = [line for line in done.stdout.splitlines() if line.startswith("{")]
    if done.returncode != 0 or not lines:
        raise SystemExit(f"{side} seed {seed} failed:\n{done.stderr[-2000:]}")
    return json.loads(lines[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--body", default=DEFAULT_BODY)
    parser.add_argument("--timesteps", type=int, default=50_000)
    parser.add_argument("--seeds", default="0,1,2")
    parser.add_argument(
        "--repeats", type=int, default=1, help="trainings per side and seed (throughput varies with the machine's load)"
    )
    parser.add_argument("--episodes", type=int, default=5, help="evaluation episodes with sampled actions")
    parser.add_argument("--sides", default="sb3,gdabench", help="sb3, gdabench")
    parser.add_argument("--one", help=argparse.SUPPRESS)
    args = parser.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    if args.one:
        print(json.dumps(run_one(args.one, args.body, args.timesteps, seeds[0], args.episodes)))
        return
    sides = args.sides.split(",")
    print(
        f"body {args.body}, {args.timesteps} timesteps, seeds {seeds} x {args.repeats}, sides alternate: "
        f"{', '.join(sides)}",
        flush=True,
    )
    rows = []
    for repeat in range(args.repeats):
        for seed in seeds:
            for side in sides if (seed + repeat) % 2 == 0 else sides[::-1]:  # alternate who goes first
                row = {**_spawn(side, args, seed), "repeat": repeat}
                rows.append(row)
                print(json.dumps({k: round(v, 3) if isinstance(v, float) else v for k, v in row.items()}), flush=True)
    print(f"\nmedians over {len(seeds)} seeds x {args.repeats} repeats:")
    keys = ["steps_per_s", "steps_per_s_cpu", "reward", "reward_mean_action"]
    medians = {
        side: {
            k: statistics.median(r[k] for r in rows if r["side"] == side)
            for k in keys
            if all(k in r for r in rows if r["side"] == side)
        }
        for side in sides
    }
    for side, figures in medians.items():
        print(f"  {side:15s} " + "  ".join(f"{k}={v:.3f}" for k, v in figures.items()))
    if "sb3" in medians:
        for side in sides:
            if side == "sb3":
                continue
            # each training against the SB3 training of the same seed and repeat, run next to it (same machine load)
            pairs = {(r["seed"], r["repeat"]): r for r in rows if r["side"] == "sb3"}
            ratios = sorted(
                r["steps_per_s"] / pairs[r["seed"], r["repeat"]]["steps_per_s"] for r in rows if r["side"] == side
            )
            cpu = statistics.median(
                r["steps_per_s_cpu"] / pairs[r["seed"], r["repeat"]]["steps_per_s_cpu"]
                for r in rows
                if r["side"] == side
            )
            speed = medians[side]["steps_per_s"] / medians["sb3"]["steps_per_s"]
            print(
                f"  {side} / sb3: throughput x{speed:.2f} (ratio of medians); per pair median "
                f"x{statistics.median(ratios):.2f}, "
                f"lowest x{ratios[0]:.2f}; CPU-seconds x{cpu:.2f}; reward {medians[side]['reward']:.3f} vs "
                f"{medians['sb3']['reward']:.3f}"
            )


if __name__ == "__main__":
    main()
