"""The Python entry points for notebooks and scripts: :func:`compare` and :func:`open_run`.

They take what the command line takes (strings such as ``"ga,gda[epochs=50]"``, or
:class:`~gdabench.config.PluginChoice` objects) and return a :class:`Run`, whose tables are
pandas DataFrames::

    import gdabench
    run = gdabench.compare(designers="ga,cppn", env="simple", seeds=range(3), budget=200)
    run.summary()                 # one row per designer and environment
    run.evaluations()             # one row per body
    run.report()                  # plots, tables and report.html next to the run
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, Sequence

import pandas as pd

from .body import parse_shape
from .config import Experiment, PluginChoice, parse_seeds
from .events import RunListener
from .execution.options import Execution
from .plugins import Registry
from .results import RunDirectory
from .runner import compare as run_experiment

Choices = str | PluginChoice | Sequence[str | PluginChoice]


def _choices(value: Choices) -> tuple[PluginChoice, ...]:
    items = [value] if isinstance(value, (str, PluginChoice)) else list(value)
    out: list[PluginChoice] = []
    for item in items:
        out += PluginChoice.parse_list(item) if isinstance(item, str) else [item]
    return tuple(out)


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
        from .report.summary import summarize, thresholds

        return summarize(self.evaluations(), thresholds(self.meta, threshold))

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
    env: Choices = "simple",
    *,
    controller: str | PluginChoice | None = None,
    seeds: str | Iterable[int] = (0,),
    budget: int = 1000,
    population: int = 25,
    shape: str | Sequence[int] = (5, 5),
    stop_at_optimum: bool = False,
    out: str | Path | None = None,
    execution: Execution | None = None,
    progress: bool = True,
    listener: RunListener | None = None,
    reg: Registry | None = None,
) -> Run:
    """Run designers side by side, as ``gdabench compare`` does, and return the finished run.

    ``env`` may name several environments (a suite): every designer runs on each.  ``seeds``
    takes ``"0..9"`` or any iterable of integers.  ``progress`` shows a progress display (in a
    terminal or a notebook); ``listener`` receives the run's events.
    """
    experiment = Experiment(
        designers=_choices(designers),
        envs=_choices(env),
        controller=PluginChoice.parse(controller) if isinstance(controller, str) else controller,
        shape=parse_shape(shape),
        population=population,
        budget=budget,
        seeds=tuple(parse_seeds(seeds if isinstance(seeds, str) else list(seeds))),
        stop_at_optimum=stop_at_optimum,
    )
    if progress and listener is None:
        from .progress import ProgressDisplay

        with ProgressDisplay(experiment) as display:
            return Run(run_experiment(experiment, out, execution=execution, listener=display, reg=reg).path)
    return Run(run_experiment(experiment, out, execution=execution, listener=listener, reg=reg).path)
