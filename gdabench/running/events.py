"""What a run tells while it goes: to progress displays (a :class:`RunListener`) and to plugins
(the event hooks of :mod:`gdabench.hookspecs`, called through :class:`PluginHooks`)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Sequence

from ..errors import one_line

if TYPE_CHECKING:
    import pandas as pd

    from ..experiment.plan import Plan
    from ..experiment.trial_spec import TrialSpec
    from ..plugins import Registry
    from .hosts import BodiesDone
    from .trial import GenerationResult


class RunListener:
    """Receives a run's events; override what you need (every method does nothing by default)."""

    def run_started(self, run_dir: Path, plan: Plan, resumed: bool) -> None:
        """The run (or a resume) starts; ``plan`` is the resolved experiment."""

    def trial_started(self, spec: TrialSpec) -> None:
        """A trial was handed to a worker (fresh, or to continue from its checkpoint)."""

    def bodies(self, spec: TrialSpec, progress: BodiesDone) -> None:
        """Bodies of a generation still running were evaluated (not told for trials on Ray)."""

    def generation(self, spec: TrialSpec, result: GenerationResult) -> None:
        """A generation's rows were written."""

    def trial_finished(self, spec: TrialSpec, error: str | None) -> None:
        """A trial ended: its rows are merged (``error`` None) or it failed with ``error``."""

    def reevaluated(self, title: str, done: int, total: int) -> None:
        """After every trial: the final best bodies of trial ``title`` (the ``done``-th of ``total``) were
        re-evaluated (:mod:`gdabench.running.reevaluation`)."""

    def run_finished(self, run_dir: Path, status: str, summary: pd.DataFrame | None) -> None:
        """The run ended: ``complete`` (with its summary table), ``failed`` (with the summary when every trial
        ran but one measured nothing: its every evaluation failed) or ``interrupted``."""


class Listeners(RunListener):
    """Several listeners, told in order."""

    def __init__(self, listeners: Sequence[RunListener]):
        self.listeners = list(listeners)

    def run_started(self, *args: Any) -> None:
        for listener in self.listeners:
            listener.run_started(*args)

    def trial_started(self, *args: Any) -> None:
        for listener in self.listeners:
            listener.trial_started(*args)

    def bodies(self, *args: Any) -> None:
        for listener in self.listeners:
            listener.bodies(*args)

    def generation(self, *args: Any) -> None:
        for listener in self.listeners:
            listener.generation(*args)

    def trial_finished(self, *args: Any) -> None:
        for listener in self.listeners:
            listener.trial_finished(*args)

    def reevaluated(self, *args: Any) -> None:
        for listener in self.listeners:
            listener.reevaluated(*args)

    def run_finished(self, *args: Any) -> None:
        for listener in self.listeners:
            listener.run_finished(*args)


def warn(message: str) -> None:
    print(f"warning: {message}", file=sys.stderr, flush=True)


class PluginHooks(RunListener):
    """Calls the plugins' event hooks; one that raises is reported in one line and not called again
    in this run, and the run goes on (a logger's failure must not cost results)."""

    def __init__(self, reg: Registry, report: Callable[[str], None] = warn):
        self.hook, self.report = reg.pm.hook, report
        self.run_dir: Path | None = None
        self.broken: set[tuple[str, str]] = set()

    def _call(self, name: str, **kwargs: Any) -> None:
        for impl in getattr(self.hook, name).get_hookimpls():
            if (impl.plugin_name, name) in self.broken:
                continue
            try:
                impl.function(**{arg: kwargs[arg] for arg in impl.argnames})
            except Exception as exc:  # noqa: BLE001 - a plugin's failure is the plugin's
                self.broken.add((impl.plugin_name, name))
                self.report(
                    f"plugin {impl.plugin_name!r}: {name}() raised {one_line(exc)}; it is not called again in this run"
                )

    def run_started(self, run_dir: Path, plan: Plan, resumed: bool) -> None:
        self.run_dir = run_dir
        self._call("gdabench_run_started", run_dir=run_dir, experiment=plan.experiment, resumed=resumed)

    def generation(self, spec: TrialSpec, result: GenerationResult) -> None:
        import pandas as pd

        from ..results import core_first

        rows = core_first(pd.DataFrame.from_records(result.rows))
        self._call(
            "gdabench_generation_finished",
            run_dir=self.run_dir,
            trial=spec,
            generation=result.generation,
            rows=rows,
            report=result.report,
        )

    def trial_finished(self, spec: TrialSpec, error: str | None) -> None:
        self._call("gdabench_trial_finished", run_dir=self.run_dir, trial=spec, error=error)

    def run_finished(self, run_dir: Path, status: str, summary: pd.DataFrame | None) -> None:
        self._call("gdabench_run_finished", run_dir=run_dir, status=status, summary=summary)
