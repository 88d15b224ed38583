"""One designer's suite run that grows by seeds, for the table scripts (landscape_table, scaling_table).

The first run of a designer lives in ``<dir>``; seeds asked for later run into
``<dir>.seeds-<seeds>`` beside it, so adding seeds 5-9 to a finished 0-4 run costs only the new
seeds, and a table reads every run of the designer.
"""

from __future__ import annotations

import glob
import sys
from dataclasses import replace
from pathlib import Path
from typing import Sequence

from gdabench import Experiment, RunDirectory
from gdabench.errors import ConfigError
from gdabench.execution.options import Execution
from gdabench.runner import compare


def seeds_text(seeds: Sequence[int]) -> str:
    """Seeds as runs of consecutive numbers, for a directory name: (3, 4, 5, 8) -> '3-5_8'."""
    groups: list[list[int]] = []
    for seed in sorted(seeds):
        if groups and seed == groups[-1][-1] + 1:
            groups[-1].append(seed)
        else:
            groups.append([seed])
    return "_".join(str(g[0]) if len(g) == 1 else f"{g[0]}-{g[-1]}" for g in groups)


def run_dirs(out: Path) -> list[Path]:
    """The designer's first run in ``out``, then the runs that added seeds to it."""
    return [d for d in [out, *sorted(out.parent.glob(f"{glob.escape(out.name)}.seeds-*"))] if (d / "run.json").exists()]


def ensure_runs(out: Path, experiment: Experiment, execution: Execution | None = None, label: str | None = None) -> list[Path]:
    """Run the seeds of ``experiment`` (one designer) that no run in ``out`` or beside it holds yet, and
    resume the interrupted runs holding seeds asked for; the designer's run directories."""
    label = label or experiment.designers[0].label
    held: set[int] = set()
    for path in run_dirs(out):
        run = RunDirectory.open(path)
        config = Experiment.from_json(run.meta["config"])
        if replace(config, seeds=experiment.seeds) != experiment:
            raise ConfigError(f"{path} holds a run with other settings (environments, budget or population); use another --root")
        if run.meta.get("status") != "complete" and set(config.seeds) & set(experiment.seeds):
            print(f"resuming {label} in {path}", file=sys.stderr)
            compare(None, path, resume=True, execution=execution)
        held.update(config.seeds)
    missing = tuple(seed for seed in experiment.seeds if seed not in held)
    if missing:
        path = out if not held else out.with_name(f"{out.name}.seeds-{seeds_text(missing)}")
        print(f"running {label} (seeds {seeds_text(missing)}) into {path}", file=sys.stderr)
        compare(replace(experiment, seeds=missing), path, execution=execution, command=sys.argv)
    return run_dirs(out)
