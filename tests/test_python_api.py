"""The Python API as the docs show it: docs/python.md's code blocks run here, in order."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

import gdabench
from gdabench.errors import ConfigError, TrialError
from gdabench.execution import Execution
from gdabench.running.events import RunListener

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "python.md"


def test_compare_returns_dataframes_and_takes_choices(tmp_path):
    run = gdabench.compare(
        designers=[gdabench.PluginChoice("random")],
        env="simple",
        seeds="0..1",
        budget=50,
        out=tmp_path / "r",
        progress=False,
    )
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


def run_script(code: str, cwd: Path, stdin: bool = False) -> subprocess.CompletedProcess:
    """``python script.py`` (or ``python - < script.py``) in ``cwd``, as a user runs a pasted example."""
    script = cwd / "script.py"
    script.write_text(code)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    if stdin:
        return subprocess.run(
            [sys.executable, "-"], input=code, capture_output=True, text=True, cwd=cwd, env=env, timeout=600
        )
    return subprocess.run([sys.executable, str(script)], capture_output=True, text=True, cwd=cwd, env=env, timeout=600)


def test_the_python_page_runs_as_a_plain_script(tmp_path):
    blocks = re.findall(r"```python\n(.*?)```", PAGE.read_text(), re.S)
    result = run_script("".join(blocks), tmp_path)
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "results" / "notebook" / "report" / "report.html").exists()


UNGUARDED = """
import gdabench
from gdabench.execution import Execution

run = gdabench.compare(designers="ga,random", env="simple", seeds="0..1", budget=50, out="results/run", progress=False,
                       execution=Execution(jobs=2, workers=2))
print(run.status, len(run.evaluations()))
"""


def test_a_script_without_a_main_guard_runs_its_workers_once(tmp_path):
    """Trial and evaluation workers are spawned; they must not run the script (and so the run) again."""
    for stdin in (False, True):
        folder = tmp_path / ("stdin" if stdin else "file")
        folder.mkdir()
        result = run_script(UNGUARDED, folder, stdin=stdin)
        assert result.returncode == 0 and result.stdout.split() == ["complete", "200"], result.stderr


def test_a_run_that_failed_before_writing_anything_can_be_run_again(tmp_path, reg):
    flag = tmp_path / "fail"
    flag.touch()
    common = {"env": "simple", "budget": 50, "out": tmp_path / "run", "progress": False, "reg": reg}
    with pytest.raises(TrialError, match="designer model diverged"):
        gdabench.compare(designers=f"fragile[fail_at=0,flag={flag}]", **common)
    assert gdabench.open_run(tmp_path / "run").status == "failed"
    flag.unlink()
    run = gdabench.compare(designers=f"fragile[fail_at=0,flag={flag}]", **common)
    assert run.status == "complete" and len(run.evaluations()) == 50
    with pytest.raises(ConfigError, match="already exists and is not empty"):  # a run with rows is never started over
        gdabench.compare(designers=f"fragile[fail_at=0,flag={flag}]", **common)


GUARDED_PLUGIN = """
import gdabench
from gdabench import DesignerSpec, hookimpl
from gdabench.designers.random_search import RandomSearch
from gdabench.execution import Execution
from gdabench.plugins import Registry


class Mine(RandomSearch):
    '''Defined in the script: workers must import the script to unpickle it.'''


class Plugin:
    @hookimpl
    def gdabench_designers(self):
        return [DesignerSpec("mine", Mine, "a designer of this script")]


if __name__ == "__main__":
    reg = Registry(extra_plugins={"mine": Plugin()})
    run = gdabench.compare(designers="mine,random", env="simple", seeds="0..1", budget=50, out="results/run",
                           progress=False, execution=Execution(jobs=2), reg=reg)
    print(run.status, len(run.evaluations()))
"""


def test_a_designer_defined_in_a_guarded_script_still_reaches_the_workers(tmp_path):
    result = run_script(GUARDED_PLUGIN, tmp_path)
    assert result.returncode == 0 and result.stdout.split() == ["complete", "200"], result.stderr


class Bodies(RunListener):
    """Every in-generation progress report, and each generation's new evaluations, by trial."""

    def __init__(self):
        self.reports, self.new = {}, {}

    def bodies(self, spec, progress):
        self.reports.setdefault((spec.title, progress.generation), []).append((progress.done, progress.total))

    def generation(self, spec, result):
        self.new[(spec.title, result.generation)] = result.report.new_evals


@pytest.mark.parametrize("jobs", [1, 2])
def test_progress_is_told_body_by_body_while_a_generation_runs(tmp_path, jobs):
    listener = Bodies()
    gdabench.compare(
        designers="ga,random",
        env="simple",
        seeds=[0],
        budget=50,
        population=10,
        out=tmp_path / "r",
        listener=listener,
        execution=Execution(jobs=jobs),
    )
    assert set(listener.reports) == set(listener.new)
    for key, reports in listener.reports.items():
        total, replayed = listener.new[key], reports[0][0]  # bodies another trial of the run had scored come at once
        assert reports == [(done, total) for done in range(replayed, total + 1)], key  # then one by one
    if jobs == 1:  # one after the other: random replays ga's generation 0, which it shares
        assert listener.reports[("random seed 0", 0)] == [(10, 10)]


class Notes(RunListener):
    def __init__(self):
        self.notes = []

    def bodies(self, spec, progress):
        if progress.note:
            self.notes.append((progress.done, progress.total, progress.note))


@pytest.mark.parametrize("jobs", [1, 2])
def test_a_generation_learning_in_lockstep_tells_its_timesteps_and_speed(tmp_path, jobs):
    listener = Notes()
    gdabench.compare(
        designers="random",
        env="walker",
        controller="ppo[timesteps=512]",
        seeds=[0, 1][:jobs],
        budget=3,
        population=3,
        out=tmp_path / "r",
        listener=listener,
        execution=Execution(jobs=jobs),
        reevaluate="off",
    )
    # the batch's last rollout is always told (others every 2 s at most), while the generation's 3 bodies run
    # figures first, so that a narrow terminal cuts the words rather than them
    finals = [n for n in listener.notes if n[2].startswith("512/512 timesteps, ")]
    assert len(finals) == jobs and all(n[:2] == (0, 3) for n in finals)
    assert finals[0][2].endswith(" env steps/s: 3 bodies learning")
