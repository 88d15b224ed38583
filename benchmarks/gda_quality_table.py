"""Print the gda quality table (docs/benchmarks/gda.md) from one or more run directories.

Runs split over several directories (e.g. seeds 0..4 and 5..9 of one setting run in parallel)
are pooled by designer label before summarising, so every row covers all of its seeds::

    python benchmarks/gda_quality_table.py RUN_DIR [RUN_DIR ...] [--threshold 100]

Columns: seeds that reached the threshold, median evaluations to reach it (runs that never
did count as "not reached", so the median is not flattered), best reward (median and range),
and the median wall time of a run.
"""

from __future__ import annotations

import argparse

import pandas as pd

from gdabench.results import RunDirectory
from gdabench.report.summary import summarize


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", help="run directories written by gdabench compare/run")
    parser.add_argument("--threshold", type=float, default=100.0, help="reward whose first reach is counted (default: 100)")
    args = parser.parse_args()
    frame = pd.concat([RunDirectory.open(path).load_evaluations() for path in args.runs], ignore_index=True)
    table = summarize(frame, args.threshold)
    print(f"| designer | seeds | reaching {args.threshold:g} | evaluations to reach it (median) | best reward, median (range) | wall s per run (median) |")
    print("|---|---|---|---|---|---|")
    for _, row in table.iterrows():
        to_reach = row["evals_to_threshold_median"]
        reach = "not reached" if to_reach == float("inf") else f"{to_reach:.0f}"
        print(
            f"| `{row['designer']}` | {row['seeds']} | {row['seeds_reached']}/{row['seeds']} | {reach} | "
            f"{row['best_median']:g} ({row['best_min']:g}-{row['best_max']:g}) | {row['wall_seconds_median']:.0f} |"
        )


if __name__ == "__main__":
    main()
