"""Designers x analytic landscapes: the comparison table of issue 10, as markdown.

Runs every (environment, designer) pair that has no complete run yet under ``--root`` (one run
directory each, ``<root>/<env>/<designer>``, so designers can be added later without redoing
the others; an interrupted run is resumed), then prints one table row per pair: seeds that
reached the environment's optimum, median evaluations to reach it (a seed that never reached
it counts as infinitely many, so the median says "not reached" when half the seeds or more
missed it), median best reward with its range, and median wall time of a seed.

    nice -n 10 python benchmarks/landscape_table.py --designers ga,random
    nice -n 10 python benchmarks/landscape_table.py --designers ga,cppn,gda,random   # adds cppn, gda
    python benchmarks/landscape_table.py --designers ga,cppn,gda,random --no-run      # table only
"""

from __future__ import annotations

import argparse
import math
import re
import sys
from pathlib import Path

import pandas as pd

from gdabench import Experiment, PluginChoice, RunDirectory
from gdabench.runner import compare
from gdabench.config import parse_seeds, split_top_level
from gdabench.errors import ConfigError, GdabenchError
from gdabench.plan import Plan
from gdabench.report.summary import summarize

ENVS = "simple,two-peaks,target,nk[k=0],nk[k=4]"


def slug(label: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.=-]+", "_", label).strip("_")


def run_dir(root: Path, env: str, designer: str) -> Path:
    return root / slug(env) / slug(designer)


def experiment_for(env: PluginChoice, designer: PluginChoice, seeds: list[int], budget: int, population: int) -> Experiment:
    return Experiment(designers=(designer,), envs=env, population=population, budget=budget, seeds=tuple(seeds))


def ensure_run(root: Path, env: PluginChoice, designer: PluginChoice, seeds: list[int], budget: int, population: int) -> None:
    """Run (or resume) one designer on one environment unless a complete run exists."""
    out = run_dir(root, env.label, designer.label)
    experiment = experiment_for(env, designer, seeds, budget, population)
    if (out / "run.json").exists():
        run = RunDirectory.open(out)
        if Experiment.from_json(run.meta["config"]) != experiment:
            raise ConfigError(f"{out} holds a run with other settings (budget, population or seeds); use another --root")
        if run.meta.get("status") == "complete":
            return
        print(f"resuming {designer.label} on {env.label} in {out}", file=sys.stderr)
        compare(experiment, out, resume=True)
    else:
        print(f"running {designer.label} on {env.label} into {out}", file=sys.stderr)
        compare(experiment, out, command=sys.argv)


def table_rows(root: Path, envs: list[PluginChoice], designers: list[PluginChoice]) -> pd.DataFrame:
    """One summary row per (env, designer) with a run under ``root``; missing runs are skipped."""
    rows = []
    for env in envs:
        for designer in designers:
            out = run_dir(root, env.label, designer.label)
            if not (out / "run.json").exists():
                continue
            run = RunDirectory.open(out)
            optimum = run.meta.get("env_optimum")
            summary = summarize(run.load_evaluations(), optimum)
            for _, r in summary.iterrows():
                rows.append({**r.to_dict(), "status": run.meta.get("status")})
    return pd.DataFrame(rows)


def fmt(value: float, digits: int = 4) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "unknown"
    return f"{value:.{digits}g}"


def markdown(rows: pd.DataFrame) -> str:
    header = (
        "| env | optimum | designer | seeds at optimum | evals to optimum (median) | best reward: median (min-max) | wall s per seed (median) |\n"
        "|---|---:|---|---:|---:|---:|---:|\n"
    )
    lines = []
    for _, r in rows.iterrows():
        known = not math.isnan(r["threshold"])
        med = r["evals_to_threshold_median"]
        to_opt = "-" if not known else ("not reached" if med == math.inf else f"{med:.0f}")
        hits = f"{r['seeds_reached']}/{r['seeds']}" if known else "-"
        note = "" if r["status"] == "complete" else f" ({r['status']})"
        lines.append(
            f"| {r['env']} | {fmt(r['threshold'])} | {r['designer']}{note} | {hits} | {to_opt} | "
            f"{fmt(r['best_median'])} ({fmt(r['best_min'])}-{fmt(r['best_max'])}) | {r['wall_seconds_median']:.1f} |"
        )
    return header + "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--designers", default="ga,cppn,gda,random", help="comma-separated designers (labels may carry [params])")
    parser.add_argument("--envs", default=ENVS, help=f"comma-separated environments (default: {ENVS})")
    parser.add_argument("--seeds", default="0..9")
    parser.add_argument("--budget", type=int, default=1000)
    parser.add_argument("--population", type=int, default=25)
    parser.add_argument("--root", type=Path, default=Path("results/landscapes"), help="where the run directories live")
    parser.add_argument("--no-run", action="store_true", help="only read existing runs and print the table")
    args = parser.parse_args(argv)
    try:
        designers = [PluginChoice.parse(d) for d in split_top_level(args.designers)]
        envs = [PluginChoice.parse(e) for e in split_top_level(args.envs)]
        seeds = parse_seeds(args.seeds)
        if not args.no_run:
            for env in envs:  # check every name and parameter before spending time on runs
                for designer in designers:
                    Plan.resolve(experiment_for(env, designer, seeds, args.budget, args.population))
            for env in envs:
                for designer in designers:
                    ensure_run(args.root, env, designer, seeds, args.budget, args.population)
        rows = table_rows(args.root, envs, designers)
    except GdabenchError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if rows.empty:
        print(f"error: no runs under {args.root} for these designers and environments", file=sys.stderr)
        return 2
    print(markdown(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
