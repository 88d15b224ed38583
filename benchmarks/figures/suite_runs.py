"""One designer's suite run that grows by seeds, for the table scripts (landscape_table, scaling_table).

A designer's run lives in ``<dir>``; seeds asked for later are added to it (``compare --resume
--seeds``), so adding seeds 5-9 to a finished 0-4 run costs only the new seeds.  Runs made before
resume could add seeds hold theirs in ``<dir>.seeds-<seeds>`` beside it; a table reads them all.
"""

from __future__ import annotations

import glob
import sys
from dataclasses import replace
from pathlib import Path

from gdabench import Experiment, RunDirectory
from gdabench.errors import ConfigError, GdabenchError, RunFailure, Terminated
from gdabench.execution.options import Execution
from gdabench.experiment.config import format_seeds
from gdabench.running.runner import compare


def run_dirs(out: Path) -> list[Path]:
    """The designer's run in ``out``, then the runs beside it that hold seeds added earlier."""
    return [d for d in [out, *sorted(out.parent.glob(f"{glob.escape(out.name)}.seeds-*"))] if (d / "run.json").exists()]


def ensure_runs(
    out: Path, experiment: Experiment, execution: Execution | None = None, label: str | None = None
) -> list[Path]:
    """Resume the interrupted runs of the designer holding seeds asked for, then add the seeds that no
    run holds yet to the run in ``out`` (so work started is finished first); the run directories."""
    label = label or experiment.designers[0].label
    metas = {path: RunDirectory.open(path).meta for path in run_dirs(out)}
    runs = {path: Experiment.from_json(meta["config"]) for path, meta in metas.items()}
    for path, config in runs.items():
        if replace(config, seeds=experiment.seeds) != experiment:
            raise ConfigError(
                f"{path} holds a run with other settings (environments, budget or population); use another --root"
            )
    held = {seed for config in runs.values() for seed in config.seeds}
    missing = tuple(seed for seed in experiment.seeds if seed not in held)
    if out not in runs:
        if missing:
            print(f"running {label} (seeds {format_seeds(missing)}) into {out}", file=sys.stderr)
            compare(replace(experiment, seeds=missing), out, execution=execution, command=sys.argv)
        return run_dirs(out)
    for path, config in sorted(runs.items(), key=lambda item: item[0] == out):  # finish older runs before adding seeds
        added = missing if path == out else ()
        if added or (metas[path].get("status") != "complete" and set(config.seeds) & set(experiment.seeds)):
            print(
                f"resuming {label} in {path}" + (f", adding seeds {format_seeds(added)}" if added else ""),
                file=sys.stderr,
            )
            compare(replace(config, seeds=config.seeds + added), path, resume=True, execution=execution)
    return run_dirs(out)


def stopped(exc: GdabenchError | KeyboardInterrupt) -> int:
    """Say in one line why a table script stopped, and its exit code as gdabench's: 2 for input, 1 for
    a run that failed, 130 or 143 for Ctrl-C or SIGTERM (the runs so far are kept either way)."""
    if isinstance(exc, KeyboardInterrupt):
        how = "terminated (SIGTERM)" if isinstance(exc, Terminated) else "interrupted"
        print(f"error: {how}; the runs so far are kept, and the same command resumes them", file=sys.stderr)
        return 143 if isinstance(exc, Terminated) else 130
    print(f"error: {exc}", file=sys.stderr)
    return 1 if isinstance(exc, RunFailure) else 2
