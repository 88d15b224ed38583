"""benchmarks/figures/controllers_compare.py (issue 56): a measurement split over processes gives the one table."""

from __future__ import annotations

import json

import pytest

from support.scripts import load_script

compare = load_script("figures/controllers_compare")

TOY = ["--tasks", "Walker-v0", "--budgets", "128", "--population", "4"]


def test_ways_and_parts_run_apart_give_the_rows_of_one_run(tmp_path, capsys):
    """Each way recorded in its own call, ``scratch`` in two parts and the 4T reference in a part and then
    whatever it lacks, against the whole measurement in one call: the same rewards for every child, and a row
    only once everything is recorded."""
    whole = tmp_path / "whole.json"
    compare.main([*TOY, "--out", str(tmp_path / "one"), "--json", str(whole)])
    record = tmp_path / "record"
    split = tmp_path / "split.json"
    calls = [["--ways", "scratch", "--part", "0/2"], ["--ways", "scratch,scratch4x", "--part", "1/2"],
             ["--ways", "parent,modular"], ["--ways", "scratch4x"]]
    for i, extra in enumerate(calls):
        capsys.readouterr()
        compare.main([*TOY, "--out", str(tmp_path / f"apart{i}"), "--record", str(record), "--json", str(split),
                      *extra])
        if i < len(calls) - 1:
            said = capsys.readouterr().out
            assert "not yet every child of:" in said and said.rstrip().endswith("scratch4x") and not split.exists()
        # the page's state of a measurement in pieces, and how a finished way compares before the row is printed
        line = compare.progress_markdown(record, ["Walker-v0"], (128,)).splitlines()[2]
        kept = compare.Record(record / "Walker-v0-128.json")
        children = kept.children()
        n = len(children)
        if i == 0:  # half of scratch's children, nothing else
            assert line.startswith(f"| Walker-v0 | 128 | trained (4) | {(n + 1) // 2} / {n} | not yet | not yet |")
            assert line.endswith("| not yet |  |  |")
        if i == 2:  # every way but half the 4T reference: parent and modular against scratch, from the record
            scratch = kept.rewards("scratch", children)
            better = [sum(a > b for a, b in zip(kept.rewards(w, children), scratch)) for w in ("parent", "modular")]
            assert [c.strip().split(" (")[0] for c in line.split("|")[-3:-1]] == [f"{b} / {n}" for b in better]
    one, apart = json.loads(whole.read_text()), json.loads(split.read_text())
    assert one[0]["children"] >= 2 and apart[0]["rewards"] == one[0]["rewards"]
    assert set(one[0]["rewards"]) == {"scratch", "parent", "modular", "scratch4x"}
    kept = json.loads((record / "Walker-v0-128.json").read_text())
    assert set(kept["ways"]["scratch"]) == {"0/2", "1/2"} and len(kept["first"]) == 4
    # the last call, for every child, trained only the children the 1/2 part had not recorded, in one batch
    lacking = kept["children"][0::2]
    assert set(kept["ways"]["scratch4x"]["0/1"]["rewards"]) == set(lacking)
    trained = (tmp_path / "apart3" / "Walker-v0" / "128" / "scratch4x").iterdir()
    assert sorted(p.name for p in trained if p.is_dir()) == sorted(lacking)
    # read back whole, as the page's command does: every child is recorded, whatever the parts, so nothing trains
    again = tmp_path / "again.json"
    compare.main([*TOY, "--out", str(tmp_path / "readback"), "--record", str(record), "--json", str(again)])
    assert json.loads(again.read_text()) == apart and not (tmp_path / "readback").exists()


def test_processes_sharing_a_record_keep_each_others_parts(tmp_path):
    """Two processes on one task and budget (the 200,000 row's parts) each read the record before the other
    writes: each part they add is kept, and generation 0's rewards are the first recorded."""
    path = tmp_path / "Walker-v0-128.json"
    one, two = compare.Record(path), compare.Record(path)
    assert one.first([1.0, 2.0]) == [1.0, 2.0] and two.first([1.0, 3.0]) == [1.0, 2.0]
    one.add("scratch", "0/2", ["a"], [0.5], 100.0)
    two.add("scratch", "1/2", ["b"], [0.7], 300.0)
    kept = compare.Record(path)
    assert kept.rewards("scratch", ["a", "b"]) == [0.5, 0.7] and kept.speed("scratch") == 200.0


def test_a_record_with_other_generation_0_rewards_is_refused(tmp_path):
    record = tmp_path / "record"
    record.mkdir()
    (record / "Walker-v0-128.json").write_text(json.dumps({"first": [0.0, 0.0, 0.0, 0.0], "ways": {}}))
    with pytest.raises(SystemExit, match="generation 0 trained to other rewards"):
        compare.main([*TOY, "--out", str(tmp_path / "out"), "--record", str(record), "--ways", "parent"])


@pytest.mark.parametrize("extra, said", [
    (["--ways", "scratch,bogus"], "--ways: unknown bogus"),
    (["--part", "2/2"], "--part 2/2"),
    (["--part", "0/2"], "leave modular out of --ways"),
])
def test_bad_ways_and_parts_are_refused(tmp_path, capsys, extra, said):
    with pytest.raises(SystemExit) as exit_:
        compare.main([*TOY, "--out", str(tmp_path), *extra])
    assert exit_.value.code == 2 and said in capsys.readouterr().err
