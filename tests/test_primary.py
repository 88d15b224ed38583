"""A pre-registered primary comparison: named in the experiment, tested alone at its level; every other
pair exploratory (Holm); and the warnings a run gets when its seeds cannot reach significance."""

from __future__ import annotations

import pytest
from scipy.stats import wilcoxon
from typer.testing import CliRunner

from gdabench.cli import app
from gdabench.errors import ConfigError
from gdabench.experiment.build import build_run, significance_warnings
from gdabench.experiment.config import Experiment, Primary
from gdabench.report.build import write_report
from gdabench.report.pairwise import holm, pairwise
from gdabench.stats.power import seeds_needed

from support.stat_tables import table

#: per seed, the best reward of three designers: a beats b on 6 of 7 seeds (exact p = 0.03125 alone)
A = [5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 2.0]
B = [4.0, 4.5, 5.0, 5.5, 6.0, 6.5, 3.0]
C = [4.5, 6.5, 6.0, 9.0, 8.0, 9.5, 2.5]


def _frame():
    runs = {("e", d, s): [v] for d, values in (("a", A), ("b", B), ("c", C)) for s, v in enumerate(values)}
    return table(runs, population=1)


def test_the_primary_comparison_is_tested_alone():
    tests = pairwise(_frame(), primary=Primary("a", "b"))
    first = tests.iloc[0]
    alone = wilcoxon(A, B).pvalue
    assert (first["role"], first["designer_a"], first["designer_b"]) == ("primary", "a", "b")
    assert first["p"] == pytest.approx(alone) and first["p_holm"] == first["p"] and first["significant"]
    assert "tested alone" in first["verdict"] and "a better than b" in first["verdict"]
    # the other pairs: exploratory, Holm over the two of them only (not over three)
    others = tests[tests["role"] == "exploratory"]
    assert len(others) == 2
    assert list(others["p_holm"]) == pytest.approx(list(holm(list(others["p"]))))
    # without a primary comparison the same pair, Holm-corrected over three pairs, is not significant
    plain = pairwise(_frame()).set_index(["designer_a", "designer_b"])
    assert (
        plain.loc[("a", "b"), "p_holm"] == pytest.approx(min(1.0, 3 * alone))
        and not plain.loc[("a", "b"), "significant"]
    )
    assert set(plain["role"]) == {"exploratory"}


def test_the_primary_comparison_may_name_b_first_and_its_own_metric():
    tests = pairwise(_frame(), primary=Primary("b", "a", metric="mean_best_so_far"))
    first = tests.iloc[0]
    assert (first["designer_a"], first["metric"], first["role"]) == ("b", "mean_best_so_far", "primary")
    assert first["a12"] < 0.5 and "a better than b" in first["verdict"]


def test_ties_are_counted_and_said():
    tied = {("e", d, s): [v] for d, values in (("a", [1.0, 2.0, 3.0, 4.0, 5.0]), ("b", [1.0, 1.0, 1.0, 1.0, 1.0]))
            for s, v in enumerate(values)}  # fmt: skip
    row = pairwise(table(tied, population=1)).iloc[0]
    assert (row["pairs"], row["untied"]) == (5, 4)
    assert "4 non-tied pairs of 5 cannot give a significant result" in row["verdict"]


def test_experiment_file_primary_sets_the_seeds_from_the_power_analysis(tmp_path):
    path = tmp_path / "e.toml"
    path.write_text(
        'designers = ["ga", "gda", "random"]\nenv = "simple"\n[primary]\na = "gda"\nb = "ga"\neffect = 0.9\n'
    )
    experiment = build_run({"config": path}).experiment
    assert experiment.primary == Primary("gda", "ga", effect=0.9)
    assert experiment.seeds == tuple(range(seeds_needed(0.9)))
    assert Experiment.from_json(experiment.to_json()) == experiment  # recorded in run.json
    path.write_text('designers = ["ga", "gda"]\nenv = "simple"\nseeds = "0..3"\nprimary = "gda,ga"\n')
    assert build_run({"config": path}).experiment.seeds == (0, 1, 2, 3)  # seeds given win
    for text, message in (('primary = "gda,cppn"', "not in this run"), ('[primary]\na = "gda"', "missing 'b'"),
                          ('[primary]\na = "gda"\nb = "ga"\neffect = 0.5', "no effect"),
                          ('[primary]\na = "gda"\nb = "ga"\nmetric = "reevaluated_best"', "needs re-evaluation"),
                          ('[primary]\na = "gda"\nb = "ga"\nalpah = 0.1', "unknown key 'alpah'")):  # fmt: skip
        path.write_text(f'designers = ["ga", "gda"]\nenv = "simple"\n{text}\n')
        with pytest.raises(ConfigError, match=message):
            build_run({"config": path}).experiment.check()


def test_warnings_before_a_run_that_cannot_conclude():
    five = build_run({"designers": "ga,cppn,gda,gda-fast,random", "env": "simple", "seeds": "0..4"}).experiment
    [line] = significance_warnings(five)
    assert "no pair of designers can differ significantly with 5 seeds" in line and "10 pair(s)" in line
    primary = build_run({"designers": "ga,gda", "env": "simple", "seeds": "0..4", "primary": "gda,ga"}).experiment
    [line] = significance_warnings(primary)
    assert "cannot be significant with 5 seeds" in line and "0.0625" in line
    short = build_run({"designers": "ga,gda", "env": "simple", "seeds": "0..9", "primary": "gda,ga"}).experiment
    assert "has 10 seeds; about 29" in significance_warnings(short)[0]
    assert significance_warnings(build_run({"designers": "ga,gda", "env": "simple", "seeds": "0..5"}).experiment) == []
    assert significance_warnings(build_run({"designers": "ga", "env": "simple"}).experiment) == []


def test_compare_warns_before_the_run(tmp_path):
    import gdabench

    with pytest.warns(UserWarning, match="no pair of designers can differ significantly with 3 seeds"):
        gdabench.compare("ga,random", "simple", seeds="0..2", budget=25, out=tmp_path / "api", progress=False)
    args = ["compare", "-d", "ga,random", "--env", "simple", "--budget", "25", "--seeds", "0..4"]
    result = CliRunner().invoke(app, [*args, "--out", str(tmp_path / "run"), "-q", "--no-report"])
    assert result.exit_code == 0, result.output
    assert "warning: no pair of designers can differ significantly with 5 seeds" in " ".join(result.output.split())


def test_the_report_tests_the_primary_comparison_and_says_when_it_was_named(tmp_path):
    out = tmp_path / "run"
    args = ["compare", "-d", "ga,random", "--env", "simple", "--budget", "25", "--seeds", "0..5"]
    result = CliRunner().invoke(app, [*args, "--out", str(out), "-q", "--no-report"])
    assert result.exit_code == 0, result.output
    report = write_report(out, animations=False, primary=Primary("ga", "random"))
    words = " ".join(next(s for s in report.sections if s.title == "Which differences are significant").paragraphs)
    assert words.startswith("Primary comparison: ga against random")
    assert any("named for this report, after the run" in n for n in report.notes)
    assert dict(report.facts)["primary comparison"].endswith("(named for this report, after the run)")
    with pytest.raises(ConfigError, match="not in this run"):
        write_report(out, animations=False, primary=Primary("ga", "gda"))
    done = CliRunner().invoke(app, ["report", str(out), "--primary", "ga,random", "--no-animations"])
    assert done.exit_code == 0, done.output
