"""Running ``gdabench`` as a real process, and reading its run directories for comparison."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pandas as pd

from gdabench.results import RunDirectory

#: columns that legitimately differ between two runs of the same command
TIMING = ["run_id", "eval_seconds", "design_seconds", "elapsed_seconds", "timestamp"]


def default_sigint() -> None:
    """Ctrl-C as from a terminal, even when the suite itself runs as a background job (whose children
    inherit an ignored SIGINT and so would never see the tests' SIGINTs)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def cli(
    *args: str, site: Path, env: dict | None = None, background: bool = False, timeout: float = 300
) -> subprocess.Popen | subprocess.CompletedProcess:
    """``python -m gdabench *args`` with the faulty plugin importable (``env`` adds variables)."""
    environ = dict(
        os.environ,
        COLUMNS="200",
        PYTHONPATH=os.pathsep.join(filter(None, [str(site), os.environ.get("PYTHONPATH")])),
        **(env or {}),
    )
    command = [sys.executable, "-m", "gdabench", *args]
    if background:
        return subprocess.Popen(
            command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=environ, preexec_fn=default_sigint
        )
    return subprocess.run(command, capture_output=True, text=True, env=environ, timeout=timeout)


def table(run_dir: Path, drop=()) -> pd.DataFrame:
    """A run's rows without the columns that differ between identical runs."""
    frame = RunDirectory.open(run_dir).load_evaluations()
    return frame.drop(columns=[*TIMING, *drop]).reset_index(drop=True)


def said(err: str) -> list[str]:
    """The lines a command printed to stderr, without the warning that its few seeds cannot reach significance
    (printed before the run starts; the tests that read these are about what a failure says)."""
    return [line for line in err.splitlines() if line.strip() and not line.startswith("warning: no pair of designers")]


def error_lines(result: subprocess.CompletedProcess) -> list[str]:
    return said(result.stderr)
