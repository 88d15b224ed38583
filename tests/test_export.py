"""`gdabench export`: IOHprofiler data read back with IOHprofiler's own reader (iohinspector),
compared with what the `ioh` package's logger writes for the same evaluations, and checked
against the parquet; CSV round trip; one-line errors."""

from __future__ import annotations

import json
import math
import shutil

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from gdabench.cli import app
from gdabench.errors import ConfigError
from gdabench.report.export import dat_block, export_run
from gdabench.report.runtimes import run_traces
from gdabench.statuses import COUNTED

from support.stat_tables import small_run, table

ioh = pytest.importorskip("ioh")
iohinspector = pytest.importorskip("iohinspector")

SEEDS = (0, 1, 2)


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return small_run(tmp_path_factory.mktemp("runs") / "small", "simple", ",".join(map(str, SEEDS)))


@pytest.fixture(scope="module")
def exported(run, tmp_path_factory):
    return export_run(run.path, "ioh", tmp_path_factory.mktemp("export") / "ioh")


def _read(folder) -> tuple[pd.DataFrame, pd.DataFrame]:
    """IOHinspector's overview (one row per run) and its data (logged evaluations, running best)."""
    manager = iohinspector.DataManager()
    manager.add_folder(str(folder))
    return manager.overview.to_pandas(), manager.load(monotonic=True, include_meta_data=True).to_pandas()


def test_iohinspector_reads_every_run_as_in_the_parquet(run, exported):
    overview, data = _read(exported)
    frame = run.load_evaluations()
    traces = {(t.designer, t.seed): t for t in run_traces(frame)}
    assert set(overview["algorithm_name"]) == {"ga", "random"}
    assert set(overview["function_name"]) == {"simple"} and set(overview["function_id"]) == {1}
    assert set(overview["dimension"]) == {25} and set(overview["instance"]) == {1}
    for designer in ("ga", "random"):
        mine = overview[overview["algorithm_name"] == designer].sort_values("run_id")
        assert len(mine) == len(SEEDS)
        for seed, row in zip(SEEDS, mine.itertuples()):  # runs are written in seed order
            trace = traces[(designer, seed)]
            assert row.evals == trace.evaluations == 60
            assert row.best_y == trace.final
            # the best-so-far IOHinspector reconstructs equals the parquet's at every logged evaluation
            logged = data[data["data_id"] == row.data_id]
            parquet = frame[
                (frame["designer"] == designer) & (frame["seed"] == seed) & frame["status"].isin(COUNTED)
            ].set_index("n_evals")
            for evaluations, raw_y in zip(logged["evaluations"], logged["raw_y"]):
                assert raw_y == parquet.loc[evaluations, "best_so_far"] == trace.curve[evaluations - 1]
            improving = [1] + [n + 1 for n in range(1, 60) if trace.curve[n] > trace.curve[n - 1]]
            assert list(logged["evaluations"]) == improving


def test_json_index_records_seed_and_best_body(run, exported):
    index = json.loads((exported / "ga" / "IOHprofiler_f1_simple.json").read_text())
    assert index["maximization"] is True and index["algorithm"]["name"] == "ga"
    runs = index["scenarios"][0]["runs"]
    assert [r["seed"] for r in runs] == list(SEEDS) and index["run_attributes"] == ["seed"]
    frame = run.load_evaluations()
    ok = frame[(frame["designer"] == "ga") & (frame["seed"] == 1) & (frame["status"] == "ok")]
    best = ok.sort_values(["reward", "n_evals"], ascending=[False, True]).iloc[0]
    assert runs[1]["best"]["y"] == best["reward"] and runs[1]["best"]["evals"] == best["n_evals"]
    assert "".join(map(str, runs[1]["best"]["x"])) == best["body"].replace("/", "")


def test_same_lines_as_the_ioh_logger_writes(run, exported, tmp_path):
    """Replay one run's rewards through ioh's own Analyzer logger and compare the files."""
    frame = run.load_evaluations()
    rows = frame[(frame["designer"] == "random") & (frame["seed"] == 2) & frame["status"].isin(COUNTED)].sort_values(
        "n_evals"
    )
    rewards = iter(rows["reward"].tolist())
    ioh.problem.wrap_integer_problem(lambda x: next(rewards), "gdabench_replay", ioh.OptimizationType.MAX, lb=0, ub=4)
    problem = ioh.get_problem("gdabench_replay", instance=1, dimension=25, problem_class=ioh.ProblemClass.INTEGER)
    logger = ioh.logger.Analyzer(root=str(tmp_path), folder_name="reference", algorithm_name="random")
    problem.attach_logger(logger)
    for body in rows["body"]:
        problem([int(c) for c in body.replace("/", "")])
    problem.reset()
    logger.close()
    (reference_json,) = (tmp_path / "reference").glob("*.json")
    reference = json.loads(reference_json.read_text())
    ours = json.loads((exported / "random" / "IOHprofiler_f1_simple.json").read_text())
    assert set(reference) <= set(ours) and reference["attributes"] == ours["attributes"]
    ref_run, our_run = reference["scenarios"][0]["runs"][0], ours["scenarios"][0]["runs"][2]
    assert set(ref_run) <= set(our_run)
    assert (ref_run["evals"], ref_run["best"]["evals"], ref_run["best"]["y"]) == (
        our_run["evals"],
        our_run["best"]["evals"],
        our_run["best"]["y"],
    )

    def block(text: str) -> list[tuple[int, float]]:
        lines = [line.split() for line in text.splitlines() if not line.startswith("evaluations")]
        values = np.maximum.accumulate([float(v) for _, v in lines])  # both readers take the running best
        return [(int(e), round(float(v), 9)) for (e, _), v in zip(lines, values)]  # ioh writes 10 decimals

    (reference_dat,) = (tmp_path / "reference").glob("data_*/*.dat")
    our_dat = (exported / "random" / ours["scenarios"][0]["path"]).read_text().split("evaluations raw_y\n")[3]
    assert block(reference_dat.read_text()) == block(our_dat)
    assert reference_dat.read_text().splitlines()[0] == "evaluations raw_y"


def test_failed_evaluations_are_minus_infinity_until_the_first_success():
    (trace,) = run_traces(table({("e", "a", 0): [math.nan, 2.0, math.nan, 1.0]}))
    assert dat_block(trace) == "evaluations raw_y\n1 -inf\n2 2.0\n4 2.0\n"


def test_several_environments_are_several_problems(run, tmp_path):
    frame = run.load_evaluations()
    other = frame.assign(env="two-peaks", reward=frame["reward"] / 2)
    both = tmp_path / "both"
    shutil.copytree(run.path, both)
    pd.concat([frame, other], ignore_index=True).to_parquet(both / "evaluations.parquet", index=False)
    overview, _ = _read(export_run(both, "ioh"))
    assert set(zip(overview["function_id"], overview["function_name"])) == {(1, "simple"), (2, "two-peaks")}
    assert len(overview) == 2 * 2 * len(SEEDS)


def test_csv_is_the_table(run, tmp_path):
    path = export_run(run.path, "csv", tmp_path / "all.csv")
    back, frame = pd.read_csv(path), run.load_evaluations()
    assert list(back.columns) == list(frame.columns) and len(back) == len(frame)
    np.testing.assert_array_equal(back["reward"], frame["reward"])
    assert list(back["body"]) == list(frame["body"])


def test_cli_export_and_its_errors(run, tmp_path):
    runner = CliRunner()
    ok = runner.invoke(app, ["export", str(run.path), "--format", "ioh", "--out", str(tmp_path / "x")])
    assert ok.exit_code == 0 and (tmp_path / "x" / "ga" / "IOHprofiler_f1_simple.json").is_file()
    default = runner.invoke(app, ["export", str(run.path), "-f", "csv"])
    assert default.exit_code == 0 and (run.path / "export" / "evaluations.csv").is_file()
    (tmp_path / "file").write_text("")
    for args, message in [
        (["--format", "xls"], "unknown export format 'xls'"),
        (["--format", "ioh", "--out", str(tmp_path / "file")], "is a file"),
        (["--format", "csv", "--out", str(tmp_path)], "is a directory"),
    ]:
        result = runner.invoke(app, ["export", str(run.path), *args])
        assert result.exit_code == 2, result.output
        assert (
            result.output.strip().splitlines() == [f"error: {result.output.strip()[7:]}"] and message in result.output
        )
    missing = runner.invoke(app, ["export", str(tmp_path / "nowhere")])
    assert missing.exit_code == 2 and missing.output.startswith("error:")
    with pytest.raises(ConfigError):
        export_run(run.path, "parquet")
