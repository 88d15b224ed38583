"""How much PPO training ranks bodies, and what multi-fidelity schedules would keep of that ranking.

Research, kept for the record (``benchmarks/research/``): the multi-fidelity schedules it plays out are
simulated here, not part of gdabench (docs/benchmarks/codesign-speed.md).

Trains ``--bodies`` random 5x5 bodies (Evolution Gym's sampler, a generation 0 of a real run) on the
voxel walker at each budget of ``--budgets`` (lockstep, split over ``--processes`` processes; results
are kept in ``--out`` per budget, so an interrupted measurement resumes), then prints:

* the rank agreement (Spearman) between every pair of budgets, and how many of each budget's top 5
  (a generation's survivors) the other budget's top 5 holds;
* successive halving over the budgets (every body at the smallest, the best ``1/eta`` of them at the
  next, ...), with survivors trained again from scratch or continued: env steps saved against training
  every body at the largest budget, Spearman of the rewards it ends with (a stopped body keeps its
  partial reward) against full training, and the top-5 agreement.  Read off without running it:
  training is deterministic and a body learns the same in any batch, so a body's reward at a budget is
  the same whether it got there in a halving round or not (continued: up to which checkpoints were
  evaluated, see :func:`halving`);
* early stopping on a plateau (stop once ``patience`` evaluations in a row did not improve the best),
  read off the evaluations of the largest budget's trainings.

``--bodies-from RUN`` trains the distinct bodies of ``--generations`` of a run's table instead (real
designers' generations).

Usage::

    python benchmarks/research/ppo_budgets.py --bodies 30 --budgets 12500,50000,200000 --processes 2 --out /tmp/budgets
    python benchmarks/research/ppo_budgets.py --bodies-from RUN --designer gda --generations 1,2,3 --budgets 12500,50000
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import gdabench  # before torch: it pins torch's CPU kernels to AVX2 (gdabench.cpu)


def train_bodies(names: list[str], timesteps: int, seed: int) -> list[dict]:
    import torch

    from gdabench.batched import ArrayBodies
    from gdabench.controllers.ppo import PPOConfig
    from gdabench.controllers.ppo.train import train
    from gdabench.envs.voxel import MAX_EPISODE_STEPS, engine
    from gdabench.envs.voxel.batch import TaskBatch

    torch.set_num_threads(1)
    pad = engine.body_tables(["44444/44444/44444/44444/44444"])
    results = train(
        PPOConfig(timesteps=timesteps),
        lambda n: ArrayBodies(TaskBatch("Walker-v0", names, n, pad=pad), n, MAX_EPISODE_STEPS),
        [seed] * len(names),
        pad=(2 + 2 * 36, 25),
    )
    return [{"body": b, "reward": r.reward, "curve": [[e.timesteps, e.mean] for e in r.evaluations]}
            for b, r in zip(names, results)]


def measure(names: list[str], budget: int, args: argparse.Namespace) -> list[dict]:
    path = Path(args.out) / f"budget-{budget}.json"
    if path.exists():
        return json.loads(path.read_text())
    env = {**os.environ, "OMP_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1"}
    shares = [names[i :: args.processes] for i in range(args.processes)]
    procs = [subprocess.Popen([sys.executable, __file__, "--one", ",".join(share), "--budget", str(budget),
                               "--seed", str(args.seed)], stdout=subprocess.PIPE, text=True, env=env)
             for share in shares if share]
    rows = [row for p in procs for row in json.loads(p.communicate()[0].splitlines()[-1])]
    if any(p.returncode for p in procs):
        raise SystemExit(f"a training process failed at budget {budget}")
    rows.sort(key=lambda r: names.index(r["body"]))
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(rows))
    return rows


def designer_bodies(run: str, generations: str, designer: str | None = None) -> list[list[str]]:
    """The distinct bodies of each of ``generations`` in a run's table (of ``designer``'s trials only
    if given), in the table's order: real designers' generations, offspring of selected parents."""
    frame = gdabench.open_run(run).evaluations()
    if designer:
        frame = frame[frame["designer"] == designer]
    return [list(dict.fromkeys(frame[frame["generation"] == int(g)]["body"])) for g in generations.split(",")]


def top(rewards: list[float], k: int) -> set[int]:
    return set(sorted(range(len(rewards)), key=lambda i: -rewards[i])[:k])


def halving(table: dict[int, list[float]], eta: int, continued: bool = False) -> tuple[list[float], int]:
    """Successive halving's final rewards and env steps: all bodies at the smallest budget, the best 1/eta on.

    ``continued``: a survivor's training goes on from where it stopped, costing only the difference to
    the next budget.  PPO's training at a constant learning rate is the same whatever its budget (the
    budget only sets when it stops and where it is evaluated), so the reward of a continued training is
    the reward at the larger budget, up to which checkpoints were evaluated.
    """
    budgets = sorted(table)
    n = len(table[budgets[0]])
    final, alive, steps, done = list(table[budgets[0]]), list(range(n)), 0, 0
    for i, budget in enumerate(budgets):
        steps += (budget - done if continued else budget) * len(alive)
        done = budget
        for b in alive:
            final[b] = table[budget][b]
        if i + 1 < len(budgets):
            alive = sorted(alive, key=lambda b: -final[b])[: max(5, -(-len(alive) // eta))]
    return final, steps


def plateau(curve: list[list[float]], patience: int) -> tuple[float, int]:
    """Best evaluation and timesteps used when stopping after ``patience`` evaluations without a new best."""
    best, since = float("-inf"), 0
    for timesteps, value in curve:
        if value > best:
            best, since = value, 0
        else:
            since += 1
            if since >= patience:
                return best, int(timesteps)
    return best, int(curve[-1][0])


def main() -> None:
    import numpy as np

    from gdabench.body import random_body

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bodies", type=int, default=30)
    parser.add_argument("--budgets", default="12500,50000,200000")
    parser.add_argument("--processes", type=int, default=2)
    parser.add_argument("--seed", type=int, default=0, help="the training seed of every body")
    parser.add_argument("--body-seed", type=int, default=7)
    parser.add_argument("--out", default="ppo-budgets")
    parser.add_argument("--bodies-from", help="a run directory: train the bodies its designers proposed instead")
    parser.add_argument("--generations", default="1,2,3", help="with --bodies-from: which generations (each trial's)")
    parser.add_argument("--designer", help="with --bodies-from: only this designer's trials")
    parser.add_argument("--one", help=argparse.SUPPRESS)
    parser.add_argument("--budget", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        print(json.dumps(train_bodies(args.one.split(","), args.budget, args.seed)))
        return
    if args.bodies_from:
        groups = designer_bodies(args.bodies_from, args.generations, args.designer)
    else:
        rng = np.random.default_rng(args.body_seed)
        groups = [[random_body(rng).text for _ in range(args.bodies)]]
    names = list(dict.fromkeys(n for g in groups for n in g))
    budgets = sorted(int(b) for b in args.budgets.split(","))
    runs = {b: measure(names, b, args) for b in budgets}
    print(f"{len(names)} bodies, training seed {args.seed}")
    summaries = []
    for label, group in zip(args.generations.split(",") if args.bodies_from else ["all"], groups):
        rows = {b: [runs[b][names.index(n)] for n in group] for b in budgets}
        print(f"\n== {'generation ' + label if args.bodies_from else 'the bodies'} ({len(group)} bodies)")
        summaries.append(report(rows, budgets))
    if len(summaries) > 1:
        print(f"\n== mean over the {len(summaries)} generations (saved, Spearman, top 5 shared)")
        for key in summaries[0]:
            values = np.array([s[key] for s in summaries])
            print(f"  {key}: " + ", ".join(f"{v:.2f}" for v in values.mean(axis=0)))


def report(runs: dict[int, list[dict]], budgets: list[int]) -> dict[str, tuple[float, float, float]]:
    """Print one body set's rank agreement and multi-fidelity figures; return the latter by schedule."""
    import numpy as np
    from scipy.stats import spearmanr

    table = {b: [r["reward"] for r in rows] for b, rows in runs.items()}
    n, largest = len(table[budgets[0]]), budgets[-1]
    print("rewards per budget (min / median / max):")
    for b in budgets:
        print(f"  {b:>8,}: {min(table[b]):6.2f} / {float(np.median(table[b])):6.2f} / {max(table[b]):6.2f}")
    print("rank agreement (Spearman) and top-5 overlap between budgets:")
    for i, a in enumerate(budgets):
        for b in budgets[i + 1 :]:
            rho = spearmanr(table[a], table[b]).statistic
            shared = len(top(table[a], 5) & top(table[b], 5))
            print(f"  {a:>8,} vs {b:>8,}: Spearman {rho:.3f}, top 5 shared {shared}/5")
    full = n * largest
    print(f"against full training at {largest:,} for every body ({full:,} env steps):")
    out = {}

    def row(name: str, final: list[float], steps: int) -> None:
        rho = spearmanr(final, table[largest]).statistic
        shared = len(top(final, 5) & top(table[largest], 5))
        print(f"  {name}: saves x{full / steps:.2f}, Spearman {rho:.3f}, top 5 shared {shared}/5")
        out[name] = (full / steps, float(rho), shared / 5)

    for continued in (False, True):
        for eta in (2, 3, 4):
            final, steps = halving(table, eta, continued)
            row(f"successive halving eta={eta} ({'continued' if continued else 'from scratch'})", final, steps)
    for patience in (2, 3, 4):
        stopped = [plateau(r["curve"], patience) for r in runs[largest]]
        row(f"early stop after {patience} evaluations without a new best", [s[0] for s in stopped],
            sum(s[1] for s in stopped))
    return out

if __name__ == "__main__":
    main()
