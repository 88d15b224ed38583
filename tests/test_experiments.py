"""Experiment files, suites, and event hooks for plugins."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from gdabench import hookimpl
from gdabench.cli import app
from gdabench.experiment.config import Experiment, PluginChoice
from gdabench.plugins import Registry
from gdabench.running.runner import compare

from support.processes import TIMING

runner = CliRunner()


def invoke(*args: str):
    return runner.invoke(app, list(args), env={"COLUMNS": "300"})


def rows(path) -> pd.DataFrame:
    from gdabench.results import RunDirectory

    return RunDirectory.open(path).load_evaluations().drop(columns=TIMING)


def test_a_toml_experiment_over_two_environments_runs_into_one_table(tmp_path):
    config = tmp_path / "exp.toml"
    config.write_text(
        'designers = ["ga", "random"]\nenvs = ["simple", "nk[k=4]"]\nbudget = 50\nseeds = "0..1"\n'
        "[execution]\njobs = 2\n"
    )
    result = invoke("compare", "--config", str(config), "--out", str(tmp_path / "run"), "-q", "--no-report")
    assert result.exit_code == 0, result.stderr
    table = rows(tmp_path / "run")
    assert set(table["env"]) == {"simple", "nk[k=4]"} and set(table["designer"]) == {"ga", "random"}
    assert table.groupby(["env", "designer", "seed"]).size().shape[0] == 8
    summary = pd.read_csv(tmp_path / "run" / "summary.csv")
    assert len(summary) == 4 and summary.set_index(["designer", "env"]).loc[("ga", "simple"), "threshold"] == 100
    # a run's run.json is an experiment file: the same rows again
    again = invoke(
        "compare", "--config", str(tmp_path / "run" / "run.json"), "--out", str(tmp_path / "again"), "-q", "--no-report"
    )
    assert again.exit_code == 0, again.stderr
    pd.testing.assert_frame_equal(rows(tmp_path / "again"), rows(tmp_path / "run"))


def test_the_command_line_overrides_the_file(tmp_path):
    config = tmp_path / "exp.toml"
    config.write_text('designers = ["ga", "random"]\nenv = "nk[k=4]"\nbudget = 500\nseeds = [0, 1, 2]\n')
    result = invoke(
        "compare",
        "--config",
        str(config),
        "-d",
        "random",
        "--budget",
        "30",
        "--out",
        str(tmp_path / "run"),
        "-q",
        "--no-report",
    )
    assert result.exit_code == 0, result.stderr
    table = rows(tmp_path / "run")
    assert set(table["designer"]) == {"random"} and set(table["seed"]) == {0, 1, 2} and set(table["env"]) == {"nk[k=4]"}
    assert table.groupby("seed")["n_evals"].max().eq(30).all()


def test_an_option_is_as_given_else_from_the_file_else_the_default(tmp_path):
    from gdabench.experiment.build import DEFAULTS, build_run

    config = tmp_path / "exp.toml"
    config.write_text('designers = ["ga"]\nbudget = 500\n[execution]\nworkers = 2\n')
    setup = build_run({"config": config, "budget": 30, "jobs": 3})
    assert (setup.experiment.budget, setup.experiment.population) == (30, DEFAULTS["population"])
    assert (setup.execution.jobs, setup.execution.workers) == (3, 2)
    assert build_run({"config": config}).experiment.budget == 500


def test_options_mean_the_same_as_text_and_as_python_values():
    from gdabench.experiment.build import build_run

    text = build_run({"designers": "ga,random", "env": "nk[k=4]", "seeds": "0..2", "shape": "4x6"}).experiment
    values = build_run({"designers": [PluginChoice("ga"), "random"], "env": PluginChoice.parse("nk[k=4]"),
                        "seeds": range(3), "shape": (4, 6)}).experiment  # fmt: skip
    assert text == values


@pytest.mark.parametrize(
    "content, fragment",
    [
        ('designers = ["ga"]\nfoo = 1\n', "exp.toml: unknown key 'foo'"),
        ('designers = ["ga"]\npopulation = "many"\n', "exp.toml: population: expected an integer, got 'many'"),
        ('designers = ["ga"]\n[execution]\nthreads = 2\n', "exp.toml: execution: unknown key 'threads'"),
        ('designers = ["ga"\n', "exp.toml: "),
        ('designers = [{ name = "ga", param = {} }]\n', "unknown key 'param'"),
    ],
)
def test_a_bad_experiment_file_is_one_line_naming_the_key_and_file(tmp_path, content, fragment):
    config = tmp_path / "exp.toml"
    config.write_text(content)
    result = invoke("compare", "--config", str(config), "--out", str(tmp_path / "run"), "-q")
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert result.exit_code == 2 and len(lines) == 1 and fragment in lines[0], result.stderr
    assert not (tmp_path / "run").exists()


def test_a_named_suite_runs_every_designer_on_every_environment(tmp_path):
    result = invoke(
        "compare",
        "-d",
        "random",
        "--suite",
        "landscapes",
        "--budget",
        "25",
        "--out",
        str(tmp_path / "run"),
        "-q",
        "--no-report",
    )
    assert result.exit_code == 0, result.stderr
    assert set(rows(tmp_path / "run")["env"]) == {"simple", "two-peaks", "target", "nk[k=0]", "nk[k=4]"}
    assert invoke("compare", "-d", "random", "--suite", "landscape", "-q").exit_code == 2  # with a did-you-mean


class Counting:
    def __init__(self):
        self.calls = []

    @hookimpl
    def gdabench_run_started(self, experiment, resumed):
        self.calls.append(("run", resumed))

    @hookimpl
    def gdabench_generation_finished(self, trial, generation, rows):
        assert (
            len(rows) and (rows["generation"] == generation).all() and (rows["designer"] == trial.designer.label).all()
        )
        self.calls.append(("generation", trial.title, generation))

    @hookimpl
    def gdabench_trial_finished(self, trial, error):
        self.calls.append(("trial", trial.title, error))

    @hookimpl
    def gdabench_run_finished(self, status, summary):
        self.calls.append(("end", status, len(summary)))


class Raising:
    @hookimpl
    def gdabench_generation_finished(self, trial):
        raise RuntimeError("tracker unreachable")


def test_hooks_are_called_once_per_generation_per_trial_and_a_raising_one_costs_nothing(tmp_path, capsys):
    counting = Counting()
    reg = Registry(entry_points=False, extra_plugins={"counting": counting, "raising": Raising()})
    exp = Experiment(
        designers=(PluginChoice("ga"), PluginChoice("random")),
        envs=PluginChoice("simple"),
        population=10,
        budget=30,
        seeds=(0, 1),
    )
    run = compare(exp, tmp_path / "run", reg=reg)
    generations = [c for c in counting.calls if c[0] == "generation"]
    written = run.load_evaluations()[["designer", "seed", "generation"]].drop_duplicates()
    assert sorted(generations) == sorted(
        ("generation", f"{d} seed {s}", g) for d, s, g in written.itertuples(index=False)
    )
    assert counting.calls[0] == ("run", False) and counting.calls[-1] == ("end", "complete", 2)
    assert sorted(c[1] for c in counting.calls if c[0] == "trial") == [
        "ga seed 0",
        "ga seed 1",
        "random seed 0",
        "random seed 1",
    ]
    warnings = [line for line in capsys.readouterr().err.splitlines() if "tracker unreachable" in line]
    assert warnings == [
        "warning: plugin 'raising': gdabench_generation_finished() raised RuntimeError: tracker unreachable; "
        "it is not called again in this run"
    ]
    assert (
        run.meta["status"] == "complete"
        and run.load_evaluations().groupby(["designer", "seed"])["n_evals"].max().eq(30).all()
    )


def test_log_tensorboard_writes_what_tensorboard_reads(tmp_path):
    event_accumulator = pytest.importorskip(
        "tensorboard.backend.event_processing.event_accumulator", reason="pip install -e '.[tensorboard]'"
    )
    result = invoke(
        "compare",
        "-d",
        "ga",
        "--population",
        "10",
        "--budget",
        "30",
        "--seeds",
        "0",
        "--log",
        "tensorboard",
        "--out",
        str(tmp_path / "run"),
        "-q",
        "--no-report",
    )
    assert result.exit_code == 0, result.stderr
    reader = event_accumulator.EventAccumulator(str(tmp_path / "run" / "tensorboard" / "ga-seed0"))
    reader.Reload()
    best = [(e.step, e.value) for e in reader.Scalars("best_so_far")]
    table = rows(tmp_path / "run").groupby("generation").agg(n=("n_evals", "max"), best=("best_so_far", "max"))
    assert [s for s, _ in best] == table["n"].tolist() and [v for _, v in best] == pytest.approx(table["best"].tolist())
    assert {"reward/max", "reward/mean", "reward/min", "evaluated"} <= set(reader.Tags()["scalars"])


def test_the_report_of_a_suite_has_a_page_per_environment_and_one_across_them(tmp_path):
    result = invoke(
        "compare",
        "-d",
        "ga,random",
        "--env",
        "simple,nk[k=4]",
        "--seeds",
        "0..2",
        "--budget",
        "50",
        "--out",
        str(tmp_path / "run"),
        "-q",
    )
    assert result.exit_code == 0, result.stderr
    report = tmp_path / "run" / "report"
    for name in (
        "best_so_far_simple.png",
        "best_so_far_nk_k=4.png",
        "rewards_per_generation_simple.png",
        "aggregate_iqm.csv",
        "ranks.csv",
    ):
        assert (report / name).exists(), name
    ranks = pd.read_csv(report / "ranks.csv").set_index("designer")
    summary = pd.read_csv(tmp_path / "run" / "summary.csv").set_index(["env", "designer"])["best_median"]
    for env in ("simple", "nk[k=4]"):
        better = "ga" if summary[(env, "ga")] > summary[(env, "random")] else "random"
        assert ranks.loc[better, env] == 1
    assert ranks["mean rank"].tolist() == pytest.approx(ranks[["simple", "nk[k=4]"]].mean(axis=1).tolist())
    html = (report / "report.html").read_text()
    assert "Performance on simple" in html and "Performance on nk[k=4]" in html and "Across environments" in html


@pytest.mark.parametrize(
    "path", sorted((Path(__file__).parent.parent / "experiments").glob("*.toml")), ids=lambda p: p.name
)
def test_every_committed_experiment_resolves_into_a_plan(path):
    from gdabench.experiment.build import build_run
    from gdabench.experiment.plan import Plan
    from gdabench.plugins import registry

    experiment = build_run({"config": path}).experiment
    plan = Plan.resolve(experiment, registry())
    assert len(plan.trials) == len(experiment.designers) * len(experiment.envs) * len(experiment.seeds) > 0


def test_the_walker_experiment_is_the_reference_co_design_and_its_budget_per_body_can_be_overridden():
    from gdabench.experiment.build import build_run

    path = Path(__file__).parent.parent / "experiments" / "walker.toml"
    faithful = build_run({"config": path}).experiment
    assert [d.name for d in faithful.designers] == ["ga", "cppn", "gda", "gda-fast", "random"]
    assert [e.name for e in faithful.envs] == ["walker"] and faithful.seeds == (0, 1, 2, 3, 4)
    assert faithful.controller.name == "ppo" and faithful.controller.params["timesteps"] == 50_000
    assert (faithful.population, faithful.budget) == (25, 150)  # 6 generations, as the reference run
    thesis = build_run({"config": path, "controller_param": ["timesteps=1000000"]}).experiment
    assert thesis.controller.params["timesteps"] == 1_000_000
