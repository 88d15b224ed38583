"""The progress display tells the truth: time left from each trial's own generations, the figures of a
line before its words (a narrow terminal cuts the words), and what a long silent phase is doing."""

from __future__ import annotations

import io

import pytest
from rich.console import Console

import gdabench
from gdabench import Experiment, PluginChoice
from gdabench.experiment.plan import Plan
from gdabench.hookspecs import GenerationReport
from gdabench.running import progress as progress_module
from gdabench.running.events import RunListener
from gdabench.running.hosts import BodiesDone
from gdabench.running.progress import ProgressDisplay
from gdabench.running.trial import GenerationResult


class Clock:
    def __init__(self):
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now


def shown(display: ProgressDisplay, width: int = 80) -> list[str]:
    console = Console(file=io.StringIO(), width=width, color_system=None, legacy_windows=False)
    console.print(display.progress.get_renderable())
    return console.file.getvalue().splitlines()


def generation(spec, number: int, n_evals: int) -> GenerationResult:
    report = GenerationReport(spec.designer.label, spec.env.label, spec.seed, number, n_evals, spec.budget, 25, 50.0)
    return GenerationResult(spec.index, number, [], b"", report)


@pytest.fixture
def display(monkeypatch):
    clock = Clock()
    monkeypatch.setattr(progress_module.time, "monotonic", clock)
    experiment = Experiment(designers=(PluginChoice("ga"),), envs=PluginChoice("simple"), budget=1000)
    spec = Plan.resolve(experiment).trials[0]
    shown = ProgressDisplay(experiment, console=Console(file=io.StringIO(), width=80))
    shown.trial_started(spec)
    return shown, spec, clock


def test_time_left_comes_from_the_trials_own_generations(display):
    """gda's generation 0 is drawn in no time and every later one trains a minute: the ETA once said
    seconds with 39 generations of a minute to go (it followed how fast the bar had moved lately)."""
    shown_display, spec, clock = display
    shown_display.generation(spec, generation(spec, 0, 25))  # at once
    clock.now += 60
    shown_display.generation(spec, generation(spec, 1, 50))  # a minute later
    lines = shown(shown_display)
    trial = next(line for line in lines if "gen 1" in line)
    assert "eta 0:38:00" in trial  # 38 more generations of a minute (950 evaluations at 2.4 s)
    assert "eta 0:38:00" in next(line for line in lines if "all trials" in line)
    clock.now += 30  # half a generation later, it counts down
    assert "eta 0:37:30" in next(line for line in shown(shown_display) if "gen 1" in line)


def test_at_80_columns_a_line_keeps_its_bar_counts_and_times_and_cuts_the_note(display):
    shown_display, spec, clock = display
    shown_display.generation(spec, generation(spec, 0, 25))
    clock.now += 60
    shown_display.generation(spec, generation(spec, 1, 50))
    note = "2,432/20,096 timesteps, 1,234 env steps/s: 10 bodies learning"
    shown_display.bodies(spec, BodiesDone(spec.index, 2, 3, 25, note))
    line = next(line for line in shown(shown_display, 80) if "gen 2" in line)
    assert "53/1000" in line and "eta 0:" in line and "2,432/20,096" in line, line


class Notes(RunListener):
    def __init__(self):
        self.notes = []

    def bodies(self, spec, progress):
        if progress.note:
            self.notes.append(progress.note)


def test_open_loop_physics_tells_its_speed(tmp_path):
    listener = Notes()
    gdabench.compare(designers="random", env="walker", controller="open-loop[trials=1]", budget=3, population=3,
                     out=tmp_path / "r", listener=listener)  # fmt: skip
    assert listener.notes and all(n.endswith(" env steps/s") for n in listener.notes), listener.notes


def test_gda_says_it_compiles_and_whether_for_the_first_time_here(tmp_path, monkeypatch):
    from gdabench.designers.gda.training import TrainerSpec, compiling_note, mark_compiled

    monkeypatch.setenv("TORCHINDUCTOR_CACHE_DIR", str(tmp_path))
    spec = TrainerSpec(("linear", 500, 1e-4, 0.02), (5, 5), 1e-3, True, 1)
    assert compiling_note(spec) == "compiling kernels (first run on this machine)"
    mark_compiled(spec)
    assert compiling_note(spec) == "compiling kernels"
