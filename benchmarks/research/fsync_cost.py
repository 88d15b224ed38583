"""What flushing every result file to disk (fsync before each rename) costs a run on ``simple``.

Research, kept for the record (``benchmarks/research/``): what the durability that a resume relies on costs
(docs/scaling.md, Resume); no figure of it is committed.

Runs the same comparison with fsync on and with fsync replaced by a no-op, alternating, in one
process, and prints the median wall time of each and their ratio.  ``simple`` is the worst case:
its evaluations cost nothing, so the writes after every generation are all there is.

    python benchmarks/research/fsync_cost.py            # ga,random on simple, seeds 0..4, 5 repeats
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path
from unittest import mock

from gdabench import Experiment, PluginChoice
from gdabench.execution import Execution
from gdabench.running.runner import compare


def timed(experiment: Experiment, out: Path, fsync: bool) -> float:
    start = time.perf_counter()
    with mock.patch("os.fsync", os.fsync if fsync else (lambda fd: None)):
        compare(experiment, out, execution=Execution(jobs=1))
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--seeds", type=int, default=5)
    args = parser.parse_args()
    experiment = Experiment(
        (PluginChoice("ga"), PluginChoice("random")), PluginChoice("simple"), seeds=tuple(range(args.seeds))
    )
    times: dict[bool, list[float]] = {True: [], False: []}
    with tempfile.TemporaryDirectory(dir=".") as tmp:
        for i in range(args.repeats):
            for fsync in (False, True) if i % 2 else (True, False):
                times[fsync].append(timed(experiment, Path(tmp) / f"{fsync}-{i}", fsync))
    on, off = statistics.median(times[True]), statistics.median(times[False])
    generations = 2 * args.seeds * 40
    print(
        f"{experiment.designers[0].label},random on simple, {args.seeds} seeds ({generations} generations, "
        f"jobs 1), median of {args.repeats}:"
    )
    print(f"  with fsync    {on:6.2f} s")
    print(f"  without fsync {off:6.2f} s")
    print(f"  ratio {on / off:.2f}  ({(on - off) / generations * 1000:.1f} ms per generation)")


if __name__ == "__main__":
    main()
