"""A run's progress display: one bar for the whole run and one line per running trial.

Used by the command line (on stderr) and by :func:`gdabench.compare` in scripts and notebooks
(rich draws it in either).  It starts with the first trial, so set-up errors print alone.
"""

from __future__ import annotations

from rich.console import Console
from rich.markup import escape
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TaskID,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)

from ..config import Experiment
from .events import RunListener
from .hosts import BodiesDone
from .trial import GenerationResult
from .trial_spec import TrialSpec


class ProgressDisplay(RunListener):
    """Progress of a run (``done``: evaluations already made per trial key, when resuming)."""

    def __init__(self, experiment: Experiment, done: dict[tuple[str, str, int], int] | None = None, *,
                 console: Console | None = None, quiet: bool = False):
        self.budget, self.quiet = experiment.budget, quiet
        self.done = dict(done or {})
        self.progress = Progress(
            TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TextColumn("evaluations"),
            TimeElapsedColumn(), TimeRemainingColumn(), console=console or Console(stderr=True), disable=quiet,
        )  # fmt: skip
        trials = len(experiment.designers) * len(experiment.envs) * len(experiment.seeds)
        self.total = self.progress.add_task("all trials", total=trials * self.budget, completed=sum(self.done.values()))
        self.lines: dict[int, TaskID] = {}

    def __enter__(self) -> ProgressDisplay:
        return self

    def __exit__(self, *exc: object) -> None:
        if self.progress.live.is_started:  # stopping a display never shown prints an empty line
            self.progress.stop()

    def trial_started(self, spec: TrialSpec) -> None:
        if not self.progress.live.is_started:
            self.progress.start()
        self.lines[spec.index] = self.progress.add_task(
            escape(f"  {spec.title}"), total=self.budget, completed=self.done.get(spec.key, 0)
        )

    def bodies(self, spec: TrialSpec, progress: BodiesDone) -> None:
        """A generation's bodies one by one: the bars move while a slow generation (physics) runs."""
        before = self.done.get(spec.key, 0)
        line = f"  {spec.title} gen {progress.generation}: body {progress.done}/{progress.total}"
        note = f", {progress.note}" if progress.note else ""
        self.progress.update(self.lines[spec.index], completed=before + progress.done, description=escape(line + note))
        self.progress.update(self.total, completed=sum(self.done.values()) + progress.done)

    def generation(self, spec: TrialSpec, result: GenerationResult) -> None:
        report = result.report
        self.done[spec.key] = report.n_evals
        best = "-" if report.best != report.best else f"{report.best:.4g}"
        self.progress.update(
            self.lines[spec.index],
            completed=report.n_evals,
            description=escape(f"  {spec.title} gen {report.generation} best {best}"),
        )
        self.progress.update(self.total, completed=sum(self.done.values()))

    def trial_finished(self, spec: TrialSpec, error: str | None) -> None:
        task = self.lines.pop(spec.index, None)
        if task is not None:
            self.progress.remove_task(task)
        if error is not None and not self.quiet:  # the run's last line names failed trials too
            self.progress.console.print(escape(f"trial {spec.title} failed: {error}"), style="red", highlight=False)

    def reevaluated(self, title: str, done: int, total: int) -> None:
        """Re-evaluation after the trials: one bar over the trials whose best bodies were trained again."""
        if not self.progress.live.is_started:
            self.progress.start()
        line = self.lines.get(-1)
        if line is None:
            line = self.lines[-1] = self.progress.add_task("re-evaluating the best bodies", total=total)
        self.progress.update(line, completed=done, description=escape(f"re-evaluated the best bodies of {title}"))
