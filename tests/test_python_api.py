"""The Python API as the docs show it: docs/python.md's code blocks run here, in order."""

from __future__ import annotations

import re
from pathlib import Path

import pandas as pd

import gdabench
from gdabench.events import RunListener

PAGE = Path(__file__).resolve().parents[1] / "docs" / "python.md"


def test_the_python_page_runs_as_written(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    blocks = re.findall(r"```python\n(.*?)```", PAGE.read_text(), re.S)
    assert len(blocks) >= 4
    namespace: dict = {}
    for block in blocks:
        exec(compile(block, str(PAGE), "exec"), namespace)  # noqa: S102 - the page is ours
    assert (tmp_path / "results" / "notebook" / "report" / "report.html").exists()


def test_compare_returns_dataframes_and_takes_choices(tmp_path):
    run = gdabench.compare(designers=[gdabench.PluginChoice("random")], env="simple", seeds="0..1", budget=50, out=tmp_path / "r", progress=False)
    assert isinstance(run.evaluations(), pd.DataFrame) and isinstance(run.summary(), pd.DataFrame)
    assert len(run.evaluations()) == 100 and run.summary().loc[0, "seeds"] == 2
    assert gdabench.open_run(tmp_path / "r").path == run.path and "best_median" in run._repr_html_()


class Counter(RunListener):
    def __init__(self):
        self.events = []

    def run_started(self, run_dir, plan, resumed):
        self.events.append("run")

    def trial_finished(self, spec, error):
        self.events.append(spec.title)

    def run_finished(self, run_dir, status, summary):
        self.events.append(status)


def test_a_listener_hears_the_whole_run(tmp_path):
    counter = Counter()
    gdabench.compare(designers="random", env="simple", seeds=[0, 1], budget=25, out=tmp_path / "r", listener=counter)
    assert counter.events[0] == "run" and counter.events[-1] == "complete"
    assert sorted(counter.events[1:-1]) == ["random seed 0", "random seed 1"]
