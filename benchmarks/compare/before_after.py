"""The same jobs on an older commit and on this one, in turn on one machine: times, and whether the tables agree.

    git worktree add /tmp/before 71cdc0a      # main just before issue 54's first merge
    python benchmarks/compare/before_after.py --before /tmp/before --rounds 2 \
        --out docs/benchmarks/output/house-before-after.json

Three jobs, each run as a command in its tree's own Python path (``PYTHONPATH=<tree>``, this environment's
packages), the sides alternating within a round (before first in odd rounds, after first in even ones) so that
a drift of the machine's load falls on both, after one untimed engine job per tree (which compiles and caches
its Numba kernels):

* ``main``: the main job, ``gdabench compare --designers ga,cppn,gda --env simple`` (seed 0, budget 1000);
* ``engine``: the voxel engine's env steps/s, ``gdabench/Walker-v2`` as a vector env of 64 environments on one
  thread, random actions;
* ``codesign``: one co-design generation, ``ga`` on ``walker`` with 25 bodies learning ``ppo[timesteps=2048]``
  in lockstep (re-evaluation off, which the older commit may lack).

Times are the command's wall and CPU seconds (its process and its children's); the figure reported per side is
the median over rounds.  The tables of ``main`` and ``codesign`` are compared row for row on every column both
sides have, leaving out the columns that time things.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
#: columns that say when or how fast, not what was designed or scored
TIMING = {"run_id", "eval_seconds", "design_seconds", "elapsed_seconds", "timestamp", "ppo_train_seconds",
          "ppo_eval_seconds", "train_seconds", "sample_seconds", "compiled"}  # fmt: skip

ENGINE = """
import sys, time
import gymnasium as gym, numpy as np
import gdabench
body = np.array([[3, 3, 3, 3, 3], [3, 3, 3, 3, 3], [3, 3, 3, 3, 3], [3, 3, 0, 3, 3], [3, 3, 0, 3, 3]])
n, steps = 64, int(sys.argv[1])
env = gym.make_vec("gdabench/Walker-v2", num_envs=n, vectorization_mode="vector_entry_point", body=body)
rng = np.random.default_rng(0)
actions = rng.uniform(0.6, 1.6, size=(steps, n, env.single_action_space.shape[0]))
env.reset(seed=0)
for a in actions[:20]:
    env.step(a)  # compiled kernels loaded, caches warm
start = time.perf_counter()
for a in actions:
    env.step(a)
print(n * steps / (time.perf_counter() - start))
"""


def compare_args(job: str, budget: int, timesteps: int) -> list[str]:
    if job == "main":
        return ["compare", "--designers", "ga,cppn,gda", "--env", "simple", "--budget", str(budget)]
    return ["compare", "--designers", "ga", "--env", "walker", "--controller", f"ppo[timesteps={timesteps}]",
            "--budget", "25", "--population", "25", "--reevaluate", "off"]  # fmt: skip


def run(tree: Path, job: str, work: Path, args: argparse.Namespace) -> dict[str, Any]:
    """One job in ``tree``: wall and CPU seconds, and the env steps/s or the run directory it made."""
    env = {**os.environ, "PYTHONPATH": str(tree)}
    out = work / f"{job}-{tree.name}-{time.monotonic_ns()}"
    if job == "engine":
        env["NUMBA_NUM_THREADS"] = "1"
        command = [sys.executable, "-c", ENGINE, str(args.engine_steps)]
    else:
        command = [sys.executable, "-m", "gdabench", *compare_args(job, args.budget, args.timesteps),
                   "--seeds", "0", "--out", str(out), "-q", "--no-report"]  # fmt: skip
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(command, cwd=tree, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        sys.exit(f"error: {job} failed in {tree}: {done.stderr.strip().splitlines()[-1:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    result: dict[str, Any] = {"wall_s": round(wall, 2), "cpu_s": round(cpu, 2)}
    if job == "engine":
        result["env_steps_per_s"] = round(float(done.stdout.split()[-1]), 1)
    else:
        result["table"] = str(out / "evaluations.parquet")
    return result


def same_table(a: str, b: str) -> str:
    """Whether two runs' tables agree row for row on their common columns other than timings."""
    import pandas as pd

    left, right = pd.read_parquet(a), pd.read_parquet(b)
    common = [c for c in left.columns if c in right.columns and c not in TIMING]
    same = len(left) == len(right) and left[common].reset_index(drop=True).equals(right[common].reset_index(drop=True))
    return f"{'identical' if same else 'DIFFERENT'} ({len(left)} rows, {len(common)} columns)"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--before", type=Path, required=True, help="a git worktree of the older commit")
    parser.add_argument("--after", type=Path, default=ROOT, help="the newer tree (default: this one)")
    parser.add_argument("--jobs", default="main,engine,codesign", help="which jobs, comma-separated")
    parser.add_argument("--rounds", type=int, default=2, help="times each job runs on each side")
    parser.add_argument("--budget", type=int, default=1000, help="the main job's evaluations per trial")
    parser.add_argument("--timesteps", type=int, default=2048, help="each body's PPO timesteps in codesign")
    parser.add_argument("--engine-steps", type=int, default=500, help="timed env steps of the engine job")
    parser.add_argument("--out", type=Path, help="write the figures here as JSON")
    args = parser.parse_args()
    jobs = args.jobs.split(",")
    if set(jobs) - {"main", "engine", "codesign"} or args.rounds < 1:
        sys.exit("error: --jobs takes main, engine and codesign; --rounds at least 1")
    sides = {"before": args.before.resolve(), "after": args.after.resolve()}
    results: dict[str, dict[str, list[dict[str, Any]]]] = {job: {s: [] for s in sides} for job in jobs}
    with tempfile.TemporaryDirectory() as tmp:
        for side in sides.values():  # each tree's Numba kernels compiled and cached before anything is timed
            run(side, "engine", Path(tmp), args)
        for job in jobs:
            for r in range(args.rounds):
                for side in (("before", "after") if r % 2 == 0 else ("after", "before")):
                    results[job][side].append(run(sides[side], job, Path(tmp), args))
                    print(f"{job} round {r + 1} {side}: {results[job][side][-1]}", flush=True)
        summary: dict[str, Any] = {"command": sys.argv, "before": str(sides["before"]), "after": str(sides["after"]),
                                   "load_average_at_end": os.getloadavg(), "jobs": {}}  # fmt: skip
        print(f"\n{'job':9} {'figure':16} {'before':>10} {'after':>10} {'after/before':>13}")
        for job in jobs:
            figures = ["env_steps_per_s", "wall_s", "cpu_s"] if job == "engine" else ["wall_s", "cpu_s"]
            rounds = {s: [{k: v for k, v in x.items() if k != "table"} for x in results[job][s]] for s in sides}
            entry: dict[str, Any] = {"rounds": rounds}
            for figure in figures:
                b, a = (statistics.median(x[figure] for x in results[job][s]) for s in ("before", "after"))
                entry[f"median_{figure}"] = {"before": b, "after": a, "ratio": round(a / b, 3)}
                print(f"{job:9} {figure:16} {b:10.1f} {a:10.1f} {a / b:13.3f}")
            if job != "engine":
                entry["tables"] = [same_table(b["table"], a["table"])
                                   for b, a in zip(results[job]["before"], results[job]["after"])]  # fmt: skip
                print(f"{job:9} tables, round by round: {', '.join(entry['tables'])}")
            summary["jobs"][job] = entry
    if args.out:
        args.out.write_text(json.dumps(summary, indent=2) + "\n")
        print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
