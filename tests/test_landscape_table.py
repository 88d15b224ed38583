"""The script that builds the designers x landscapes table from one suite run per designer."""

from __future__ import annotations

import json
from dataclasses import replace

import pytest

from support.scripts import load_script


@pytest.fixture(scope="module")
def table():
    return load_script("figures/landscape_table")


def test_runs_each_pair_once_and_prints_a_row_per_pair(table, tmp_path, capsys):
    args = [
        "--designers",
        "ga,random",
        "--envs",
        "nk[k=1],target",
        "--seeds",
        "0,1",
        "--budget",
        "40",
        "--population",
        "10",
    ]
    assert table.main([*args, "--root", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    rows = [line for line in out.splitlines() if line.startswith(("| nk", "| target"))]
    assert [r.split(" | ")[2] for r in rows] == ["ga", "random", "ga", "random"]
    assert all("/2 |" in r for r in rows)  # seeds at optimum out of 2
    assert "| target | 100 |" in out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ga", "random"]  # one suite run per designer
    stamp = (tmp_path / "ga" / "evaluations.parquet").stat().st_mtime_ns
    assert table.main([*args, "--root", str(tmp_path)]) == 0  # complete runs are not redone
    assert (tmp_path / "ga" / "evaluations.parquet").stat().st_mtime_ns == stamp
    assert capsys.readouterr().out == out


def test_seeds_added_later_count_in_the_designers_row(table, tmp_path, capsys):
    from gdabench import Experiment
    from gdabench.running.runner import compare

    base = [
        "--designers",
        "random",
        "--envs",
        "target",
        "--budget",
        "20",
        "--population",
        "10",
        "--root",
        str(tmp_path),
    ]
    assert table.main([*base, "--seeds", "0"]) == 0
    first = Experiment.from_json(json.loads((tmp_path / "random" / "run.json").read_text())["config"])
    compare(replace(first, seeds=(1, 2)), tmp_path / "random.seeds-1-2")  # where earlier versions put added seeds
    assert table.main([*base, "--seeds", "0..3"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["random", "random.seeds-1-2"]
    assert json.loads((tmp_path / "random" / "run.json").read_text())["config"]["seeds"] == [0, 3]
    row = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| target")][-1]
    assert row.split(" | ")[3] == "0/4"  # seeds at optimum, out of all four seeds


def test_refuses_to_mix_settings_and_reports_unknown_designers(table, tmp_path, capsys):
    base = ["--envs", "target", "--seeds", "0", "--population", "10", "--root", str(tmp_path)]
    assert table.main(["--designers", "random", "--budget", "20", *base]) == 0
    assert table.main(["--designers", "random", "--budget", "30", *base]) == 2
    assert "other settings" in capsys.readouterr().err
    assert table.main(["--designers", "random,nosuch", "--budget", "20", *base]) == 2
    assert "unknown designer 'nosuch'" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("raised", "code", "fragment"),
    [
        ("Terminated", 143, "terminated (SIGTERM); the runs so far are kept, and the same command resumes them"),
        ("KeyboardInterrupt", 130, "interrupted; the runs so far are kept"),
        ("TrialError", 1, "a trial failed"),
    ],
)
def test_a_run_stopped_or_failed_is_one_line_with_gdabench_exit_codes(
    table, tmp_path, capsys, monkeypatch, raised, code, fragment
):
    from gdabench import errors

    def stop(*args, **kwargs):
        raise (KeyboardInterrupt if raised == "KeyboardInterrupt" else getattr(errors, raised))("a trial failed")

    monkeypatch.setattr(table, "ensure_runs", stop)
    assert table.main(["--designers", "random", "--envs", "target", "--seeds", "0", "--root", str(tmp_path)]) == code
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and fragment in lines[0], lines


def test_an_interrupted_run_is_finished_before_seeds_are_added(table, tmp_path, monkeypatch):
    import sys

    from gdabench import Experiment
    from gdabench.running.runner import compare

    base = [
        "--designers",
        "random",
        "--envs",
        "target",
        "--budget",
        "20",
        "--population",
        "10",
        "--root",
        str(tmp_path),
    ]
    assert table.main([*base, "--seeds", "0"]) == 0
    first = Experiment.from_json(json.loads((tmp_path / "random" / "run.json").read_text())["config"])
    compare(replace(first, seeds=(1,)), tmp_path / "random.seeds-1")
    meta = tmp_path / "random.seeds-1" / "run.json"
    meta.write_text(json.dumps({**json.loads(meta.read_text()), "status": "interrupted"}))
    calls = []
    monkeypatch.setattr(
        sys.modules[table.ensure_runs.__module__],
        "compare",
        lambda experiment, out, **kw: calls.append((out.name, experiment.seeds)),
    )
    table.main([*base, "--seeds", "0..2"])
    assert calls == [("random.seeds-1", (1,)), ("random", (0, 2))]
