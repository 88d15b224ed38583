"""Quality regression cases: short fixed-seed runs and the key figures they must reproduce.

A speed test cannot notice that a designer got worse; these cases can.  Each case runs one
designer on one environment for a few seeds and records the best reward reached after a few
evaluation counts.  ``tests/test_quality.py`` re-runs every case and compares with the committed
figures in ``tests/expectations/quality-<env>-<designer>.json``.

Add a designer with one line in ``CASES`` (e.g. ``Case("ga")``, or ``Case("gda", tolerance=...,
per_seed=False)`` for a designer whose runs are not bit-identical across machines), then write its
expectations.

Regenerate expectations only deliberately, after a change that is *meant* to alter results
(and say why in the commit message)::

    python tests/support/quality_cases.py            # every case
    python tests/support/quality_cases.py ga cppn    # only these designers

then review ``git diff tests/expectations`` before committing.
"""

from __future__ import annotations

import json
import sys
import tempfile
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from gdabench import Experiment, PluginChoice
from gdabench.running.runner import compare
from gdabench.stats.core import best_so_far_curve

EXPECTATIONS = Path(__file__).resolve().parents[1] / "expectations"


@dataclass(frozen=True)
class Case:
    designer: str
    env: str = "simple"
    budget: int = 200
    seeds: tuple[int, ...] = (0, 1, 2)
    #: evaluation counts at which the best reward so far is recorded
    checkpoints: tuple[int, ...] = (50, 100, 200)
    #: allowed absolute difference per figure (0: the run must be reproduced exactly)
    tolerance: float = 0.0
    #: compare every seed's figure (True) or only the median over seeds (False)
    per_seed: bool = True

    @property
    def name(self) -> str:
        return f"{self.env}-{self.designer}"

    @property
    def path(self) -> Path:
        return EXPECTATIONS / f"quality-{self.name}.json"


CASES = [
    Case("ga"),
    Case("random"),
    Case("cppn", budget=50, checkpoints=(1, 5, 10, 25, 50)),  # reaches 100 within ~50 evaluations: look earlier
    # under the AVX2 pin (gdabench.cpu) gda's runs are the same on any x86-64 CPU, so one seed, exactly, is as
    # strict as three with slack.  gda-fast: four generations.  Faithful gda has no case here: its seed 0 to the
    # first trained generation is checked row for row against the committed reference run, compiled as a
    # full-size run is (tests/test_reference_runs.py), and a case of its own cost another trained generation
    # (39 CPU seconds of a 1,500-second suite)
    Case("gda-fast", budget=100, seeds=(1,), checkpoints=(50, 100)),
]


def measure(case: Case, workdir: Path) -> dict:
    """Run the case and return its key figures: best reward after each checkpoint, per seed and median."""
    experiment = Experiment(
        designers=(PluginChoice(case.designer, {}, case.designer),),
        envs=PluginChoice(case.env, {}, case.env),
        budget=case.budget,
        seeds=case.seeds,
    )
    run = compare(experiment, workdir / case.name)
    table = pd.read_parquet(run.evaluations_path)
    curves = {int(seed): best_so_far_curve(g, case.budget) for seed, g in table.groupby("seed")}
    best_at = {}
    for n in case.checkpoints:
        per_seed = {str(seed): float(curve[n - 1]) for seed, curve in curves.items()}
        best_at[str(n)] = {"per_seed": per_seed, "median": float(np.median(list(per_seed.values())))}
    return {"case": {k: v for k, v in asdict(case).items() if k not in ("tolerance", "per_seed")}, "best_at": best_at}


def main(designers: list[str]) -> None:
    chosen = [c for c in CASES if not designers or c.designer in designers]
    unknown = set(designers) - {c.designer for c in CASES}
    if unknown:
        sys.exit(f"no quality case for {', '.join(sorted(unknown))}; add one to CASES in {__file__}")
    EXPECTATIONS.mkdir(exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        for case in chosen:
            figures = measure(case, Path(tmp))
            case.path.write_text(json.dumps(figures, indent=2, sort_keys=True) + "\n")
            medians = ", ".join(f"{v['median']:g} @ {n}" for n, v in figures["best_at"].items())
            print(f"wrote {case.path} (median best reward after {medians} evaluations)")


if __name__ == "__main__":
    main(sys.argv[1:])
