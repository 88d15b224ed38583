"""The script that runs designers on several body shapes and tabulates the gap to the optimum."""

from __future__ import annotations

import json

import pandas as pd
import pytest

from support.scripts import BENCHMARKS, load_script


@pytest.fixture(scope="module")
def table():
    return load_script("figures/scaling_table")


def test_budget_and_population_follow_the_voxels(table):
    assert table.scaled((5, 5), 40, 1.0) == (25, 1000)
    assert table.scaled((8, 8), 40, 1.0) == (64, 2560)
    assert table.scaled((12, 12), 40, 1.0) == (144, 5760)
    assert table.scaled((12, 12), 40, 0.25) == (36, 5760)


def test_one_run_per_designer_and_shape_gaps_tests_and_plot(table, tmp_path, capsys):
    args = ["--designers", "ga,random", "--envs", "target,nk[k=1]", "--shapes", "3x3,4x4", "--seeds", "0..5",
            "--evals-per-voxel", "6", "--root", str(tmp_path / "runs")]
    plot, csv = tmp_path / "gap.png", tmp_path / "gap.csv"
    assert table.main([*args, "--plot", str(plot), "--csv", str(csv)]) == 0
    out = capsys.readouterr().out
    assert sorted(p.relative_to(tmp_path / "runs").as_posix() for p in (tmp_path / "runs").glob("*/*")) == [
        "3x3/ga", "3x3/random", "4x4/ga", "4x4/random"]
    rows = pd.read_csv(csv)
    assert list(zip(rows["env"], rows["shape"], rows["designer"]))[:4] == [
        ("target", "3x3", "ga"), ("target", "3x3", "random"), ("target", "4x4", "ga"), ("target", "4x4", "random")]
    assert (rows["seeds"] == 6).all() and (rows["population"] == rows["voxels"]).all()
    assert (rows["budget"] == 6 * rows["voxels"]).all()
    assert ((rows["gap_median"] >= 0) & (rows["gap_median"] <= 1)).all()
    assert (rows["gap_q1"] <= rows["gap_median"]).all() and (rows["gap_median"] <= rows["gap_q3"]).all()
    assert (rows.loc[rows["env"] == "target", "optimum"] == 100).all()
    assert (rows["optimum_kind"] == "optimum").all()  # nk's optimum is exact on bodies this small
    # the gap is (optimum - best) / optimum of the per-seed bests
    one = rows[(rows["env"] == "target") & (rows["shape"] == "4x4") & (rows["designer"] == "ga")].iloc[0]
    assert one["gap_median"] == pytest.approx((100 - one["best_median"]) / 100)
    assert "| target | random | 3x3 | 6 |" in out  # random against ga, six seeds paired
    assert "| target | random | 4x4 vs 3x3 | 6 |" in out
    assert "### Time per generation" in out
    assert plot.stat().st_size > 10_000
    stamp = (tmp_path / "runs" / "4x4" / "ga" / "evaluations.parquet").stat().st_mtime_ns
    assert table.main(args) == 0  # complete runs are not redone, and the tables are the same
    assert (tmp_path / "runs" / "4x4" / "ga" / "evaluations.parquet").stat().st_mtime_ns == stamp
    assert capsys.readouterr().out == out
    assert table.main([*args, "--no-run", "--designers", "ga"]) == 0
    assert "Against ga" not in capsys.readouterr().out  # nothing to compare the baseline with


def test_seeds_added_later_join_the_first_run_and_give_the_table_of_one_run(table, tmp_path, capsys):
    base = ["--designers", "random,ga", "--envs", "target", "--shapes", "3x3", "--evals-per-voxel", "4"]
    later, once = tmp_path / "later", tmp_path / "once"
    assert table.main([*base, "--seeds", "0", "--root", str(later)]) == 0
    capsys.readouterr()
    assert table.main([*base, "--seeds", "0..2,5", "--root", str(later), "--csv", str(tmp_path / "later.csv")]) == 0
    added = capsys.readouterr().out
    assert sorted(p.name for p in (later / "3x3").iterdir()) == ["ga", "random"]
    assert json.loads((later / "3x3" / "ga" / "run.json").read_text())["config"]["seeds"] == [0, 1, 2, 5]
    stamp = (later / "3x3" / "ga" / "evaluations.parquet").stat().st_mtime_ns
    assert table.main([*base, "--seeds", "0..2,5", "--root", str(later)]) == 0  # nothing left to run
    assert (later / "3x3" / "ga" / "evaluations.parquet").stat().st_mtime_ns == stamp
    assert table.main([*base, "--seeds", "0..2,5", "--root", str(once), "--csv", str(tmp_path / "once.csv")]) == 0
    def tests(out):  # the paired comparisons (the gap table's wall times differ between runs)
        return out[out.index("### Against"):out.index("### Time per generation")]
    assert tests(capsys.readouterr().out) == tests(added)
    rows = pd.read_csv(tmp_path / "later.csv")
    assert (rows["seeds"] == 4).all() and (rows["seed_list"] == "0,1,2,5").all()
    pd.testing.assert_frame_equal(
        rows.drop(columns="wall_s_median"), pd.read_csv(tmp_path / "once.csv").drop(columns="wall_s_median")
    )


def test_bad_input_is_one_error_line(table, tmp_path, capsys):
    base = ["--envs", "target", "--seeds", "0", "--root", str(tmp_path)]
    assert table.main(["--designers", "random", "--shapes", "3x3", "--evals-per-voxel", "4", *base]) == 0
    capsys.readouterr()
    assert table.main(["--designers", "random", "--shapes", "3x3", "--evals-per-voxel", "5", *base]) == 2
    assert "other settings" in capsys.readouterr().err
    assert table.main(["--designers", "random,nosuch", "--shapes", "3x3", *base]) == 2
    assert "unknown designer 'nosuch'" in capsys.readouterr().err
    assert table.main(["--designers", "random", "--shapes", "3by3", *base]) == 2
    assert capsys.readouterr().err.startswith("error:")
    assert table.main(["--designers", "ga", "--shapes", "3x3", "--no-run", *base]) == 2
    assert "no runs" in capsys.readouterr().err


def test_comparisons_pair_by_seed_orient_a12_and_correct_per_designer(table):
    from gdabench import PluginChoice
    from gdabench.report.pairwise import holm

    seeds = range(8)
    rows = []
    for shape, voxels, loss in (("3x3", 9, 0.0), ("6x6", 36, 0.1), ("9x9", 81, 0.2)):
        for s in seeds:
            ga = 0.2 + 0.01 * s + loss  # the baseline loses ground on the larger shapes
            rows.append({"env": "e", "shape": shape, "voxels": voxels, "seed": s, "designer": "ga", "gap": ga})
            rows.append(
                {
                    "env": "e",
                    "shape": shape,
                    "voxels": voxels,
                    "seed": s,
                    "designer": "better",
                    "gap": ga - 0.05 - 0.001 * s,
                }
            )
            rows.append(
                {
                    "env": "e",
                    "shape": shape,
                    "voxels": voxels,
                    "seed": s,
                    "designer": "same",
                    "gap": ga + (0.001 if s % 2 else -0.001),
                }
            )
    frame = pd.DataFrame(rows)
    tests = table.comparisons(frame, PluginChoice.parse_list("e"), PluginChoice.parse_list("ga,better,same"), "ga")
    assert list(tests["what"]) == ["3x3", "6x6", "9x9", "6x6 vs 3x3", "9x9 vs 3x3"] * 2
    better = tests[tests["designer"] == "better"].set_index("what")
    assert better.loc["3x3", "difference"] == pytest.approx(-0.0535)  # median of -(0.05 + 0.001 s)
    assert better.loc["3x3", "a12"] > 0.9  # A12 over all runs, as the project's: the seeds' spread overlaps a little
    assert better.loc["3x3", "p"] == pytest.approx(2 / 2**8)  # paired: every seed closer, the smallest exact p
    assert better.loc["6x6 vs 3x3", "difference"] == pytest.approx(0.0)  # the same lead at every size
    assert better.loc["9x9 vs 3x3", "difference"] == pytest.approx(0.0)
    same = tests[tests["designer"] == "same"]
    assert (same["p"] > 0.5).all() and (same["magnitude"] != "large").all()
    for _, family in tests.groupby("designer"):  # Holm within each designer's rows, not across designers
        assert list(family["p_holm"]) == pytest.approx(list(holm(family["p"].to_numpy())))


def test_the_committed_experiment_follows_the_scripts_rule(table):
    from gdabench.experiment.build import build_run

    experiment = build_run({"config": BENCHMARKS.parent / "experiments" / "scaling.toml"}).experiment
    assert (experiment.population, experiment.budget) == table.scaled(experiment.shape, 40, 1.0)
    assert ",".join(e.label for e in experiment.envs) == table.DEFAULT_ENVS
    assert table.shape_text(experiment.shape) in table.DEFAULT_SIZES.split(",")
