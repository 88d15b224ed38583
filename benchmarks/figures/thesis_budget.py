"""The thesis's budget against its author's numbers: the author's Walker-v0 bodies trained again here.

The thesis's author trained every Walker-v0 body with Evolution Gym 2.0's PPO for 1e6 timesteps and
published each body's reward (``docs/benchmarks/output/thesis-walker-bodies.csv``, read from
JohnStewardson/evolving_robots_diffusion by ``benchmarks/ops/thesis_walker_bodies.py``).  This script draws
a stratified sample of those bodies (every reward stratum, the course-crossers included), trains each
with ``ppo`` on ``walker`` at every budget of ``--budgets`` and training seed of ``--seeds``, exactly as a
run with that seed trains it (the trial path: ``evaluate_batch`` on the walker environment, lockstep,
evaluation seed from the run seed and the body), and sets the rewards beside the author's:

* Spearman's rank correlation of each budget's rewards with the author's 1e6 rewards (and with this
  1e6's), and how many of the author's top 5 each budget's top 5 holds;
* the share of bodies that cross the course (reach x = 9.9 within 500 steps) in both;
* the mean difference, here minus the author's: both are scored without the final step's reward
  (Evolution Gym 2.0's convention, ``ppo``'s default ``episode_end=evogym2``).

A body crosses the course when its score comes within 0.1 of the distance to the goal (9.9 minus the
body's starting mean x): the final step, whose reward is dropped, moves a walker much less than that,
and a body that has not crossed after 500 steps ends further away (see ``crossing_distance``).

Rows are appended to ``--out`` (CSV) as each batch of ``--chunk`` bodies finishes, so a killed run loses
at most one batch and resumes where it stopped (a lockstep batch of 25 bodies costs 0.6 of the CPU time
of five batches of 5, so batches are as large as the loss of one allows).  Jobs run in the order of
``--order`` (budget:seed).  ``--part I/N`` trains every N-th body of the sample from the I-th only, so
that N processes (each with its own ``--out``) share the sample; ``table --rows`` reads them together.
One process, one torch thread; set NUMBA_NUM_THREADS=1 and run it under ``nice``::

    NUMBA_NUM_THREADS=1 nice -n 19 python benchmarks/figures/thesis_budget.py train --out /work/wt/thesis-budget.csv \\
        --order 12500:0,50000:0,200000:0,1000000:0:13,12500:1,50000:1,200000:1
    python benchmarks/figures/thesis_budget.py table --rows docs/benchmarks/output/thesis-budget.csv
"""

from __future__ import annotations

import argparse
import csv
import os
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

import gdabench  # noqa: F401 - before torch: it pins torch's CPU kernels to AVX2 (gdabench.cpu)

BODIES = Path(__file__).resolve().parents[2] / "docs/benchmarks/output/thesis-walker-bodies.csv"
FIELDS = ["budget", "seed", "body", "author", "author_designer", "reward", "distance", "best_at", "unstable",
          "seconds", "cpu_seconds", "batch", "finished"]  # fmt: skip
#: the thesis's budget per body, the reference every smaller budget is ranked against
THESIS_TIMESTEPS = 1_000_000
#: a score within this of the distance to the goal crosses the course (the dropped final step moves less)
CROSSING_MARGIN = 0.1


def author_bodies() -> pd.DataFrame:
    """The author's distinct bodies, each with its (first) published reward and designer."""
    frame = pd.read_csv(BODIES, comment="#")
    return frame.drop_duplicates("body").reset_index(drop=True)


def stratified_sample(bodies: pd.DataFrame, strata: int, crossers: int, seed: int) -> pd.DataFrame:
    """``strata`` bodies, one drawn from each of equal-count strata of the author's rewards, plus ``crossers``
    more drawn from the bodies that cross the course (the top stratum alone would hold one or two)."""
    rng = np.random.default_rng(seed)
    distance = bodies["body"].map(crossing_distance)
    crossed = bodies["reward"] >= distance - CROSSING_MARGIN
    ranked = bodies.assign(crossed=crossed).sort_values("reward", kind="stable").reset_index(drop=True)
    picks = [int(rng.choice(part)) for part in np.array_split(np.arange(len(ranked)), strata)]
    rest = [i for i in ranked.index[ranked["crossed"]] if i not in picks]
    picks += [int(i) for i in rng.choice(rest, size=min(crossers, len(rest)), replace=False)]
    return ranked.loc[sorted(picks)].reset_index(drop=True)


def crossing_distance(body: str) -> float:
    """How far the body's mean point x must travel to pass the goal at x = 9.9 from its starting pose."""
    from gdabench.envs.voxel import engine

    tables = engine.body_tables([body])
    start = float(tables.init_pos[0, : tables.n_points[0], 0].mean())
    return 9.9 - start


def done_keys(path: Path) -> set[tuple[int, int, str]]:
    if not path.exists():
        return set()
    frame = pd.read_csv(path)
    return {(int(b), int(s), str(x)) for b, s, x in zip(frame["budget"], frame["seed"], frame["body"])}


def train_chunk(bodies: list[str], budget: int, seed: int) -> tuple[list, float, float]:
    """Train ``bodies`` as a run with ``seed`` trains them (one lockstep batch); outcomes, wall and CPU seconds."""
    from gdabench import seeding
    from gdabench.body import Body
    from gdabench.execution.evaluation import evaluate_batch
    from gdabench.experiment.build import build_run
    from gdabench.experiment.plan import Plan
    from gdabench.plugins import registry
    from gdabench.strategy import EvalTask

    experiment = build_run({"designers": "random", "env": "walker", "controller": f"ppo[timesteps={budget}]",
                            "population": 1, "budget": 1}).experiment  # fmt: skip
    plan = Plan.resolve(experiment, registry(), designers=False)
    parsed = [Body.from_text(b) for b in bodies]
    tasks = [EvalTask(b, seeding.evaluation_seed(seed, b.hash), plan.envs[0].factory, plan.controller) for b in parsed]
    start, cpu = time.perf_counter(), time.process_time()
    outcomes = evaluate_batch(tasks)
    return outcomes, time.perf_counter() - start, time.process_time() - cpu


def train(args: argparse.Namespace) -> None:
    import torch

    torch.set_num_threads(1)
    sample = stratified_sample(author_bodies(), args.strata, args.crossers, args.sample_seed)
    out = Path(args.out)
    done = done_keys(out)
    index, parts = (int(v) for v in args.part.split("/"))
    mine = list(sample.itertuples())[index::parts]
    for job in args.order.split(","):
        budget, seed, *size = (int(float(v)) for v in job.split(":"))
        chunk_size = size[0] if size else args.chunk
        todo = [r for r in mine if (budget, seed, r.body) not in done]
        for start in range(0, len(todo), chunk_size):
            chunk = todo[start : start + chunk_size]
            outcomes, seconds, cpu = train_chunk([r.body for r in chunk], budget, seed)
            new = not out.exists()
            with out.open("a", newline="") as f:
                writer = csv.DictWriter(f, fieldnames=FIELDS)
                if new:
                    writer.writeheader()
                for r, o in zip(chunk, outcomes):
                    writer.writerow({
                        "budget": budget, "seed": seed, "body": r.body, "author": r.reward,
                        "author_designer": r.designer, "reward": o.reward,
                        "distance": round(crossing_distance(r.body), 4),
                        "best_at": o.info.get("ppo_best_at", ""), "unstable": o.info.get("ppo_unstable_episodes", ""),
                        "seconds": round(seconds / len(chunk), 2), "cpu_seconds": round(cpu / len(chunk), 2),
                        "batch": len(chunk),
                        "finished": time.strftime("%Y-%m-%dT%H:%M:%S"),
                    })  # fmt: skip
                f.flush()
                os.fsync(f.fileno())
            print(f"{time.strftime('%H:%M:%S')} budget {budget:,} seed {seed}: {start + len(chunk)}/{len(todo)} "
                  f"bodies, {seconds:,.0f} s ({cpu:,.0f} s CPU) for {len(chunk)}", flush=True)  # fmt: skip


def top(values: pd.Series, k: int = 5) -> set:
    return set(values.sort_values(ascending=False).index[:k])


def table(rows: pd.DataFrame) -> pd.DataFrame:
    """One row per budget and training seed (and the mean over seeds): agreement with the author's rewards."""
    from scipy.stats import spearmanr

    cpu = rows["cpu_seconds"] if "cpu_seconds" in rows.columns else pd.Series(np.nan, index=rows.index)
    rows = rows.assign(crossed=rows["reward"] >= rows["distance"] - CROSSING_MARGIN,
                       author_crossed=rows["author"] >= rows["distance"] - CROSSING_MARGIN, cpu=cpu)  # fmt: skip
    full = rows[rows["budget"] == THESIS_TIMESTEPS].groupby("body")["reward"].mean()  # empty until 1e6 is trained
    out = []
    groups = [(b, str(s), g) for (b, s), g in rows.groupby(["budget", "seed"])]
    groups += [(b, "mean", g.groupby("body").agg(reward=("reward", "mean"), author=("author", "first"),
                                                crossed=("crossed", "mean"), author_crossed=("author_crossed", "first"),
                                                seconds=("seconds", "sum"), cpu=("cpu", "sum")).reset_index())
               for b, g in rows.groupby("budget") if g["seed"].nunique() > 1]  # fmt: skip
    for budget, seed, g in sorted(groups, key=lambda x: (x[0], x[1] == "mean", x[1])):
        g = g.set_index("body")
        crossed = g["crossed"] >= 0.5
        both = int((crossed & g["author_crossed"]).sum())
        shared = len(top(g["reward"]) & top(g["author"]))
        out.append({
            "timesteps": int(budget), "seed": seed, "bodies": len(g),
            "spearman_author": spearmanr(g["reward"], g["author"]).statistic,
            "spearman_1e6": (spearmanr(g["reward"], full.loc[g.index]).statistic
                             if budget != THESIS_TIMESTEPS and g.index.isin(full.index).all() else np.nan),
            "top5_shared": shared,
            "cross_here": int(crossed.sum()), "cross_author": int(g["author_crossed"].sum()), "cross_both": both,
            "mean_diff": float((g["reward"] - g["author"]).mean()),
            "median_here": float(g["reward"].median()), "median_author": float(g["author"].median()),
            "hours": float(g["seconds"].sum()) / 3600,
            "cpu_hours": float(g["cpu"].sum(min_count=len(g))) / 3600,
        })  # fmt: skip
    return pd.DataFrame(out)


def markdown(frame: pd.DataFrame) -> str:
    head = ("| timesteps | training seed | bodies | Spearman vs author | Spearman vs 1e6 here | author's top 5 kept "
            "| cross here / author / both | mean difference | median here / author | hours: wall (CPU) |")
    lines = [head, "|" + "---|" * 10]
    for r in frame.itertuples():
        s1e6 = "" if np.isnan(r.spearman_1e6) else f"{r.spearman_1e6:.2f}"
        lines.append(f"| {r.timesteps:,} | {r.seed} | {r.bodies} | {r.spearman_author:.2f} | {s1e6} "
                     f"| {r.top5_shared}/5 "
                     f"| {r.cross_here} / {r.cross_author} / {r.cross_both} | {r.mean_diff:+.2f} "
                     f"| {r.median_here:.2f} / {r.median_author:.2f} | {r.hours:.2f} "
                     + ("|" if np.isnan(r.cpu_hours) else f"({r.cpu_hours:.2f}) |"))  # fmt: skip
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    t = sub.add_parser("train", help="train the sample (resumable)")
    t.add_argument("--out", required=True)
    t.add_argument("--order", default="12500:0,50000:0,200000:0,1000000:0", help="budget:seed[:chunk] jobs, in order")
    t.add_argument("--chunk", type=int, default=25, help="bodies per lockstep batch (and per write), unless a job says")
    t.add_argument("--part", default="0/1", help="I/N: train bodies I, I+N, I+2N, ... of the sample")
    for p in (t, sub.add_parser("sample", help="print the sample")):
        p.add_argument("--strata", type=int, default=20)
        p.add_argument("--crossers", type=int, default=5)
        p.add_argument("--sample-seed", type=int, default=2024)
    s = sub.add_parser("table", help="the agreement table from the rows")
    s.add_argument("--rows", required=True, help="the rows' CSV (several, comma-separated, are read together)")
    s.add_argument("--markdown", help="also write the table as markdown here")
    args = parser.parse_args()
    if args.command == "train":
        train(args)
    elif args.command == "sample":
        print(stratified_sample(author_bodies(), args.strata, args.crossers, args.sample_seed).to_string())
    else:
        rows = pd.concat([pd.read_csv(path) for path in args.rows.split(",")], ignore_index=True)
        frame = table(rows.drop_duplicates(["budget", "seed", "body"]))
        print(frame.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
        if args.markdown:
            Path(args.markdown).write_text(markdown(frame) + "\n")


if __name__ == "__main__":
    sys.exit(main())
