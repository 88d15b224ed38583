"""Designers x analytic landscapes: the comparison table of docs/benchmarks/landscapes.md, as markdown.

Each designer runs the ``landscapes`` suite (or the environments given with ``--envs``) as one
suite run, ``<root>/<designer>``, unless a complete one exists (designers and seeds can be added
later without redoing the others, see ``suite_runs.py``; an interrupted run is resumed).  Then one
table row per (environment, designer): seeds that reached the environment's optimum, median evaluations to reach it
(a seed that never reached it counts as infinitely many, so the median says "not reached" when half the
seeds or more missed it), median best reward with its range, and median wall time of a seed.

    nice -n 10 python benchmarks/figures/landscape_table.py --designers ga,random
    nice -n 10 python benchmarks/figures/landscape_table.py --designers ga,cppn,gda,random   # adds cppn, gda
    python benchmarks/figures/landscape_table.py --designers ga,cppn,gda,random --no-run      # table only

Each run is ``gdabench compare --suite landscapes -d DESIGNER --seeds 0..9 --out <root>/DESIGNER``.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import pandas as pd
from suite_runs import ensure_runs, run_dirs, stopped

from gdabench import Experiment, PluginChoice, RunDirectory
from gdabench.errors import GdabenchError
from gdabench.experiment.config import parse_seeds
from gdabench.experiment.plan import Plan, file_name
from gdabench.plugins import registry
from gdabench.stats.summary import summarize, thresholds


def table_rows(designers: list[list[Path]], envs: list[PluginChoice]) -> pd.DataFrame:
    """One summary row per (env, designer) over all of a designer's runs, environments in the order given."""
    frames = []
    for dirs in designers:
        runs = [RunDirectory.open(d) for d in dirs]
        if runs:
            status = next((r.meta.get("status") for r in runs if r.meta.get("status") != "complete"), "complete")
            evaluations = pd.concat([r.load_evaluations() for r in runs], ignore_index=True)
            frames.append(summarize(evaluations, thresholds(runs[0].meta)).assign(status=status))
    if not frames:
        return pd.DataFrame()
    rows = pd.concat(frames, ignore_index=True)
    order = {e.label: i for i, e in enumerate(envs)}
    return rows[rows["env"].isin(order)].sort_values("env", key=lambda col: col.map(order), kind="stable")


def fmt(value: float, digits: int = 4) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "unknown"
    return f"{value:.{digits}g}"


def markdown(rows: pd.DataFrame) -> str:
    header = (
        "| env | optimum | designer | seeds at optimum | evals to optimum (median) | best reward: median "
        "(min-max) | wall s per seed (median) |\n"
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
    parser.add_argument(
        "--designers", default="ga,cppn,gda,random", help="comma-separated designers (labels may carry [params])"
    )
    parser.add_argument("--envs", default=None, help="comma-separated environments (default: the landscapes suite)")
    parser.add_argument("--seeds", default="0..9")
    parser.add_argument("--budget", type=int, default=1000)
    parser.add_argument("--population", type=int, default=25)
    parser.add_argument("--root", type=Path, default=Path("results/landscapes"), help="where the run directories live")
    parser.add_argument("--no-run", action="store_true", help="only read existing runs and print the table")
    args = parser.parse_args(argv)
    try:
        designers = PluginChoice.parse_list(args.designers)
        envs = (
            PluginChoice.parse_list(args.envs)
            if args.envs
            else [PluginChoice.parse(e) for e in registry().get("suite", "landscapes").spec.envs]
        )
        seeds = tuple(parse_seeds(args.seeds))
        experiments = [
            Experiment((d,), tuple(envs), population=args.population, budget=args.budget, seeds=seeds)
            for d in designers
        ]
        if not args.no_run:
            for experiment in experiments:  # check every name and parameter before spending time on runs
                Plan.resolve(experiment)
            for experiment in experiments:
                ensure_runs(args.root / file_name(experiment.designers[0].label), experiment)
        rows = table_rows([run_dirs(args.root / file_name(d.label)) for d in designers], envs)
    except (GdabenchError, KeyboardInterrupt) as exc:
        return stopped(exc)
    if rows.empty:
        print(f"error: no runs under {args.root} for these designers", file=sys.stderr)
        return 2
    print(markdown(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
