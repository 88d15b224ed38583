"""The committed reference runs are what the code gives: the same command and seed, the same rows."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
#: what a row says about the design process (not when or how fast it ran)
ROW = ["designer", "seed", "generation", "body", "reward", "status"]


def test_ga_and_cppn_give_the_committed_simple_reference_rows(tmp_path):
    """``gda`` takes minutes per seed, ``ga`` and ``cppn`` a second: two of the reference run's seeds of these two
    are run again with its settings. A change that alters them (seeding, selection, encoding, the harness) must
    come with the reference run made again (``benchmarks/reference_results.py``), whose tables the docs and the
    README show."""
    import gdabench

    committed = pd.read_parquet(ROOT / "results" / "reference" / "simple" / "evaluations.parquet")
    seeds = [0, 7]
    run = gdabench.compare("ga,cppn", "simple", seeds=seeds, budget=1000, population=25, out=tmp_path / "run",
                           progress=False)  # fmt: skip
    got = run.evaluations()[ROW].sort_values(ROW[:4], kind="stable").reset_index(drop=True)
    want = committed[committed["designer"].isin(["ga", "cppn"]) & committed["seed"].isin(seeds)][ROW]
    want = want.sort_values(ROW[:4], kind="stable").reset_index(drop=True)
    assert len(want) == 2 * len(seeds) * 1000
    pd.testing.assert_frame_equal(got, want, check_dtype=False, check_categorical=False)
