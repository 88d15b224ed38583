"""The plugin contract of gdabench.

A plugin is any module (or object) with functions marked ``@gdabench.hookimpl`` whose names
match the hooks below.  Built-in plugins are registered through exactly these hooks; a
third-party package makes itself known by declaring an entry point::

    [project.entry-points.gdabench]
    my_plugin = "my_package.plugin"      # the module holding the hookimpls

Two kinds of hooks, as in pytest:

* *collectors* return specs (:mod:`gdabench.specs`): a name, a factory given as an import
  string, default parameters and a one-line description; suites name environments;
* *events* tell a plugin what a run is doing (run started, generation finished, trial finished,
  run finished), e.g. to log figures to an experiment tracker.

Keep the plugin module light: it is imported whenever gdabench starts, so import heavy libraries
only in the factory's module (or inside an event hook).  A ``gdabench_*`` function that is not one
of these hooks, or lacks the ``@gdabench.hookimpl`` marker, is refused with one line.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Sequence

from .specs import PROJECT_NAME, ControllerSpec, DesignerSpec, EnvironmentSpec, SuiteSpec, hookimpl, hookspec

if TYPE_CHECKING:  # the event hooks' argument types; importing them here would import pandas at start-up
    import pandas as pd

    from .experiment.config import Experiment
    from .experiment.trial_spec import TrialSpec

__all__ = ["PROJECT_NAME", "GenerationReport", "hookimpl", "hookspec"]


@dataclass(frozen=True)
class GenerationReport:
    """Progress of one trial after one generation (what progress bars and hooks see)."""

    designer: str
    env: str
    seed: int
    generation: int
    n_evals: int
    budget: int
    new_evals: int
    best: float


@hookspec
def gdabench_designers() -> Sequence[DesignerSpec]:
    """Return the designers (morphology search algorithms) this plugin provides.

    The factory is called as ``factory(shape=(H, W), population=int, budget=int,
    seed=numpy.random.SeedSequence, **params)`` and must return a
    :class:`gdabench.Designer` (ask/tell).
    """


@hookspec
def gdabench_environments() -> Sequence[EnvironmentSpec]:
    """Return the environments (ways to score a body) this plugin provides.

    The factory is called as ``factory(shape=(H, W), **params)`` and must return a
    :class:`gdabench.Environment`.
    """


@hookspec
def gdabench_controllers() -> Sequence[ControllerSpec]:
    """Return the controllers (ways to make a body act in a physics environment).

    The factory is called as ``factory(**params)`` and must return a
    :class:`gdabench.Controller`.
    """


@hookspec
def gdabench_suites() -> Sequence[SuiteSpec]:
    """Return named suites of environments (``--suite NAME``) this plugin provides."""


# -- events: called by the process that runs a comparison, in the order they happen ----------------
# An implementation that raises is reported in one line naming its plugin and is not called again in
# that run; the run itself goes on.  Arguments are passed by name: take only those you need.


@hookspec
def gdabench_run_started(run_dir: Path, experiment: Experiment, resumed: bool) -> None:
    """A run (or a resume) starts writing ``run_dir``."""


@hookspec
def gdabench_generation_finished(
    run_dir: Path, trial: TrialSpec, generation: int, rows: pd.DataFrame, report: GenerationReport
) -> None:
    """A generation of ``trial`` was written: its ``rows`` as they are in the results table, and a
    ``report`` with the trial's evaluations so far and its best reward."""


@hookspec
def gdabench_trial_finished(run_dir: Path, trial: TrialSpec, error: str | None) -> None:
    """``trial`` ended: its rows are merged (``error`` None), or it failed with ``error``."""


@hookspec
def gdabench_run_finished(run_dir: Path, status: str, summary: pd.DataFrame | None) -> None:
    """The run ended with ``status`` (complete, failed or interrupted); ``summary`` is the
    per-designer table when it completed."""
