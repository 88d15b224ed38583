"""The Python entry points for notebooks and scripts: :func:`compare` and :func:`open_run`.

They take what the command line takes (strings such as ``"ga,gda[epochs=50]"``, or
:class:`~gdabench.experiment.config.PluginChoice` objects) and return a :class:`Run`, whose tables are
pandas DataFrames::

    import gdabench
    run = gdabench.compare(designers="ga,cppn", env="simple", seeds=range(3), budget=200)
    run.summary()                 # one row per designer and environment
    run.evaluations()             # one row per body
    run.report()                  # plots, tables and report.html next to the run
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

import pandas as pd

from .execution.options import Execution
from .experiment.build import DEFAULTS, Choices, RunSetup, build_run, significance_warnings
from .experiment.config import PluginChoice
from .plugins import Registry
from .results import RunDirectory, load_reevaluations
from .running.events import RunListener
from .running.runner import execute


@dataclass(frozen=True)
class Run:
    """A run directory, read as pandas tables (the run may still be going)."""

    path: Path

    @property
    def meta(self) -> dict[str, Any]:
        """``run.json``: configuration, status, versions, execution."""
        return RunDirectory.open(self.path).meta

    @property
    def status(self) -> str:
        return str(self.meta.get("status"))

    def evaluations(self) -> pd.DataFrame:
        """One row per proposed body (see :data:`gdabench.results.COLUMNS`)."""
        return RunDirectory.open(self.path).load_evaluations()

    def summary(self, threshold: float | None = None) -> pd.DataFrame:
        """One row per (designer, environment, controller): best reward, evaluations to the
        threshold (default: each environment's optimum), wall time, with bootstrap intervals."""
        from .stats.summary import summarize, thresholds

        again = load_reevaluations(self.path)
        return summarize(self.evaluations(), thresholds(self.meta, threshold), reevaluations=again)

    def reevaluations(self) -> pd.DataFrame:
        """One row per re-evaluation of a trial's final best bodies (see :mod:`gdabench.running.reevaluation`)."""
        return load_reevaluations(self.path)

    def report(self, out: str | Path | None = None, **options: Any) -> Path:
        """Write the report (see :func:`gdabench.report.build.write_report`); the path of report.html."""
        from .report.build import write_report

        return write_report(self.path, out, **options).out / "report.html"

    def _repr_html_(self) -> str:  # a notebook shows the summary table
        return self.summary().to_html(index=False)


def open_run(path: str | Path) -> Run:
    """A run already on disk (finished, failed, or still going)."""
    return Run(RunDirectory.open(path).path)


def compare(
    designers: Choices,
    env: Choices = DEFAULTS["env"],
    *,
    controller: str | PluginChoice | None = None,
    seeds: str | Iterable[int] = DEFAULTS["seeds"],
    budget: int = DEFAULTS["budget"],
    population: int = DEFAULTS["population"],
    shape: str | Sequence[int] = DEFAULTS["shape"],
    stop_at_optimum: bool = DEFAULTS["stop_at_optimum"],
    reevaluate: str | bool | None = None,
    primary: str | Mapping[str, Any] | None = None,
    out: str | Path | None = None,
    execution: Execution | None = None,
    progress: bool = True,
    listener: RunListener | None = None,
    reg: Registry | None = None,
) -> Run:
    """Run designers side by side, as ``gdabench compare`` does, and return the finished run.

    ``env`` may name several environments (a suite): every designer runs on each.  ``seeds``
    takes ``"0..9"`` or any iterable of integers.  ``progress`` shows a progress display (in a
    terminal or a notebook); ``listener`` receives the run's events.  ``reevaluate`` is ``"3x5"``
    (each trial's 3 best bodies under 5 further seeds), ``"off"``, or None for the default (on with a
    controller); ``primary`` names the comparison tested alone (``"gda,ga"`` or a table as in an
    experiment file).  Warns (``UserWarning``) before the run when its seeds cannot reach significance.
    """
    extra = {k: v for k, v in (("reevaluate", reevaluate), ("primary", primary)) if v is not None}
    setup = build_run(
        {"designers": designers, "env": env, "controller": controller, "seeds": seeds, "budget": budget,
         "population": population, "shape": shape, "stop_at_optimum": stop_at_optimum, "out": out, **extra,
         **(execution.to_json() if execution is not None else {})},
        reg=reg,
    )  # fmt: skip
    for line in significance_warnings(setup.experiment):  # what the seeds cannot show, before the run
        warnings.warn(line, UserWarning, stacklevel=2)
    if progress and listener is None:
        from .running.progress import ProgressDisplay

        with ProgressDisplay(setup.experiment) as display:
            return _run(setup, display, reg)
    return _run(setup, listener, reg)


def _run(setup: RunSetup, listener: RunListener | None, reg: Registry | None) -> Run:
    return Run(execute(setup, listener=listener, reg=reg).path)
