"""Print the gda quality table (docs/benchmarks/gda.md) from one or more run directories.

Runs split over several directories (e.g. seeds 0..4 and 5..9 of one setting run in parallel)
are pooled by designer label before summarising, so every row covers all of its seeds::

    python benchmarks/figures/gda_quality_table.py RUN_DIR [RUN_DIR ...] [--threshold 100]

Columns: seeds that reached the threshold, median evaluations to reach it (runs that never
did count as "not reached", so the median is not flattered), best reward (median and range),
and the median wall time of a run.  Only finished trials count: the rows of a trial still running
(or cut short) are left out and said so on stderr.
"""

from __future__ import annotations

import argparse
import sys

import pandas as pd

from gdabench.results import RunDirectory
from gdabench.stats.summary import summarize


def finished_rows(run: RunDirectory) -> pd.DataFrame:
    """The evaluations of ``run``'s finished trials."""
    rows = run.load_evaluations()
    finished = run.finished_trials()
    keep = [(e, d, int(s)) in finished for e, d, s in zip(rows["env"], rows["designer"], rows["seed"])]
    for key in sorted(set(zip(rows["env"], rows["designer"], rows["seed"])) - finished):
        print(f"left out: {key[1]} on {key[0]}, seed {key[2]} (not finished)", file=sys.stderr)
    return rows[keep]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", help="run directories written by gdabench compare/run")
    parser.add_argument(
        "--threshold", type=float, default=100.0, help="reward whose first reach is counted (default: 100)"
    )
    args = parser.parse_args()
    frame = pd.concat([finished_rows(RunDirectory.open(path)) for path in args.runs], ignore_index=True)
    table = summarize(frame, args.threshold)
    print(
        f"| designer | seeds | reaching {args.threshold:g} | evaluations to reach it (median) | best reward, "
        "median (range) | wall s per run (median) |"
    )
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
