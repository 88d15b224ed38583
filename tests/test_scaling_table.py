"""The script that runs designers on several body shapes and tabulates the gap to the optimum."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pandas as pd
import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "scaling_table.py"


@pytest.fixture(scope="module")
def table():
    spec = importlib.util.spec_from_file_location("scaling_table", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


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
