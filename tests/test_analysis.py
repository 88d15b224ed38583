"""Statistics of the report (runtimes, pairwise tests, power, aggregates): hand-computed cases,
scipy and rliable reference values, censoring, several environments, and the report's pages."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.stats import mannwhitneyu, norm, trim_mean, wilcoxon

from gdabench.errors import ConfigError
from gdabench.report import aggregate as agg
from gdabench.report.build import write_report
from gdabench.report.pairwise import a12, holm, magnitude, pairwise
from gdabench.report.runtimes import (
    default_targets,
    expected_runtime,
    expected_runtime_ci,
    fixed_budget,
    fixed_target,
    run_scores,
    run_traces,
    runtime_ecdf,
)
from gdabench.results import RunDirectory
from gdabench.stats.power import critical_value, minimum_seeds, noether, power, seeds_needed

from support.stat_tables import small_run, table


# -- runtimes --------------------------------------------------------------------------------------
def test_trace_runtime_and_budget_values_by_hand():
    (t,) = run_traces(table({("e", "a", 0): [1.0, 3.0, 2.0, 5.0]}))
    assert list(t.curve) == [1, 3, 3, 5]
    assert t.runtime(3) == 2 and t.runtime(4) == 4 and t.runtime(1) == 1
    assert math.isnan(t.runtime(6))  # censored: never reached
    assert t.at(3) == 3 and math.isnan(t.at(10))
    assert t.at(10, optimum=5.0) == 5.0  # stopped at the optimum: it stands


def test_failed_evaluations_count_but_never_lower_the_best():
    (t,) = run_traces(table({("e", "a", 0): [float("nan"), 2.0, float("nan"), 1.0]}))
    assert t.evaluations == 4
    assert math.isnan(t.curve[0]) and list(t.curve[1:]) == [2, 2, 2]
    assert t.runtime(2) == 2


def test_ert_is_cocos_definition_by_hand():
    # two runs reach the target after 10 and 30 evaluations, one misses it in 100: (10 + 30 + 100) / 2
    assert expected_runtime([10, 30, np.nan], [50, 80, 100]) == 70
    assert expected_runtime([np.nan, np.nan], [100, 100]) == math.inf
    assert expected_runtime([4, 4], [9, 9]) == 4


def test_fixed_target_table_by_hand_with_censored_runs():
    rewards = {
        ("e", "a", 0): [1, 5, 5, 5, 5, 5],  # reaches 5 at 2
        ("e", "a", 1): [1, 1, 1, 1, 5, 5],  # at 5
        ("e", "a", 2): [1, 1, 1, 1, 1, 1],  # never: contributes its 6 evaluations
        ("e", "b", 0): [1, 1, 1, 1, 1, 1],
        ("e", "b", 1): [1, 1, 1, 1, 1, 1],
        ("e", "b", 2): [1, 1, 1, 1, 1, 1],
    }
    ft = fixed_target(table({k: list(map(float, v)) for k, v in rewards.items()}), [5.0])
    a = ft[ft["designer"] == "a"].iloc[0]
    assert (a["runs"], a["successes"]) == (3, 2)
    assert a["success_rate"] == pytest.approx(2 / 3)
    assert a["ert"] == pytest.approx((2 + 5 + 6) / 2)
    assert a["median_runtime"] == 5
    assert a["ert_ci_low"] <= a["ert"] <= a["ert_ci_high"]
    b = ft[ft["designer"] == "b"].iloc[0]
    assert b["successes"] == 0 and b["ert"] == math.inf and b["median_runtime"] == math.inf
    assert b["ert_ci_low"] == b["ert_ci_high"] == math.inf


def test_ert_interval_is_a_bootstrap_over_runs():
    rt, used = np.array([10.0, np.nan, np.nan, 20.0]), np.array([100.0, 100.0, 100.0, 100.0])
    low, high = expected_runtime_ci(rt, used, resamples=4000, seed=3)
    # the same resampling done by hand, one resample at a time
    idx = np.random.default_rng(3).integers(0, 4, size=(4000, 4))
    erts = [expected_runtime(rt[i], used[i]) for i in idx]
    assert (low, high) == tuple(np.quantile(erts, [0.025, 0.975], method="inverted_cdf"))
    assert high == math.inf  # some resamples hold only the unsuccessful run
    assert expected_runtime_ci([5.0, 5.0], [9, 9]) == (5.0, 5.0)


def test_runtime_ecdf_by_hand():
    frame = table({("e", "a", 0): [1.0, 2.0, 2.0, 4.0], ("e", "a", 1): [1.0, 1.0, 2.0, 2.0]})
    ecdf = runtime_ecdf(frame, [2.0, 4.0]).set_index("evaluations")["fraction"]
    # (run, target) pairs: run 0 reaches 2 at 2 and 4 at 4; run 1 reaches 2 at 3, never 4
    assert ecdf.loc[1] == 0 and ecdf.loc[2] == 0.25 and ecdf.loc[3] == 0.5 and ecdf.loc[4] == 0.75


def test_fixed_budget_by_hand():
    frame = table({("e", "a", s): [float(s), float(s + 1), float(s + 3)] for s in range(5)})
    fb = fixed_budget(frame, [1, 3]).set_index("budget")
    assert fb.loc[1, "median"] == 2 and fb.loc[3, "median"] == 5
    assert fb.loc[3, "q25"] == 4 and fb.loc[3, "q75"] == 6 and fb.loc[3, "mean"] == 5
    assert fb.loc[1, "ci_low"] <= 2 <= fb.loc[1, "ci_high"]
    short = fixed_budget(table({("e", "a", 0): [1.0, 2.0], ("e", "a", 1): [1.0, 2.0, 3.0]}), [3])
    assert short["runs"].iloc[0] == 1  # the run that stopped short has no value at 3 (not its last value)


def test_default_targets_span_first_generation_to_best():
    frame = table({("e", "a", 0): [10.0, 20.0, 30.0, 60.0], ("e", "a", 1): [20.0, 20.0, 30.0, 40.0]}, population=2)
    traces = run_traces(frame)
    # first-generation bests: 20 and 20 -> low 20; best found 60
    assert default_targets(traces, 4) == [30.0, 40.0, 50.0, 60.0]
    assert default_targets(traces, 4, optimum=100.0) == [30.0, 40.0, 50.0, 60.0, 100.0]
    assert default_targets(traces, 4, optimum=60.0)[-1] == 60.0


def test_tables_group_by_environment():
    one = table({("e1", "a", 0): [1.0, 2.0], ("e1", "b", 0): [1.0, 1.0]})
    two = table({("e2", "a", 0): [5.0, 9.0], ("e2", "b", 0): [7.0, 7.0]})
    ft = fixed_target(pd.concat([one, two]), {"e1": [2.0], "e2": [8.0]})
    assert list(ft["env"]) == ["e1", "e1", "e2", "e2"]
    assert list(ft["ert"]) == [2.0, math.inf, 2.0, math.inf]


def test_unknown_metric_is_one_error():
    with pytest.raises(ConfigError, match="unknown metric"):
        run_scores(table({("e", "a", 0): [1.0]}), "speed")


# -- effect size and multiple comparisons -----------------------------------------------------------
def test_a12_by_hand_and_against_scipy():
    # pairs of (1,2,3) against (2,2,0): 5 wins and 2 ties of 9
    assert a12([1, 2, 3], [2, 2, 0]) == pytest.approx(6 / 9)
    rng = np.random.default_rng(0)
    x, y = rng.integers(0, 5, 12), rng.integers(1, 6, 9)  # many ties
    assert a12(x, y) == pytest.approx(mannwhitneyu(x, y).statistic / (len(x) * len(y)))
    assert [magnitude(v) for v in (0.5, 0.57, 0.3, 0.9)] == ["negligible", "small", "medium", "large"]


def test_holm_by_hand():
    np.testing.assert_allclose(holm([0.01, 0.04, 0.03]), [0.03, 0.06, 0.06])
    out = holm([0.01, np.nan, 0.04])
    assert out[0] == pytest.approx(0.02) and math.isnan(out[1]) and out[2] == pytest.approx(0.04)
    assert holm([0.5, 0.9]).max() <= 1.0


# -- pairwise tests ------------------------------------------------------------------------------------
def _scored(scores: dict[str, list[float]], env: str = "e", run_id: str = "r1") -> pd.DataFrame:
    """A table whose runs end at the given best rewards (one evaluation each)."""
    return table({(env, d, s): [v] for d, values in scores.items() for s, v in enumerate(values)}, run_id=run_id)


def test_paired_test_is_scipys_wilcoxon_with_holm():
    a = [10.0, 12, 9, 14, 11, 13, 15, 10, 12, 16]
    b = [v - d for v, d in zip(a, [1, 2, 0.5, 3, 1.5, 2.5, 4, 0.25, 1.25, 3.5])]
    c = [v + 0.1 * (-1) ** i for i, v in enumerate(a)]
    tests = pairwise(_scored({"a": a, "b": b, "c": c}))
    ab = tests.iloc[0]
    assert ab["test"] == "Wilcoxon signed-rank" and ab["pairs"] == 10
    assert ab["p"] == pytest.approx(wilcoxon(a, b).pvalue) == pytest.approx(2 / 1024)  # a beats b on every seed
    assert ab["difference"] == pytest.approx(np.median(np.subtract(a, b)))
    assert ab["p_holm"] == pytest.approx(holm(tests["p"])[0])
    assert ab["a12"] == pytest.approx(a12(a, b)) and ab["significant"]
    assert ab["verdict"].startswith("a better than b: significant at 0.05")
    ac = tests.iloc[1]
    assert not ac["significant"] and ac["verdict"].startswith("no significant difference")


def test_pairs_across_runs_are_unpaired_mann_whitney():
    a, b = [5.0, 6, 7, 8], [1.0, 2, 3, 9]
    frame = pd.concat([_scored({"a": a}, run_id="r1"), _scored({"b": b}, run_id="r2")])
    row = pairwise(frame).iloc[0]
    assert row["test"] == "Mann-Whitney U" and row["pairs"] == 0
    assert row["p"] == pytest.approx(mannwhitneyu(a, b, alternative="two-sided").pvalue)
    assert row["difference"] == np.median(a) - np.median(b)
    forced = pairwise(frame, pairing="unpaired").iloc[0]
    assert forced["p"] == row["p"]
    with pytest.raises(ConfigError, match="pairing"):
        pairwise(frame, pairing="sometimes")


def test_missing_seed_makes_auto_unpaired_and_paired_drops_it():
    frame = _scored({"a": [1.0, 2, 3, 4, 5, 6], "b": [2.0, 3, 4, 5, 6]})
    assert pairwise(frame).iloc[0]["test"] == "Mann-Whitney U"
    forced = pairwise(frame, pairing="paired").iloc[0]
    assert forced["test"] == "Wilcoxon signed-rank" and forced["pairs"] == 5
    assert forced["p"] == pytest.approx(wilcoxon([1.0, 2, 3, 4, 5], [2.0, 3, 4, 5, 6]).pvalue)


def test_holm_family_is_one_environment():
    one = _scored({"a": [9.0, 8, 7, 9, 8, 9, 7, 8], "b": [1.0, 2, 1, 2, 1, 2, 1, 2]}, env="e1")
    two = _scored({"a": [1.0, 2, 1, 2, 1, 2, 1, 2], "b": [3.0, 3, 3, 3, 3, 3, 3, 3]}, env="e2")
    tests = pairwise(pd.concat([one, two]))
    assert list(tests["env"]) == ["e1", "e2"]
    assert list(tests["p_holm"]) == list(tests["p"])  # one pair per environment: nothing to correct


def test_one_seed_cannot_be_tested():
    row = pairwise(_scored({"a": [5.0], "b": [3.0]})).iloc[0]
    assert math.isnan(row["p"]) and not row["significant"]
    assert "nothing can be concluded" in row["verdict"]


def test_identical_designers_give_p_one():
    row = pairwise(_scored({"a": [1.0, 2, 3], "b": [1.0, 2, 3]})).iloc[0]
    assert row["p"] == 1.0 and row["a12"] == 0.5 and row["seeds_for_power"] is pd.NA


# -- power ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize(("n", "c"), [(6, 0), (8, 3), (10, 8), (20, 52), (30, 137)])
def test_critical_values_are_the_published_ones_and_scipys(n, c):
    assert critical_value(n, 0.05) == c
    ranks = np.arange(1, n + 1)

    def p_with(w_plus: int) -> float:
        """scipy's exact p for differences +-1..n whose positive ranks sum to w_plus."""
        positive, left = set(), w_plus
        for r in ranks[::-1]:
            if r <= left:
                positive.add(r)
                left -= r
        return wilcoxon(np.where(np.isin(ranks, list(positive)), ranks, -ranks).astype(float)).pvalue

    assert p_with(c) <= 0.05 < p_with(c + 1)


def test_simulated_power_rejects_exactly_where_scipy_does():
    n, effect, draws = 9, 0.75, 300
    diffs = np.random.default_rng(0).standard_normal((draws, n)) + norm.ppf(effect)
    by_scipy = np.mean([wilcoxon(d).pvalue <= 0.05 for d in diffs])
    assert power(n, effect, draws=draws, seed=0) == pytest.approx(by_scipy)


def test_seeds_needed():
    assert minimum_seeds(0.05) == 6 and minimum_seeds(0.05 / 3) == 7
    assert power(5, 0.99) == 0.0  # five seeds cannot reach 0.05
    assert power(40, 0.5) <= 0.05 + 0.015  # no effect: rejects at about the level
    needed = [seeds_needed(a) for a in (0.9, 0.71, 0.64)]
    assert needed == sorted(needed) and needed[0] >= 6
    # Noether's normal approximation for the signed-rank test agrees within a few seeds
    p_prime = norm.cdf(math.sqrt(2) * norm.ppf(0.64))
    approximation = (norm.ppf(0.975) + norm.ppf(0.8)) ** 2 / (3 * (p_prime - 0.5) ** 2)
    assert noether(0.64) == pytest.approx(approximation)
    assert abs(needed[2] - approximation) / approximation < 0.1
    assert seeds_needed(0.71, comparisons=3) > needed[1]
    assert seeds_needed(0.5) is None and seeds_needed(0.501) is None  # no effect / out of reach
    assert seeds_needed(0.29) == needed[1]  # two-sided


# -- aggregates (rliable) ---------------------------------------------------------------------------------
# What rliable 1.2.0 returns for hand-made normalised scores (runs x tasks), made by benchmarks/ops/rliable_reference.py
# in a venv with rliable and pandas 2 (rliable cannot be imported next to gdabench's pandas 3): point estimates, and
# 95% stratified-bootstrap percentile intervals with `reps` resamples after np.random.seed(0).
RLIABLE = json.loads((Path(__file__).parent / "expectations" / "rliable.json").read_text())
#: bootstrap noise between rliable's resamples and gdabench's (a plain mean instead of the IQM is off by 0.04)
TOL = 0.02


def _scores(names) -> pd.DataFrame:
    """The hand-made scores of ``names`` as the table aggregate_scores reads."""
    rows = []
    for name in names:
        matrix = np.array(RLIABLE["inputs"][name])
        for t in range(matrix.shape[1]):
            rows += [{"designer": name, "env": f"e{t}", "normalised": v} for v in matrix[:, t]]
    return pd.DataFrame(rows)


@pytest.mark.parametrize("name", ["X", "Y", "A", "B", "C"])
def test_aggregate_point_estimates_are_rliables(name):
    tasks = list(np.array(RLIABLE["inputs"][name]).T)
    theirs = RLIABLE["designers"][name]
    assert agg.iqm(tasks) == pytest.approx(theirs["iqm"])
    assert agg.iqm(tasks) == pytest.approx(trim_mean(np.concatenate(tasks), 0.25))
    np.testing.assert_allclose(agg.profile(tasks, RLIABLE["taus"]), theirs["profile"], atol=1e-8)


@pytest.mark.parametrize("pair", ["X,Y", "A,B", "C,B"])
def test_improvement_probability_is_rliables(pair):
    x, y = (list(np.array(RLIABLE["inputs"][n]).T) for n in pair.split(","))
    assert agg.improvement_probability(x, y) == pytest.approx(RLIABLE["improvement"][pair]["probability"])


@pytest.mark.parametrize("names", [("X", "Y"), ("A", "B", "C")])
def test_stratified_intervals_match_rliables(names):
    iqms, profiles, improvements = agg.aggregate_scores(_scores(names), resamples=RLIABLE["reps"], taus=RLIABLE["taus"])
    for name in names:
        theirs = RLIABLE["designers"][name]
        mine = iqms.set_index("designer").loc[name]
        np.testing.assert_allclose([mine["ci_low"], mine["ci_high"]], theirs["iqm_ci"], atol=TOL)
        mine = profiles[profiles["designer"] == name]
        np.testing.assert_allclose([mine["ci_low"], mine["ci_high"]], theirs["profile_ci"], atol=TOL)
    for pair, theirs in RLIABLE["improvement"].items():
        x, y = pair.split(",")
        if {x, y} <= set(names):
            mine = improvements.set_index(["designer_x", "designer_y"]).loc[(x, y)]
            np.testing.assert_allclose([mine["ci_low"], mine["ci_high"]], theirs["ci"], atol=TOL)


def _rliable():
    """rliable's modules where they import (its arch dependency fails next to pandas 3: a TypeError, not an
    ImportError, so pytest.importorskip would not skip)."""
    try:
        from rliable import library, metrics
    except Exception as exc:  # noqa: BLE001
        pytest.skip(f"rliable does not import here: {type(exc).__name__}")
    return library, metrics


def test_aggregates_against_rliable_itself_where_it_imports():
    library, metrics = _rliable()
    for name in ("X", "A", "C"):
        matrix = np.array(RLIABLE["inputs"][name])
        assert agg.iqm(list(matrix.T)) == pytest.approx(metrics.aggregate_iqm(matrix))
    x, y = np.array(RLIABLE["inputs"]["A"]), np.array(RLIABLE["inputs"]["B"])
    assert agg.improvement_probability(list(x.T), list(y.T)) == pytest.approx(metrics.probability_of_improvement(x, y))


def test_stratified_bootstrap_never_mixes_environments():
    # every run of task 0 scores 0, of task 1 scores 1: any resample keeps half zeros, half ones
    low, high = agg.stratified_bootstrap(lambda t: np.concatenate(t, axis=1).mean(axis=1), [np.zeros(4), np.ones(4)])
    assert low == high == 0.5


def test_normalised_scores_and_designers_missing_an_environment():
    frame = pd.concat(
        [
            _scored({"a": [2.0, 4.0], "b": [0.0, 1.0], "c": [3.0, 3.0]}, env="e1"),
            _scored({"a": [10.0, 30.0], "b": [20.0, 20.0]}, env="e2"),
        ]
    )
    scores = agg.normalised_scores(frame)
    e1 = scores[scores["env"] == "e1"].set_index(["designer", "seed"])["normalised"]
    assert e1.loc[("a", 1)] == 1.0 and e1.loc[("b", 0)] == 0.0 and e1.loc[("a", 0)] == 0.5
    with_optimum = agg.normalised_scores(frame, optima={"e2": 50.0})
    assert with_optimum[with_optimum["env"] == "e2"]["normalised"].max() == pytest.approx(0.5)
    iqm, profiles, poi = agg.aggregate_scores(scores, resamples=200)
    assert list(iqm["designer"]) == ["a", "b"]  # c ran on e1 only
    assert iqm.set_index("designer").loc["a", "iqm"] == pytest.approx(
        agg.iqm([np.array([0.5, 1.0]), np.array([0.0, 1.0])])
    )
    assert set(zip(poi["designer_x"], poi["designer_y"])) == {("a", "b"), ("b", "a")}
    pab = poi.set_index(["designer_x", "designer_y"])["probability"]
    assert pab.loc[("a", "b")] + pab.loc[("b", "a")] == pytest.approx(1.0)
    assert profiles.groupby("designer").size().tolist() == [agg.PROFILE_POINTS] * 2


# -- the report -------------------------------------------------------------------------------------------
def _run(tmp_path, name: str, env: str, seeds: str) -> RunDirectory:
    return small_run(tmp_path / name, env, seeds)


def _section(report, title: str):
    return next(s for s in report.sections if s.title == title)


def test_one_seed_report_says_nothing_can_be_concluded(tmp_path):
    run = _run(tmp_path, "one", "simple", "0")
    report = write_report(run.path, animations=False)
    words = " ".join(_section(report, "Which differences are significant").paragraphs)
    assert "Nothing can be concluded" in words and "one seed" in words
    assert f"at least {minimum_seeds(0.05)} seeds" in words
    summary = (report.out / "summary.md").read_text()
    assert "Nothing can be concluded" in summary and "Seeds needed for a given effect" in summary
    assert "Nothing can be concluded" in (report.out / "report.html").read_text()


def test_report_pages_agree_with_the_functions(tmp_path):
    run = _run(tmp_path, "many", "simple", "0..5")
    report = write_report(run.path, animations=False)
    frame = run.load_evaluations()
    titles = [s.title for s in report.sections]
    assert titles[0] == "Which differences are significant"
    assert "Fixed target: evaluations to reach a reward" in titles and "Aggregate over environments" not in titles
    stored = pd.read_csv(report.out / "pairwise.csv")
    expected = pairwise(frame)
    np.testing.assert_allclose(stored["p_holm"], expected["p_holm"])
    assert (
        stored["test"].iloc[0] == "Wilcoxon signed-rank" and stored["same_start"].iloc[0] == "yes"
    )  # ga and random share generation 0
    ert = pd.read_csv(report.out / "fixed_target.csv")
    np.testing.assert_allclose(ert["ert"], fixed_target(frame, optima={"simple": 100.0})["ert"])
    assert (report.out / "ecdf_simple.png").is_file() and (report.out / "fixed_budget.csv").is_file()
    words = " ".join(_section(report, "Which differences are significant").paragraphs)
    assert "With 6 seeds per designer" in words


def test_several_environments_get_the_aggregate_page(tmp_path):
    simple = _run(tmp_path, "simple", "simple", "0..2")
    peaks = _run(tmp_path, "peaks", "two-peaks", "0..2")
    both = tmp_path / "both"
    shutil.copytree(simple.path, both)
    merged = pd.concat([simple.load_evaluations(), peaks.load_evaluations()], ignore_index=True)
    merged.to_parquet(both / "evaluations.parquet", index=False)
    report = write_report(both, animations=False)
    section = _section(report, "Aggregate over environments")
    assert [t.title for t in section.tables] == [
        "Interquartile mean of normalised best rewards",
        "Probability of improvement",
    ]
    iqm = pd.read_csv(report.out / "aggregate_iqm.csv")
    assert list(iqm["designer"]) == ["ga", "random"] and (iqm["envs"] == 2).all()
    assert set(pd.read_csv(report.out / "pairwise.csv")["env"]) == {"simple", "two-peaks"}
    assert (report.out / "ecdf_two-peaks.png").is_file() and (report.out / "performance_profiles.png").is_file()


def test_scores_are_normalised_against_random_search_and_the_optimum():
    """rliable's Atari normalisation: 0 = the random designer's median on the environment, 1 = its optimum
    (where known; else the best run); where random did not run, the lowest run counts 0."""
    frame = pd.concat([
        _scored({"random": [2.0, 4.0, 6.0], "ga": [8.0, 10.0, 3.0]}, env="e1"),
        _scored({"ga": [1.0, 3.0], "cppn": [2.0, 5.0]}, env="e2"),
    ])  # fmt: skip
    scores = agg.normalised_scores(frame, optima={"e1": 12.0})
    e1 = scores[scores["env"] == "e1"].set_index(["designer", "seed"])["normalised"]
    assert e1.loc[("random", 1)] == 0.0 and e1.loc[("ga", 1)] == 0.75 and e1.loc[("ga", 2)] == pytest.approx(-1 / 8)
    e2 = scores[scores["env"] == "e2"].set_index(["designer", "seed"])["normalised"]
    assert e2.loc[("ga", 0)] == 0.0 and e2.loc[("cppn", 1)] == 1.0
    assert agg.normalisation_words(scores) == ("e1: 0 = 4 (random's median), 1 = 12 (optimum); "
                                               "e2: 0 = 1 (lowest run), 1 = 5 (best run)")  # fmt: skip
