"""``gdabench compare`` with the gda designer, end to end through the command line."""

from __future__ import annotations

import pandas as pd
from typer.testing import CliRunner

from gdabench.cli import app


def test_compare_ga_and_gda_on_simple_end_to_end(tmp_path):
    out = tmp_path / "run"
    args = [
        "compare",
        "--designers",
        "ga,gda",
        "--env",
        "simple",
        "--seeds",
        "0,1,2",
        "--budget",
        "40",
        "--population",
        "10",
    ]
    args += ["-D", "gda.epochs=2", "-D", "gda.steps=50", "--out", str(out), "-q"]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    rows = pd.read_parquet(out / "evaluations.parquet")
    assert set(rows["designer"]) == {"ga", "gda"}
    gda = rows[rows["designer"] == "gda"]
    assert sorted(gda["seed"].unique()) == [0, 1, 2]
    assert (gda.groupby("seed")["n_evals"].max() == 40).all()
    assert (gda["status"] == "ok").all()  # every proposal valid and new
    assert set(gda["source"]) <= {"initial", "sampled", "random"}
    assert (gda.loc[gda["generation"] == 0, "source"] == "initial").all()
    assert (gda.loc[gda["generation"] > 0, "source"] == "sampled").any()
    assert gda.loc[gda["generation"] > 0, "train_loss"].notna().all()


def test_gda_parameter_errors_are_one_line(tmp_path):
    result = CliRunner().invoke(
        app, ["compare", "--designers", "gda[sampler=euler]", "--out", str(tmp_path / "x"), "-q"]
    )
    assert result.exit_code == 2
    assert "unknown sampler" in result.output and "Traceback" not in result.output


def test_gda_runs_on_bodies_smaller_than_3x3(tmp_path):
    """The docs once said gda needs bodies of at least 3x3; it runs on smaller ones, down to a single voxel
    (whose only valid bodies are 3 and 4: generation 0 draws one, the model samples the other)."""
    for shape, population, budget in (("2x2", 10, 20), ("1x5", 10, 20), ("1x1", 1, 2)):
        out = tmp_path / shape
        result = CliRunner().invoke(
            app,
            [
                "run",
                "gda[epochs=2,steps=5]",
                "--shape",
                shape,
                "--budget",
                str(budget),
                "--population",
                str(population),
                "--out",
                str(out),
                "-q",
                "--no-report",
            ],
        )
        assert result.exit_code == 0, result.output
        rows = pd.read_parquet(out / "evaluations.parquet")
        assert rows["n_evals"].max() == budget and (rows.loc[rows["generation"] > 0, "source"] == "sampled").any()
