"""A run's progress display: one bar for the whole run and one line per running trial.

Used by the command line (on stderr) and by :func:`gdabench.compare` in scripts and notebooks
(rich draws it in either).  It starts with the first trial, so set-up errors print alone.
"""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass, field

from rich.console import Console
from rich.markup import escape
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    ProgressColumn,
    Task,
    TaskID,
    TextColumn,
    TimeElapsedColumn,
)
from rich.table import Column
from rich.text import Text

from ..experiment.config import Experiment
from ..experiment.trial_spec import TrialSpec
from .events import RunListener
from .hosts import BodiesDone
from .trial import GenerationResult

Key = tuple[str, str, int]
#: generations an estimate of the time per evaluation looks back on
RECENT = 5


@dataclass
class _Pace:
    """How fast one trial goes, from its own generations: the first one a run makes is left out once
    there are others (a designer's generation 0 is usually drawn at random, in no time)."""

    since: float  # when the last generation (or the trial) ended / started
    generations: list[tuple[float, int]] = field(default_factory=list)  # (seconds, evaluations) each

    def seconds_per_evaluation(self) -> float | None:
        made = self.generations[1:] or self.generations
        seconds, evaluations = sum(s for s, _ in made[-RECENT:]), sum(n for _, n in made[-RECENT:])
        return seconds / evaluations if evaluations else None


class _Eta(ProgressColumn):
    """Time left, as the display estimated it (``task.fields['eta']``: a deadline on the monotonic clock)."""

    def render(self, task: Task) -> Text:
        deadline = task.fields.get("eta")
        if deadline is None or task.finished:
            return Text("eta -:--:--", style="progress.remaining")
        left = max(0, int(deadline - time.monotonic()))
        return Text(f"eta {left // 3600}:{left // 60 % 60:02d}:{left % 60:02d}", style="progress.remaining")


class ProgressDisplay(RunListener):
    """Progress of a run (``done``: evaluations already made per trial key, when resuming).

    Each line reads: what runs, the bar, evaluations done, time elapsed and left, then what the trial
    says it is doing (cut first on a narrow terminal).  Time left comes from each trial's own
    generations (the time per evaluation of its last few), not from how fast the bars moved lately:
    a ``gda`` generation spends a minute training and then scores its 25 bodies at once.
    """

    def __init__(self, experiment: Experiment, done: dict[tuple[str, str, int], int] | None = None, *,
                 console: Console | None = None, quiet: bool = False):
        self.budget, self.quiet = experiment.budget, quiet
        self.done = dict(done or {})
        fixed = Column(no_wrap=True)
        self.progress = Progress(
            TextColumn("{task.description}", table_column=Column(no_wrap=True, overflow="ellipsis", max_width=28)),
            BarColumn(bar_width=12, table_column=fixed), MofNCompleteColumn(table_column=fixed),
            TimeElapsedColumn(table_column=fixed), _Eta(table_column=fixed),
            TextColumn("{task.fields[note]}", table_column=Column(no_wrap=True, overflow="ellipsis", ratio=1)),
            console=console or Console(stderr=True), disable=quiet, expand=True,
        )  # fmt: skip
        self.keys: list[Key] = [(e.label, d.label, s) for s in experiment.seeds for e in experiment.envs
                                for d in experiment.designers]  # fmt: skip
        self.total = self.progress.add_task("all trials", total=len(self.keys) * self.budget,
                                            completed=sum(self.done.values()), note="")  # fmt: skip
        self.lines: dict[int, TaskID] = {}
        self.paces: dict[Key, _Pace] = {}

    def __enter__(self) -> ProgressDisplay:
        return self

    def __exit__(self, *exc: object) -> None:
        if self.progress.live.is_started:  # stopping a display never shown prints an empty line
            self.progress.stop()

    def trial_started(self, spec: TrialSpec) -> None:
        if not self.progress.live.is_started:
            self.progress.start()
        self.paces[spec.key] = _Pace(time.monotonic())
        self.lines[spec.index] = self.progress.add_task(
            escape(f"  {spec.title}"), total=self.budget, completed=self.done.get(spec.key, 0), note=""
        )

    def bodies(self, spec: TrialSpec, progress: BodiesDone) -> None:
        """A generation's bodies one by one: the bars move while a slow generation (physics) runs."""
        before = self.done.get(spec.key, 0)
        bodies = f"body {progress.done}/{progress.total}" if progress.total else ""  # the bar counts them too
        self.progress.update(self.lines[spec.index], completed=before + progress.done,
                             description=escape(f"  {spec.title} gen {progress.generation}"),
                             note=escape(progress.note or bodies))  # fmt: skip
        self.progress.update(self.total, completed=sum(self.done.values()) + progress.done)

    def generation(self, spec: TrialSpec, result: GenerationResult) -> None:
        report = result.report
        now, pace = time.monotonic(), self.paces[spec.key]
        pace.generations.append((now - pace.since, report.n_evals - self.done.get(spec.key, 0)))
        pace.since = now
        self.done[spec.key] = report.n_evals
        best = "-" if report.best != report.best else f"{report.best:.4g}"
        self.progress.update(
            self.lines[spec.index],
            completed=report.n_evals,
            description=escape(f"  {spec.title} gen {report.generation}"),
            note=escape(f"best {best}"),
            eta=self._deadline([spec.key]),
        )
        self.progress.update(self.total, completed=sum(self.done.values()), eta=self._deadline(self.keys))

    def _deadline(self, keys: list[Key]) -> float | None:
        """When ``keys``' trials will have finished, from their paces (a trial not started yet goes at the pace
        of its designer's other trials, or of all); the running trials share the work left."""
        paces = {k: p.seconds_per_evaluation() for k, p in self.paces.items()}
        known = {k: v for k, v in paces.items() if v is not None}
        if not known:
            return None
        overall = statistics.mean(known.values())
        by_designer: dict[str, list[float]] = {}
        for (_, designer, _), spe in known.items():
            by_designer.setdefault(designer, []).append(spe)
        seconds = 0.0
        for key in keys:
            left = self.budget - self.done.get(key, 0)
            if left > 0:
                spe = known[key] if key in known else statistics.mean(by_designer.get(key[1], [overall]))
                seconds += left * spe
        running = max(1, sum(1 for k in keys if k in self.paces and self.done.get(k, 0) < self.budget))
        since = max((self.paces[k].since for k in keys if k in self.paces), default=time.monotonic())
        return since + seconds / running

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
