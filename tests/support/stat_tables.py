"""Hand-made evaluations tables for the statistics and export tests."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
from typer.testing import CliRunner

from gdabench.cli import app
from gdabench.results import RunDirectory


def table(runs: dict[tuple[str, str, int], list[float]], *, population: int = 2, run_id: str = "r1") -> pd.DataFrame:
    """A minimal evaluations table: one row per evaluation; NaN rewards are failed evaluations."""
    rows = []
    for (env, designer, seed), rewards in runs.items():
        for n, reward in enumerate(rewards, start=1):
            failed = isinstance(reward, float) and math.isnan(reward)
            rows.append(
                {
                    "run_id": run_id, "designer": designer, "env": env, "controller": "", "population": population,
                    "budget": len(rewards), "seed": seed, "generation": (n - 1) // population,
                    "index": (n - 1) % population,
                    "body": "44444/44444/44444/44444/44444", "body_hash": f"{designer}-{seed}-{n}", "reward": reward,
                    "status": "error" if failed else "ok", "n_evals": n, "best_so_far": np.nan, "elapsed_seconds": 0.0,
                }
            )  # fmt: skip
    return pd.DataFrame(rows)


def small_run(out: Path, env: str, seeds: str, budget: int = 60, designers: str = "ga,random") -> RunDirectory:
    """A real run made through the command line (no report): `compare --designers ... --seeds ...`."""
    args = [
        "compare",
        "--designers",
        designers,
        "--env",
        env,
        "--seeds",
        seeds,
        "--budget",
        str(budget),
        "--out",
        str(out),
        "--quiet",
        "--no-report",
    ]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    return RunDirectory.open(out)
