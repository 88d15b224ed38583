"""How long `gdabench report` takes on a full-size run (prints figures; not part of the test suite).

    python benchmarks/figures/report_speed.py                 # builds ga,random on simple, 1000 evaluations, seeds 0..9
    python benchmarks/figures/report_speed.py RUN_DIR -n 5    # times the report of an existing run

Prints the median, min and max wall time of ``write_report`` over ``-n`` repetitions (the run
is read from disk each time, as the CLI does; imports are not counted).
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import pandas as pd

from gdabench import Experiment, PluginChoice
from gdabench.report.build import write_report
from gdabench.running.runner import compare


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("run_dir", nargs="?", type=Path)
    parser.add_argument("-n", "--repeat", type=int, default=5)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        run_dir = args.run_dir
        if run_dir is None:
            experiment = Experiment(
                designers=(PluginChoice("ga", {}, "ga"), PluginChoice("random", {}, "random")),
                envs=PluginChoice("simple", {}, "simple"),
                budget=1000,
                seeds=tuple(range(10)),
            )
            run_dir = compare(experiment, Path(tmp) / "run").path
        rows = len(pd.read_parquet(run_dir / "evaluations.parquet"))
        times = []
        for i in range(args.repeat):
            start = time.perf_counter()
            write_report(run_dir, Path(tmp) / f"report{i}")
            times.append(time.perf_counter() - start)
    print(
        f"report of {run_dir} ({rows} rows): median {statistics.median(times):.2f} s, min {min(times):.2f} "
        f"s, max {max(times):.2f} s over {len(times)} runs"
    )


if __name__ == "__main__":
    main()
