"""Re-evaluated scores: each trial's final best bodies trained again under further seeds, and the trial
scored by the best of their means (the issue of a trial's best being the maximum of noisy numbers)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from gdabench import seeding
from gdabench.body import Body
from gdabench.cli import app
from gdabench.errors import ConfigError
from gdabench.experiment.build import build_run
from gdabench.experiment.config import Experiment, PluginChoice, Reevaluation
from gdabench.report.build import write_report
from gdabench.report.pairwise import pairwise
from gdabench.results import load_reevaluations as load
from gdabench.running.reevaluation import reevaluate_directory, top_bodies
from gdabench.running.runner import compare
from gdabench.stats.reevaluated import trial_scores


def _noisy(body: str, seed: int) -> float:
    """What the test plugin's ``noisy`` environment scores: the sum of the codes plus N(0, 1) from the seed."""
    return float(Body.from_text(body).voxels.astype(int).sum()) + float(np.random.default_rng(seed).normal())


@pytest.fixture
def noisy_run(tmp_path, reg):
    exp = Experiment((PluginChoice("ga"), PluginChoice("random")), PluginChoice("noisy"), population=5, budget=20,
                     seeds=(0, 1, 2), reevaluate=Reevaluation(top=2, seeds=3))  # fmt: skip
    return compare(exp, tmp_path / "run", reg=reg)


def test_the_trial_is_scored_by_its_best_bodys_mean_over_further_seeds(noisy_run):
    frame, again = noisy_run.load_evaluations(), load(noisy_run.path)
    scores = trial_scores(frame, again).set_index(["designer", "seed"])
    changed = 0
    for (designer, seed), trial in frame.groupby(["designer", "seed"]):
        ok = trial[trial["status"] == "ok"].sort_values("reward", ascending=False)
        top = list(dict.fromkeys(ok["body"]))[:2]  # the two best distinct bodies, by their reward in the trial
        means = {b: np.mean([_noisy(b, seeding.reevaluation_seed(seed, Body.from_text(b).hash, j)) for j in (1, 2, 3)])
                 for b in top}  # fmt: skip
        best = max(means, key=means.get)
        row = scores.loc[(designer, seed)]
        assert row["raw_best"] == ok["reward"].iloc[0]
        assert row["reevaluated_best"] == pytest.approx(means[best]) and row["reevaluated_body"] == best
        assert row["drop"] == pytest.approx(row["raw_best"] - means[best])
        changed += row["reevaluated_best"] != row["raw_best"]
    assert changed == len(scores)  # fresh seeds: no trial keeps its raw best
    assert set(again["replicate"]) == {1, 2, 3} and len(again) == len(scores) * 2 * 3
    # the seeds are the re-evaluation stream's, never the evaluation that selected the body
    first = {(r.seed, r.body_hash): seeding.evaluation_seed(r.seed, r.body_hash) for r in again.itertuples()}
    assert not any(r.eval_seed == first[(r.seed, r.body_hash)] for r in again.itertuples())
    assert noisy_run.meta["reevaluated"]["top"] == 2


def test_tests_and_summary_use_the_reevaluated_best(noisy_run):
    frame, again = noisy_run.load_evaluations(), load(noisy_run.path)
    scores = trial_scores(frame, again).set_index(["designer", "seed"])["reevaluated_best"]
    tests = pairwise(frame, "auto", reevaluations=again)
    row = tests.iloc[0]
    assert row["metric"] == "reevaluated_best"
    assert row["median_a"] == pytest.approx(scores.loc["ga"].median())
    summary = pd.read_csv(noisy_run.path / "summary.csv").set_index("designer")
    assert summary.loc["random", "reevaluated_median"] == pytest.approx(scores.loc["random"].median())
    report = write_report(noisy_run.path, animations=False)
    text = (report.out / "summary.md").read_text()
    assert "## Re-evaluated scores" in text and "re-evaluated best reward" in text
    per_body = pd.read_csv(report.out / "reevaluated_bodies.csv")
    assert per_body["replicates"].eq(3).all() and per_body["sd"].gt(0).all()  # the noise per body


def test_a_report_of_one_body_per_trial_says_so_and_shows_no_change_of_body(tmp_path, reg):
    """With one body re-evaluated per trial (the committed walker run's 1x3), the report does not speak of "1 best
    bodies" and does not count trials whose best body changed: it cannot change."""
    exp = Experiment((PluginChoice("ga"),), PluginChoice("noisy"), population=5, budget=10, seeds=(0, 1),
                     reevaluate=Reevaluation(top=1, seeds=2))  # fmt: skip
    run = compare(exp, tmp_path / "run", reg=reg)
    text = (write_report(run.path, animations=False).out / "summary.md").read_text()
    assert "each trial's best body was trained again under 2 further seeds (" in text
    assert "1 best bodies" not in text
    section = text[text.index("Raw and re-evaluated best per designer") :]
    row = next(line for line in section.splitlines() if line.startswith("| ga |"))
    assert row.rstrip(" |").endswith("| -"), row


def test_top_bodies_are_distinct_and_best_first():
    trial = pd.DataFrame({"body": ["a", "b", "a", "c", "d"], "body_hash": ["a", "b", "a", "c", "d"],
                          "reward": [5.0, 7.0, 5.0, 7.0, np.nan], "status": ["ok", "ok", "duplicate", "ok", "error"],
                          "n_evals": [1, 2, 2, 3, 4], "index": [0, 1, 2, 0, 1]})  # fmt: skip
    assert list(top_bodies(trial, 3)["body"]) == ["b", "c", "a"]  # ties: the one evaluated first


def test_on_by_default_with_a_controller_and_off_without(tmp_path):
    assert (
        build_run({"designers": "ga,gda", "env": "walker", "controller": "ppo"}).experiment.reevaluate == Reevaluation()
    )
    assert build_run({"designers": "ga,gda", "env": "simple"}).experiment.reevaluate is None
    off = build_run({"designers": "ga", "env": "walker", "controller": "ppo", "reevaluate": "off"}).experiment
    assert off.reevaluate is None
    path = tmp_path / "e.toml"
    path.write_text('designers = ["ga"]\nenv = "walker"\ncontroller = "ppo"\nreevaluate = "2x4"\n')
    assert build_run({"config": path}).experiment.reevaluate == Reevaluation(2, 4)
    path.write_text('designers = ["ga"]\nenv = "walker"\ncontroller = "ppo"\nreevaluate = false\n')
    assert build_run({"config": path}).experiment.reevaluate is None
    for bad in ("3", "0x5", "3x", "threexfive"):
        with pytest.raises(ConfigError, match="reevaluate"):
            build_run({"designers": "ga", "env": "simple", "reevaluate": bad})


def test_a_run_made_without_it_is_reevaluated_later_and_resumes(tmp_path, reg):
    exp = Experiment((PluginChoice("ga"),), PluginChoice("noisy"), population=5, budget=15, seeds=(0, 1))
    run = compare(exp, tmp_path / "run", reg=reg)
    assert load(run.path).empty
    full = reevaluate_directory(run.path, Reevaluation(2, 2), reg=reg)
    assert len(full) == 2 * 2 * 2
    # a kill after the first trial: the second trial's rows are missing, and only they are made again
    (run.path / "reevaluations.parquet").write_bytes(b"")
    full[full["seed"] == 0].to_parquet(run.path / "reevaluations.parquet", index=False)
    told = []
    again = reevaluate_directory(run.path, None, on_trial=lambda t, d, n: told.append(t), reg=reg)
    key = ["seed", "body_hash", "replicate"]
    pd.testing.assert_frame_equal(again.sort_values(key).reset_index(drop=True)[key + ["reward"]],
                                  full.sort_values(key).reset_index(drop=True)[key + ["reward"]])  # fmt: skip
    assert told == ["ga seed 0", "ga seed 1"]
    with pytest.raises(ConfigError, match="would mix"):
        reevaluate_directory(run.path, Reevaluation(3, 2), reg=reg)


def test_the_command_reevaluates_a_run(tmp_path):
    out = tmp_path / "run"
    made = CliRunner().invoke(app, ["compare", "-d", "ga,random", "--env", "simple", "--budget", "30", "--seeds", "0,1",
                                    "--out", str(out), "-q", "--no-report"])  # fmt: skip
    assert made.exit_code == 0, made.output
    done = CliRunner().invoke(app, ["reevaluate", str(out), "--reevaluate", "2x2"])
    assert done.exit_code == 0, done.output
    table = load(out)
    assert len(table) == 2 * 2 * 2 * 2 and (table["reward"] == table["first_reward"]).all()  # simple: no noise
    bad = CliRunner().invoke(app, ["reevaluate", str(out), "--reevaluate", "off"])
    assert bad.exit_code == 2 and "nothing to do" in bad.output


def test_trial_score_by_hand_the_best_mean_not_the_raw_best():
    """Body b won the trial by luck (9.0 once); over three further seeds a averages 6 and b 5: the trial scores 6."""
    frame = pd.DataFrame({"env": "e", "designer": "d", "run_id": "r", "seed": 0, "body": ["a", "b", "c"],
                          "body_hash": ["a", "b", "c"], "reward": [7.0, 9.0, 1.0], "status": "ok", "n_evals": [1, 2, 3],
                          "index": [0, 1, 2]})  # fmt: skip
    again = pd.DataFrame({"env": "e", "designer": "d", "run_id": "r", "seed": 0, "rank": [1, 1, 1, 2, 2, 2],
                          "body": ["b"] * 3 + ["a"] * 3, "body_hash": ["b"] * 3 + ["a"] * 3,
                          "first_reward": [9.0] * 3 + [7.0] * 3, "replicate": [1, 2, 3] * 2,
                          "reward": [4.0, 5.0, 6.0, 5.0, 6.0, 7.0], "status": "ok"})  # fmt: skip
    row = trial_scores(frame, again).iloc[0]
    assert (row["raw_best"], row["raw_body"]) == (9.0, "b")
    assert (row["reevaluated_best"], row["reevaluated_body"], row["reevaluated_sd"]) == (6.0, "a", 1.0)
    assert row["drop"] == 3.0 and row["bodies"] == 2 and row["replicates"] == 3


def test_a_run_scored_by_other_dynamics_is_not_reevaluated(tmp_path):
    out = tmp_path / "run"
    made = CliRunner().invoke(app, ["compare", "-d", "random", "--env", "simple", "--budget", "25", "--out", str(out),
                                    "-q", "--no-report"])  # fmt: skip
    assert made.exit_code == 0, made.output
    from gdabench.results import RunDirectory

    run = RunDirectory.open(out)
    run.update_meta(envs={"simple": {"optimum": 100.0, "version": "gdabench/simple-v0"}})
    with pytest.raises(ConfigError, match="re-evaluating it would mix"):
        reevaluate_directory(out, Reevaluation(1, 1))
    assert load(out).empty
