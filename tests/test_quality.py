"""Quality regression: fixed-seed short runs must reproduce their committed key figures.

An algorithmic change that makes a designer find worse (or different) bodies fails here.  If the
change is intended, regenerate the expectations deliberately (see ``tests/support/quality_cases.py``).
"""

from __future__ import annotations

import json
from dataclasses import asdict

import pytest

from support.quality_cases import CASES, Case, measure


@pytest.mark.parametrize("case", CASES, ids=lambda c: c.name)
def test_key_figures_match_expectations(case: Case, tmp_path):
    assert case.path.is_file(), (
        f"no expectations for {case.name}: run `python tests/support/quality_cases.py {case.designer}`"
        " and commit the file"
    )
    expected = json.loads(case.path.read_text())
    settings = {k: v for k, v in asdict(case).items() if k not in ("tolerance", "per_seed")}
    assert expected["case"] == json.loads(json.dumps(settings)), (
        f"{case.path.name} was written for other settings; regenerate it"
    )
    got = measure(case, tmp_path)["best_at"]
    regenerate = (
        f"if this change is intended, regenerate with `python tests/support/quality_cases.py {case.designer}`"
        " and commit the diff"
    )
    for n, want in expected["best_at"].items():
        pairs = [("median", got[n]["median"], want["median"])]
        if case.per_seed:
            pairs += [(f"seed {s}", got[n]["per_seed"][s], v) for s, v in want["per_seed"].items()]
        for what, value, target in pairs:
            direction = "worse" if value < target else "better"
            assert abs(value - target) <= case.tolerance, (
                f"{case.designer} on {case.env}: best reward after {n} evaluations ({what}) is {value:g}, "
                f"expected {target:g} "
                f"({direction}); {regenerate}"
            )
