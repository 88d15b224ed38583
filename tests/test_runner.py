"""The harness loop: budget, validity, de-duplication, failures, determinism, resume, schema."""

from __future__ import annotations

import json
import math
import signal
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from gdabench import (
    Controller,
    ControllerSpec,
    Designer,
    DesignerSpec,
    Environment,
    EnvironmentSpec,
    Evaluation,
    Experiment,
    PluginChoice,
    hookimpl,
)
from gdabench.body import Body
from gdabench.errors import ConfigError, TrialError
from gdabench.plugins import Registry
from gdabench.results import COLUMNS, RunDirectory
from gdabench.running.runner import compare
from gdabench.specs import Factory
from gdabench.strategy import EvaluationStrategy

from support.listeners import KillAt, Killed

A, B, C, D = "33/00", "44/00", "34/30", "43/03"
INVALID = "11/11"


class Scripted(Designer):
    """Proposes fixed generations of body texts and records what it is told."""

    told: list = []
    fail_at: dict = {}

    def __init__(self, *, script=(), fail_ask_at=-1, **kw):
        super().__init__(**kw)
        self.script, self.fail_ask_at, self.generation = [list(g) for g in script], fail_ask_at, 0

    def ask(self):
        if self.generation == self.fail_ask_at and not Scripted.fail_at.get("done"):
            Scripted.fail_at["done"] = True
            raise RuntimeError("boom in ask")
        gen = self.script[min(self.generation, len(self.script) - 1)]
        return [Body.from_text(t) for t in gen]

    def tell(self, bodies, rewards):
        Scripted.told.append(([b.text for b in bodies], list(rewards)))
        self.generation += 1


class Flaky(Environment):
    """Sum of codes, except chosen bodies raise or return NaN."""

    def __init__(self, *, raise_on=(), nan_on=(), **kw):
        super().__init__(**kw)
        self.raise_on, self.nan_on = set(raise_on), set(nan_on)

    def evaluate(self, body, *, seed, controller=None, workdir=None):
        if body.text in self.raise_on:
            raise ValueError("simulated failure\nsecond line")
        if body.text in self.nan_on:
            return math.nan
        return float(body.voxels.sum())


class Versioned(Flaky):
    version = "flaky-v3"


class FakePlugin:
    @hookimpl
    def gdabench_designers(self):
        return [
            DesignerSpec("scripted", Scripted, "test designer"),
            DesignerSpec(
                "scripted-ab", Scripted, "a variant: defaults fill in parameters", defaults={"script": [[A, B]]}
            ),
        ]

    @hookimpl
    def gdabench_environments(self):
        return [
            EnvironmentSpec("flaky", Flaky, "test env"),
            EnvironmentSpec("versioned", Versioned, "test env with a version"),
        ]


@pytest.fixture
def reg():
    Scripted.told.clear()
    Scripted.fail_at.clear()
    return Registry(entry_points=False, extra_plugins={"fake": FakePlugin()})


def scripted(script, env="flaky", budget=4, population=4, seeds=(0,), **env_params):
    params = {"script": script}
    return Experiment(
        designers=(PluginChoice("scripted", params, "scripted"),),
        envs=PluginChoice(env, env_params, env),
        shape=(2, 2),
        population=population,
        budget=budget,
        seeds=seeds,
    )


def test_invalid_and_duplicates_are_recorded_not_evaluated(tmp_path, reg):
    exp = scripted([[A, INVALID, A, B], [A, C], [D]], budget=4)
    run = compare(exp, tmp_path / "run", reg=reg)
    df = run.load_evaluations()
    assert list(df["status"]) == ["ok", "invalid", "duplicate", "ok", "duplicate", "ok", "ok"]
    assert list(df["n_evals"]) == [1, 1, 1, 2, 2, 3, 4]
    assert df.loc[1, "message"] == "no actuator" and math.isnan(df.loc[1, "reward"])
    assert df.loc[2, "reward"] == df.loc[0, "reward"] == df.loc[4, "reward"] == 6.0
    assert list(df["best_so_far"]) == [6, 6, 6, 8, 8, 10, 10]
    # the designer is told every body it proposed, in order; nan for the invalid one
    bodies, rewards = Scripted.told[0]
    assert bodies == [A, INVALID, A, B]
    assert rewards[0] == 6 and math.isnan(rewards[1]) and rewards[2:] == [6, 8]
    assert len(Scripted.told) == 2  # the last generation exhausts the budget and is not told
    assert run.meta["status"] == "complete"


def test_spec_defaults_define_variants_and_are_recorded(tmp_path, reg):
    exp = Experiment(
        designers=(PluginChoice("scripted-ab"),), envs=PluginChoice("flaky"), shape=(2, 2), population=2, budget=2
    )
    df = compare(exp, tmp_path / "run", reg=reg).load_evaluations()
    assert list(df["body"]) == [A, B]
    assert json.loads(df["designer_params"].iloc[0]) == {"script": [[A, B]]}
    bad = Experiment(
        designers=(PluginChoice("scripted-ab", {"nope": 1}),),
        envs=PluginChoice("flaky"),
        shape=(2, 2),
        population=2,
        budget=2,
    )
    with pytest.raises(ConfigError, match="has no parameter 'nope'"):
        compare(bad, tmp_path / "bad", reg=reg)


def test_budget_truncates_last_generation(tmp_path, reg):
    exp = Experiment(designers=(PluginChoice("random"),), envs=PluginChoice("simple"), population=25, budget=30)
    df = compare(exp, tmp_path / "run").load_evaluations()
    assert len(df) == 30 and df["n_evals"].max() == 30 and list(df.groupby("generation").size()) == [25, 5]


def test_failed_evaluations_are_rows_and_use_budget(tmp_path, reg):
    exp = scripted([[A, B], [C, D]], budget=4, raise_on=[B], nan_on=[C])
    df = compare(exp, tmp_path / "run", reg=reg).load_evaluations()
    assert list(df["status"]) == ["ok", "error", "error", "ok"]
    assert df.loc[1, "message"] == "ValueError: simulated failure"
    assert "non-finite" in df.loc[2, "message"]
    assert list(df["n_evals"]) == [1, 2, 3, 4]


def test_designer_failure_leaves_resumable_run(tmp_path, reg):
    script = [[A, B], [C], [D], ["34/00"], ["43/00"]]
    exp = Experiment(
        designers=(PluginChoice("scripted", {"script": script, "fail_ask_at": 2}, "scripted"),),
        envs=PluginChoice("flaky"),
        shape=(2, 2),
        population=2,
        budget=6,
    )
    with pytest.raises(TrialError, match="raised in ask\\(\\): RuntimeError: boom in ask"):
        compare(exp, tmp_path / "run", reg=reg)
    run = RunDirectory.open(tmp_path / "run")
    assert run.meta["status"] == "failed" and "boom" in run.meta["error"]
    partial = run.load_evaluations()
    assert sorted(partial["generation"].unique()) == [0, 1]
    resumed = compare(None, tmp_path / "run", resume=True, reg=reg).load_evaluations()
    Scripted.fail_at["done"] = True  # the reference run does not fail
    reference = compare(exp, tmp_path / "ref", reg=reg).load_evaluations()
    cols = ["generation", "index", "body", "reward", "status", "n_evals", "best_so_far"]
    pd.testing.assert_frame_equal(resumed[cols], reference[cols])
    assert RunDirectory.open(tmp_path / "run").meta["status"] == "complete"


def test_resume_after_a_crash_mid_trial_gives_the_full_table(tmp_path):
    """A crash after a generation was written: resume continues from there, nothing redone or doubled."""
    exp = Experiment(
        designers=(PluginChoice("ga"), PluginChoice("random")), envs=PluginChoice("simple"), budget=150, seeds=(0, 1)
    )
    full = compare(exp, tmp_path / "full").load_evaluations()

    with pytest.raises(Killed):
        compare(exp, tmp_path / "crash", listener=KillAt("ga", 1, 3))
    partial = RunDirectory.open(tmp_path / "crash").load_evaluations()
    assert partial[(partial.designer == "ga") & (partial.seed == 1)]["generation"].max() == 3
    # the checkpoint after generation 3 is on disk too: a kill between the two is the reliability suite's
    resumed = compare(None, tmp_path / "crash", resume=True).load_evaluations()
    cols = ["designer", "seed", "generation", "index", "body", "reward", "n_evals", "best_so_far"]
    key = ["seed", "designer", "generation", "index"]
    a = resumed[cols].sort_values(key).reset_index(drop=True)
    b = full[cols].sort_values(key).reset_index(drop=True)
    pd.testing.assert_frame_equal(a, b)


def test_an_interrupted_compare_gives_the_caller_its_signal_handlers_back(tmp_path):
    """A notebook that interrupts one compare keeps its Ctrl-C; a subprocess it starts later inherits it too."""
    exp = Experiment(designers=(PluginChoice("random"),), envs=PluginChoice("simple"), budget=100, seeds=(0,))
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    with pytest.raises(KeyboardInterrupt):
        compare(exp, tmp_path / "run", listener=KillAt("random", 0, 1, error=KeyboardInterrupt()))
    assert {s: signal.getsignal(s) for s in before} == before
    assert RunDirectory.open(tmp_path / "run").meta["status"] == "interrupted"


def test_same_command_same_table(tmp_path):
    exp = Experiment(
        designers=(PluginChoice("ga"), PluginChoice("random")), envs=PluginChoice("simple"), budget=200, seeds=(0, 1, 2)
    )
    a = compare(exp, tmp_path / "a").load_evaluations()
    b = compare(exp, tmp_path / "b").load_evaluations()
    timing = ["run_id", "eval_seconds", "design_seconds", "elapsed_seconds", "timestamp"]
    pd.testing.assert_frame_equal(a.drop(columns=timing), b.drop(columns=timing))
    # every evaluated body is valid and unique within its (designer, seed) run
    ok = a[a["status"] == "ok"]
    assert ok.groupby(["designer", "seed"])["body_hash"].apply(lambda s: s.is_unique).all()
    assert all(Body.from_text(t).is_valid() for t in ok["body"])
    # common random numbers: ga and random share generation 0 under the same seed
    g0 = a[a["generation"] == 0]
    assert list(g0[(g0.designer == "ga") & (g0.seed == 1)]["body"]) == list(
        g0[(g0.designer == "random") & (g0.seed == 1)]["body"]
    )


def test_results_schema_and_run_json(tmp_path):
    exp = Experiment(
        designers=(PluginChoice("ga", {"survivors": 5}, "ga[survivors=5]"),), envs=PluginChoice("simple"), budget=60
    )
    run = compare(exp, tmp_path / "run", command=["gdabench", "compare"])
    df = run.load_evaluations()
    assert list(df.columns[: len(COLUMNS)]) == [c for c in COLUMNS if c in df.columns[: len(COLUMNS)]]
    assert set(COLUMNS) <= set(df.columns)
    assert (df["designer"] == "ga[survivors=5]").all() and (df["designer_name"] == "ga").all()
    assert json.loads(df["designer_params"].iloc[0]) == {"survivors": 5}
    assert all(Body.from_text(t).hash == h for t, h in zip(df["body"], df["body_hash"]))
    assert df["n_evals"].is_monotonic_increasing and df["best_so_far"].is_monotonic_increasing
    assert np.array_equal(df["best_so_far"], df["reward"].cummax())
    meta = run.meta
    assert meta["status"] == "complete" and meta["command"] == ["gdabench", "compare"]
    assert meta["env_optimum"] == 100.0
    assert meta["versions"]["gdabench"] and meta["versions"]["numpy"] and "gdabench" in meta["versions"]["plugins"]
    assert Experiment.from_json(meta["config"]) == exp
    summary = pd.read_csv(run.path / "summary.csv")
    assert summary.loc[0, "best_median"] == df["reward"].max()


def test_the_environment_version_is_recorded_in_rows_and_run_json(tmp_path, reg):
    run = compare(scripted([[A, B]], env="versioned", budget=2, population=2), tmp_path / "v", reg=reg)
    assert (run.load_evaluations()["env_version"] == "flaky-v3").all() and run.meta["env_version"] == "flaky-v3"
    plain = compare(scripted([[A, B]], budget=2, population=2), tmp_path / "plain", reg=reg)
    assert (plain.load_evaluations()["env_version"] == "").all() and plain.meta["env_version"] is None


def test_stuck_designer_is_stopped(tmp_path, reg):
    exp = scripted([[A], [A]], budget=10, population=1)
    with pytest.raises(TrialError, match="proposed no new valid body in 20 generations"):
        compare(exp, tmp_path / "run", reg=reg)


@pytest.mark.parametrize(
    "exp, fragment",
    [
        (
            Experiment(designers=(PluginChoice("nope"),), envs=PluginChoice("simple")),
            "unknown designer 'nope'; known designers: ",
        ),
        (Experiment(designers=(PluginChoice("ga"),), envs=PluginChoice("simpel")), "Did you mean 'simple'"),
        (
            Experiment(designers=(PluginChoice("ga"),), envs=PluginChoice("simple"), population=0),
            "population must be an integer from 1 to 10,000, got 0",
        ),
        (
            Experiment(designers=(PluginChoice("ga"),), envs=PluginChoice("simple"), budget=10),
            "budget (10) must be at least the population (25)",
        ),
        (
            Experiment(designers=(PluginChoice("ga", {"survivors": 30}),), envs=PluginChoice("simple")),
            "survivors must be between",
        ),
        (
            Experiment(designers=(PluginChoice("ga", {"nope": 1}),), envs=PluginChoice("simple")),
            "has no parameter 'nope'",
        ),
        (Experiment(designers=(PluginChoice("ga", {"budget": 1}),), envs=PluginChoice("simple")), "set by the harness"),
    ],
)
def test_bad_configuration_creates_no_run_directory(tmp_path, exp, fragment):
    with pytest.raises(ConfigError) as info:
        compare(exp, tmp_path / "run")
    assert fragment in str(info.value)
    assert not (tmp_path / "run").exists()


def test_existing_directory_is_not_overwritten(tmp_path):
    exp = Experiment(designers=(PluginChoice("random"),), envs=PluginChoice("simple"), budget=25)
    compare(exp, tmp_path / "run")
    with pytest.raises(ConfigError, match="already exists"):
        compare(exp, tmp_path / "run")


def test_stop_at_optimum_ends_a_run_after_the_generation_that_reaches_it(tmp_path, reg):
    script = [[A], ["44/44", C], [D], [B]]  # simple on 2x2: the optimum is 16 ("44/44")
    full = compare(
        scripted(script, env="simple", budget=5, population=2), tmp_path / "full", reg=reg
    ).load_evaluations()
    exp = Experiment(**{**scripted(script, env="simple", budget=5, population=2).__dict__, "stop_at_optimum": True})
    run = compare(exp, tmp_path / "stopped", reg=reg)
    stopped = run.load_evaluations()
    assert list(full["body"]) == [A, "44/44", C, D, B]
    assert list(stopped["body"]) == [A, "44/44", C]  # the rest of the budget is not spent
    assert stopped["best_so_far"].iloc[-1] == 16.0 and run.meta["status"] == "complete"
    assert Experiment.from_json(run.meta["config"]).stop_at_optimum is True


# -- the evaluation-strategy extension point ---------------------------------------------------
class Budgeted(Controller):
    """Reward = sum of codes, scaled by how much of a 100-step budget it may spend."""

    def __init__(self, *, steps: int = 100, halving: bool = False):
        self.steps, self.halving = steps, halving

    def evaluate(self, make_env, *, seed, workdir=None):
        raise AssertionError("the test environment calls score() directly")

    def score(self, body):
        return Evaluation(float(body.voxels.sum()) * min(1.0, self.steps / 100), {"steps": self.steps})

    def evaluation_strategy(self):
        return Halving() if self.halving else None


class Halving(EvaluationStrategy):
    """Every body on a quarter of the budget, then the better half on all of it."""

    def evaluate(self, tasks, evaluate):
        short = [
            replace(t, controller=Factory.of(t.controller.factory, {**dict(t.controller.params), "steps": 25}))
            for t in tasks
        ]
        first = evaluate(short)
        keep = sorted(range(len(tasks)), key=lambda i: -first[i].reward)[: len(tasks) // 2]
        outcomes = [replace(o, info={**o.info, "stopped_early": 1}) for o in first]
        for i, outcome in zip(keep, evaluate([tasks[i] for i in keep])):
            outcomes[i] = replace(outcome, info={**outcome.info, "stopped_early": 0})
        return outcomes


class Trained(Environment):
    requires_controller = True

    def evaluate(self, body, *, seed, controller=None, workdir=None):
        return controller.score(body)


class StrategyPlugin:
    @hookimpl
    def gdabench_environments(self):
        return [EnvironmentSpec("trained", Trained, "test env scored by a controller", requires_controller=True)]

    @hookimpl
    def gdabench_controllers(self):
        return [ControllerSpec("budgeted", Budgeted, "test controller with a step budget")]


def test_a_controller_can_hand_each_generation_to_an_evaluation_strategy(tmp_path):
    reg = Registry(entry_points=False, extra_plugins={"strategy": StrategyPlugin()})
    exp = Experiment(
        designers=(PluginChoice("random"),),
        envs=PluginChoice("trained"),
        controller=PluginChoice("budgeted", {"halving": True}),
        population=8,
        budget=16,
    )
    rows = compare(exp, tmp_path / "run", reg=reg).load_evaluations()
    for _, generation in rows.groupby("generation"):
        full = generation["body"].map(lambda t: float(Body.from_text(t).voxels.sum()))
        finished = generation["stopped_early"] == 0
        assert finished.sum() == 4 and (generation.loc[finished, "reward"] == full[finished]).all()
        assert (generation.loc[~finished, "reward"] == full[~finished] / 4).all()  # partial rewards, marked
        assert (generation.loc[finished, "steps"] == 100).all() and (generation.loc[~finished, "steps"] == 25).all()
    plain = Experiment(**{**exp.__dict__, "controller": PluginChoice("budgeted")})
    untouched = compare(plain, tmp_path / "plain", reg=reg).load_evaluations()
    assert "stopped_early" not in untouched and (untouched["steps"] == 100).all()
